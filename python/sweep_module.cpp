// The `sweep` Python module (pybind11): scenes run whole or stepped, their state and contacts as
// numpy arrays, and the Lagrangian layer of a URDF model. docs/python.md is its guide; every
// input error is raised as sweep.InputError (a ValueError) with the command line's message.
#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "apps/sweep/run.hpp"
#include "apps/sweep/scene_file.hpp"
#include "contact/detection.hpp"
#include "framework/configuration.hpp"
#include "framework/crba.hpp"
#include "framework/dynamics.hpp"
#include "framework/energy.hpp"
#include "framework/error.hpp"
#include "framework/jacobian.hpp"
#include "framework/kinematics.hpp"
#include "framework/rnea.hpp"
#include "framework/urdf_import.hpp"
#include "integrators/time_stepper.hpp"

namespace py = pybind11;

namespace sweep {
namespace {

// nlohmann JSON to Python objects (the summary, as summary.json holds it)
py::object toPython(const nlohmann::ordered_json& j) {
  if (j.is_object()) {
    py::dict d;
    for (auto it = j.begin(); it != j.end(); ++it) d[py::str(it.key())] = toPython(it.value());
    return std::move(d);
  }
  if (j.is_array()) {
    py::list l;
    for (const auto& x : j) l.append(toPython(x));
    return std::move(l);
  }
  if (j.is_boolean()) return py::bool_(j.get<bool>());
  if (j.is_number_integer()) return py::int_(j.get<long long>());
  if (j.is_number()) return py::float_(j.get<double>());
  if (j.is_string()) return py::str(j.get<std::string>());
  return py::none();
}

// A scene's overrides as `--set` takes them: {"scheme.name": "catching-up", "time.step": 1e-4}
std::vector<std::string> overrideList(const std::optional<py::dict>& overrides) {
  std::vector<std::string> out;
  if (!overrides) return out;
  for (const auto& [key, value] : *overrides) {
    std::string text;
    if (py::isinstance<py::bool_>(value))
      text = value.cast<bool>() ? "true" : "false";
    else if (py::isinstance<py::float_>(value))
      text = exactNumber(value.cast<double>());
    else
      text = py::str(value).cast<std::string>();
    out.push_back(py::str(key).cast<std::string>() + "=" + text);
  }
  return out;
}

// A scene is a file's path, or a dict that holds what a scene file would (its text is the
// dict as JSON, which is YAML; relative file names are taken from base_dir).
SceneFile loadScene(const py::object& scene, const std::optional<py::dict>& overrides,
                    const std::vector<std::string>& settings_files,
                    const std::optional<std::string>& scheme, std::optional<double> dt,
                    std::optional<double> t_end, const std::string& base_dir = ".") {
  SceneFile file;
  if (py::isinstance<py::dict>(scene)) {
    // numpy arrays and scalars go in as lists and numbers
    const py::cpp_function plain([](const py::object& value) -> py::object {
      if (py::hasattr(value, "tolist")) return value.attr("tolist")();
      throw InputError("scene dict: " + py::repr(value).cast<std::string>() +
                       " is not a number, string, list or dict");
    });
    const std::string text = py::module_::import("json")
                                 .attr("dumps")(scene, py::arg("default") = plain)
                                 .cast<std::string>();
    file = loadSceneText(text, base_dir + "/<scene dict>", overrideList(overrides), settings_files);
  } else {
    file =
        loadSceneFile(py::str(scene).cast<std::string>(), overrideList(overrides), settings_files);
  }
  if (scheme) file.run.scheme.scheme = schemeFromName(*scheme);
  if (dt) {
    if (!(*dt > 0.0) || !std::isfinite(*dt))
      throw InputError("dt: must be > 0, got " + exactNumber(*dt));
    file.run.scheme.h = *dt;
  }
  if (t_end) {
    if (!(*t_end > 0.0) || !std::isfinite(*t_end))
      throw InputError("t_end: must be > 0, got " + exactNumber(*t_end));
    file.run.t_end = *t_end;
  }
  file.run.scheme.validate();
  stepCount(0.0, file.run.t_end, file.run.scheme.h);  // as `sweep check` and `run` count it
  return file;
}

// Runs `work` on a thread of its own with the GIL released, while this thread checks for
// Ctrl-C (Python's signal handlers run on the main thread only): on one, `stop` is set, the
// work finishes its step and KeyboardInterrupt is raised.
template <class Work>
void runInterruptibly(std::atomic<bool>& stop, Work&& work) {
  std::mutex mutex;
  std::condition_variable done_signal;
  bool done = false;
  std::exception_ptr failure;
  std::thread worker([&] {
    try {
      work();
    } catch (...) {
      failure = std::current_exception();
    }
    std::lock_guard<std::mutex> lock(mutex);
    done = true;
    done_signal.notify_one();
  });
  bool interrupted = false;
  {
    py::gil_scoped_release release;
    std::unique_lock<std::mutex> lock(mutex);
    while (!done_signal.wait_for(lock, std::chrono::milliseconds(50), [&] { return done; })) {
      lock.unlock();
      {
        py::gil_scoped_acquire acquire;
        if (PyErr_CheckSignals() != 0) {
          interrupted = true;
          stop = true;
        }
      }
      lock.lock();
    }
  }
  worker.join();
  if (failure) std::rethrow_exception(failure);
  if (interrupted) throw py::error_already_set();
}

// the names and values of stats.csv's columns (visitStepStats), timings included
py::dict stepStatsDict(const StepStats& s) {
  py::dict d;
  visitStepStats(s, true, [&](const char* name, const auto& value) {
    if constexpr (std::is_same_v<std::decay_t<decltype(value)>, SolverStatus>)
      d[name] = enumName(value);
    else
      d[name] = value;
  });
  return d;
}

// A scene stepped from Python: the scene file, its model and the stepper, owned together.
SceneFile withEquations(SceneFile file, const std::vector<EquationSystem>& systems,
                        const std::vector<ConstraintFunction>& constraints) {
  file.spec.systems = systems;
  file.spec.constraints = constraints;
  return file;
}

class Simulation {
 public:
  Simulation(const py::object& scene, const std::optional<py::dict>& overrides,
             const std::vector<std::string>& settings_files,
             const std::optional<std::string>& scheme, std::optional<double> dt,
             const std::string& base_dir, const std::vector<EquationSystem>& systems,
             const std::vector<ConstraintFunction>& constraints)
      : file_(withEquations(
            loadScene(scene, overrides, settings_files, scheme, dt, std::nullopt, base_dir),
            systems, constraints)),
        scene_(std::make_unique<Scene>(buildSceneFile(file_))),
        stepper_(std::make_unique<TimeStepper>(scene_->model, scene_->cmodel, file_.run.scheme,
                                               scene_->forces)) {
    stepper_->reset(0.0, scene_->q0, scene_->v0);
  }

  // a model built in code: its settings, model and contact model, started at (q0, v0)
  Simulation(SceneFile file, std::unique_ptr<Scene> scene)
      : file_(std::move(file)),
        scene_(std::move(scene)),
        stepper_(std::make_unique<TimeStepper>(scene_->model, scene_->cmodel, file_.run.scheme,
                                               scene_->forces)) {
    stepper_->reset(0.0, scene_->q0, scene_->v0);
  }

  py::dict step() {
    const StepStats* s = nullptr;
    {
      py::gil_scoped_release release;
      s = &stepper_->step();
    }
    checkFinite();
    if (divergedSolve(*s)) throw std::runtime_error(divergedSolveMessage(*s));
    return stepStatsDict(*s);
  }

  // Steps until t_end (the scene's end time by default); callback(sim) after each step, which
  // may return False to stop. Returns the number of steps.
  long run(std::optional<double> t_end, const std::optional<py::function>& callback) {
    const double end = t_end ? *t_end : file_.run.t_end;
    const long steps = stepCount(stepper_->time(), end, file_.run.scheme.h);
    long done = 0;
    if (callback) {
      for (; done < steps; ++done) {
        step();
        if (PyErr_CheckSignals() != 0) throw py::error_already_set();
        const py::object keep_going =
            (*callback)(py::cast(this, py::return_value_policy::reference));
        if (!keep_going.is_none() && !keep_going.cast<bool>()) return done + 1;
      }
      return done;
    }
    std::atomic<bool> stop{false};
    runInterruptibly(stop, [&] {
      for (; done < steps && !stop.load(); ++done) {
        if (divergedSolve(stepper_->step())) return;
        if (!stepper_->q().allFinite() || !stepper_->v().allFinite()) return;
      }
    });
    checkFinite();
    if (divergedSolve(stepper_->stats()))
      throw std::runtime_error(divergedSolveMessage(stepper_->stats()));
    return done;
  }

  // checked as a saved state is: a finite time, coordinates and velocities within their
  // bounds, unit quaternions, joints within their limits and couplings, no deep overlap
  void setState(double t, const VectorX& q, const VectorX& v) {
    const Model& model = scene_->model;
    if (!std::isfinite(t)) throw InputError("set_state: t must be finite, got " + exactNumber(t));
    if (q.size() != model.nq || v.size() != model.nv)
      throw InputError("set_state: q and v must have nq = " + std::to_string(model.nq) +
                       " and nv = " + std::to_string(model.nv) + " entries");
    for (Eigen::Index i = 0; i < q.size(); ++i)
      if (!(std::abs(q[i]) <= kMaxCoordinate))
        throw InputError("set_state: q[" + std::to_string(i) + "] = " + exactNumber(q[i]) +
                         " must be finite and within " + formatValue(kMaxCoordinate) +
                         " (m or rad)");
    for (Eigen::Index i = 0; i < v.size(); ++i)
      if (!(std::abs(v[i]) <= kMaxSpeed))
        throw InputError("set_state: v[" + std::to_string(i) + "] = " + exactNumber(v[i]) +
                         " must be finite and within " + formatValue(kMaxSpeed) +
                         " (m/s or rad/s)");
    checkState(*scene_, SavedState{t, q, v}, file_.spec.max_initial_overlap, "set_state");
    stepper_->reset(t, q, v);
  }

  // contacts of the last step: witness points, normals, gaps, impulses, body indices
  py::dict contacts() const {
    const auto& contacts = stepper_->contactData().contacts;
    const auto& impulses = stepper_->impulses();
    const py::ssize_t n = static_cast<py::ssize_t>(contacts.size());
    py::array_t<double> point_a({n, py::ssize_t{3}}), point_b({n, py::ssize_t{3}}),
        normal({n, py::ssize_t{3}}), impulse({n, py::ssize_t{3}}), gap(n);
    py::array_t<int> body_a(n), body_b(n);
    auto pa = point_a.mutable_unchecked<2>(), pb = point_b.mutable_unchecked<2>(),
         nm = normal.mutable_unchecked<2>(), im = impulse.mutable_unchecked<2>();
    auto g = gap.mutable_unchecked<1>();
    auto ba = body_a.mutable_unchecked<1>(), bb = body_b.mutable_unchecked<1>();
    for (py::ssize_t c = 0; c < n; ++c) {
      const Contact& k = contacts[c];
      const Vector3 P =
          c < static_cast<py::ssize_t>(impulses.size()) ? impulses[c] : Vector3::Zero();
      for (int i = 0; i < 3; ++i) {
        pa(c, i) = k.point_a[i];
        pb(c, i) = k.point_b[i];
        nm(c, i) = k.normal[i];
        im(c, i) = P[i];
      }
      g(c) = k.gap;
      ba(c) = k.body_a.kind == BodyRef::Kind::Dynamic ? k.body_a.index : -1;
      bb(c) = k.body_b.kind == BodyRef::Kind::Dynamic ? k.body_b.index : -1;
    }
    // the bodies' names: a dynamic body's, a driven one's, or a fixed geometry's own
    const Model& model = scene_->model;
    const ContactModel& cmodel = scene_->cmodel;
    auto nameOf = [&](const BodyRef& ref, int geometry) -> std::string {
      if (ref.kind == BodyRef::Kind::Dynamic) return model.bodies[ref.index].name;
      if (ref.kind == BodyRef::Kind::Driven) return model.driven_bodies[ref.index].name;
      return cmodel.geometries[geometry].name;
    };
    py::list name_a, name_b;
    for (py::ssize_t c = 0; c < n; ++c) {
      name_a.append(nameOf(contacts[c].body_a, contacts[c].key.geometry_a));
      name_b.append(nameOf(contacts[c].body_b, contacts[c].key.geometry_b));
    }
    py::dict d;
    d["name_a"] = name_a;
    d["name_b"] = name_b;
    d["point_a"] = point_a;
    d["point_b"] = point_b;
    d["normal"] = normal;
    d["gap"] = gap;
    d["impulse"] = impulse;
    d["body_a"] = body_a;
    d["body_b"] = body_b;
    return d;
  }

  // every bounded shape at the current state, in world coordinates (planes are left out)
  py::list shapes() {
    const Model& model = scene_->model;
    const ContactModel& cmodel = scene_->cmodel;
    forwardKinematics(model, data_, stepper_->q(), stepper_->v());
    updateGeometryPoses(model, data_, cmodel, stepper_->time(), cdata_);
    py::list out;
    for (int g = 0; g < cmodel.size(); ++g) {
      const Geometry& geometry = cmodel.geometries[g];
      const Shape& shape = geometry.shape;
      if (isUnbounded(shape)) continue;
      const bool driven = geometry.body.kind == BodyRef::Kind::Driven;
      if (driven && !model.driven_bodies[geometry.body.index].presentAt(stepper_->time())) continue;
      const Pose& pose = cdata_.geometry_pose[g];
      py::dict d;
      d["name"] = geometry.name;
      d["type"] = shapeTypeName(shape.type);
      d["kind"] = geometry.body.kind == BodyRef::Kind::Dynamic ? "dynamic"
                  : driven                                     ? "driven"
                                                               : "world";
      d["body"] = geometry.body.kind == BodyRef::Kind::Dynamic ? geometry.body.index : -1;
      d["position"] = Vector3(pose.translation);
      d["rotation"] = Matrix3(pose.rotation);
      d["radius"] = shape.radius;
      if (shape.type == ShapeType::Segment) {
        d["start"] = Vector3(pose.apply(shape.segment_start));
        d["end"] = Vector3(pose.apply(shape.segment_end));
      }
      if (shape.type == ShapeType::Box) d["size"] = Vector3(2.0 * shape.half_extents);
      if (shape.type == ShapeType::Cylinder || shape.type == ShapeType::Capsule)
        d["length"] = shape.length;
      if (shape.type == ShapeType::Polygon) {
        MatrixX vertices(shape.vertices.size(), 3);
        for (std::size_t k = 0; k < shape.vertices.size(); ++k)
          vertices.row(k) = pose.apply(shape.vertices[k]).transpose();
        d["vertices"] = vertices;
      }
      out.append(d);
    }
    return out;
  }

  // the body whose `field` (its name, its joint's name) is `name`; InputError "<missing> named
  // 'NAME'" when there is none
  int bodyNamed(std::string Body::*field, const std::string& name, const char* missing) const {
    const std::vector<Body>& bodies = scene_->model.bodies;
    for (std::size_t b = 0; b < bodies.size(); ++b)
      if (bodies[b].*field == name) return static_cast<int>(b);
    throw InputError(std::string(missing) + " named '" + name + "'");
  }

  // a body of the model at the current state: its frame's world pose, the world velocity of
  // its origin and its world angular velocity
  py::dict body(const std::string& name) {
    const Model& model = scene_->model;
    const int index = bodyNamed(&Body::name, name, "body: the scene has no dynamic body");
    forwardKinematics(model, data_, stepper_->q(), stepper_->v());
    const Pose& pose = data_.world_pose[index];
    const Vector6& twist = data_.velocity[index];  // body coordinates (w, v)
    py::dict d;
    d["position"] = Vector3(pose.translation);
    d["rotation"] = Matrix3(pose.rotation);
    d["velocity"] = Vector3(pose.rotation * twist.tail<3>());
    d["angular_velocity"] = Vector3(pose.rotation * twist.head<3>());
    return d;
  }

  // a joint's coordinates and velocities, by its name, and where they sit in q and v
  py::dict joint(const std::string& name) {
    const Body& b =
        scene_->model.bodies[bodyNamed(&Body::joint_name, name, "joint: the scene has no joint")];
    py::dict d;
    d["q"] = VectorX(stepper_->q().segment(b.q_index, b.joint.nq()));
    d["v"] = VectorX(stepper_->v().segment(b.v_index, b.joint.nv()));
    d["q_index"] = b.q_index;
    d["v_index"] = b.v_index;
    d["body"] = b.name;
    return d;
  }

  const TimeStepper& stepper() const { return *stepper_; }
  TimeStepper& stepper() { return *stepper_; }
  const SceneFile& file() const { return file_; }
  const Scene& scene() const { return *scene_; }

 private:
  void checkFinite() const {
    if (!stepper_->q().allFinite() || !stepper_->v().allFinite())
      throw std::runtime_error("the state stopped being finite at t = " +
                               exactNumber(stepper_->time()));
  }

  SceneFile file_;
  std::unique_ptr<Scene> scene_;
  std::unique_ptr<TimeStepper> stepper_;
  Data data_{scene_->model};  // shapes(): its own kinematics, the stepper's untouched
  ContactData cdata_{scene_->model, scene_->cmodel};
};

// Python callables as the C++ functions of a system or constraint: each call takes the GIL
// (the stepper runs without it) and checks what comes back.
// What a callable returned as a matrix or vector (a number is a 1 x 1 one).
template <class Result>
Result numericResult(const py::object& r, const std::string& who) {
  try {
    if (py::isinstance<py::float_>(r) || py::isinstance<py::int_>(r))
      return Result::Constant(1, 1, r.cast<double>());
    return r.cast<Result>();
  } catch (const py::cast_error&) {
    throw std::runtime_error(who + " must return " +
                             (Result::ColsAtCompileTime == 1 ? "a vector" : "a matrix") +
                             " of numbers");
  }
}
MatrixX matrixResult(const py::object& r, const std::string& who) {
  return numericResult<MatrixX>(r, who);
}
VectorX vectorResult(const py::object& r, const std::string& who) {
  return numericResult<VectorX>(r, who);
}

EquationSystem systemFromPython(const std::string& name, int nq, int nv, py::function mass,
                                std::optional<py::function> forces,
                                std::optional<py::function> integrate,
                                std::optional<py::function> potential, bool constant_mass,
                                std::optional<VectorX> reference) {
  EquationSystem s;
  s.name = name;
  s.nq = nq;
  s.nv = nv;
  s.constant_mass = constant_mass;
  if (reference) s.reference = *reference;
  const std::string who = "system '" + name + "': ";
  s.mass = [mass, who](const VectorX& q) {
    py::gil_scoped_acquire gil;
    return matrixResult(mass(q), who + "mass(q)");
  };
  if (forces)
    s.forces = [f = *forces, who](double t, const VectorX& q, const VectorX& v) {
      py::gil_scoped_acquire gil;
      return vectorResult(f(t, q, v), who + "forces(t, q, v)");
    };
  if (integrate)
    s.integrate = [f = *integrate, who](const VectorX& q, const VectorX& dv) {
      py::gil_scoped_acquire gil;
      return vectorResult(f(q, dv), who + "integrate(q, dv)");
    };
  if (potential)
    s.potential = [f = *potential](const VectorX& q) {
      py::gil_scoped_acquire gil;
      return f(q).cast<double>();
    };
  return s;
}

ConstraintFunction constraintFromPython(const std::string& name, py::function gap,
                                        py::function normal, std::optional<py::function> tangent,
                                        std::optional<py::function> tangent2, double friction,
                                        double restitution, bool bilateral) {
  ConstraintFunction c;
  c.name = name;
  c.bilateral = bilateral;
  c.friction = friction;
  c.restitution = restitution;
  const std::string who = "constraint '" + name + "': ";
  c.gap = [gap](const VectorX& q) {
    py::gil_scoped_acquire gil;
    return gap(q).cast<double>();
  };
  auto direction = [who](py::function f, const char* what) {
    return [f, who, what](const VectorX& q) {
      py::gil_scoped_acquire gil;
      return vectorResult(f(q), who + what);
    };
  };
  c.normal = direction(normal, "normal(q)");
  if (tangent) c.tangent = direction(*tangent, "tangent(q)");
  if (tangent2) c.tangent2 = direction(*tangent2, "tangent2(q)");
  return c;
}

// A read-only numpy view of a vector the owner keeps (no copy).
py::array view(const VectorX& x, py::handle owner) {
  py::array a(py::dtype::of<double>(), {x.size()}, {sizeof(double)}, x.data(), owner);
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

// The Lagrangian layer of a model (URDF): each call works on its own copy of the state, so no
// result depends on an earlier call.
class Dynamics {
 public:
  using Input = Eigen::Ref<const VectorX>;

  explicit Dynamics(Model model)
      : model_(std::move(model)),
        data_(model_),
        dof_names_(model_.dofNames()),
        q_(model_.nq),
        v_(model_.nv),
        a_(model_.nv) {}

  const Model& model() const { return model_; }
  const std::vector<std::string>& dofNames() const { return dof_names_; }
  int dofIndex(const std::string& name) const { return model_.dofIndex(name); }

  // Inputs are numpy arrays read in place (Eigen::Ref) and copied into buffers sized once;
  // results are copied out (no view of Data, which the next call changes).
  MatrixX massMatrix(Input q) {
    crba(model_, data_, takeQ(q));
    return denseMassMatrix(model_, data_);
  }
  VectorX rneaForces(Input q, Input v, Input a) {
    return rnea(model_, data_, takeQ(q), take(v, "v", v_), take(a, "a", a_));
  }
  VectorX bias(Input q, Input v) { return biasForces(model_, data_, takeQ(q), take(v, "v", v_)); }
  VectorX gravity(Input q) { return gravityForces(model_, data_, takeQ(q)); }
  VectorX coriolis(Input q, Input v) {
    return coriolisForces(model_, data_, takeQ(q), take(v, "v", v_));
  }
  VectorX toBodyFrame(Input q, Input v) {
    return velocityToBodyFrame(model_, takeQ(q), take(v, "v", v_));
  }
  VectorX fromBodyFrame(Input q, Input v) {
    return velocityFromBodyFrame(model_, takeQ(q), take(v, "v_body", v_));
  }
  VectorX acceleration(Input q, Input v, Input tau) {
    return forwardDynamics(model_, data_, takeQ(q), take(v, "v", v_), take(tau, "tau", a_));
  }
  double kinetic(Input q, Input v) {
    return kineticEnergy(model_, data_, takeQ(q), take(v, "v", v_));
  }
  double potential(Input q) { return potentialEnergy(model_, data_, takeQ(q)); }
  std::pair<Matrix3, Vector3> bodyPose(Input q, const std::string& body) {
    const int b = model_.bodyIndex(body);
    forwardKinematics(model_, data_, takeQ(q));
    return {data_.world_pose[b].rotation, data_.world_pose[b].translation};
  }
  Vector3 com(Input q) { return centerOfMass(model_, data_, takeQ(q)); }
  MatrixX jacobian(Input q, const std::string& body, const Vector3& point) {
    const int b = model_.bodyIndex(body);
    if (!point.allFinite()) throw InputError("point: must be finite");
    forwardKinematics(model_, data_, takeQ(q));
    Eigen::Matrix<double, 6, Eigen::Dynamic> J =
        Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, model_.nv);
    Pose frame;
    frame.translation = point;
    frameJacobian(model_, data_, b, frame, J);
    return J;
  }

 private:
  const VectorX& takeQ(Input q) {
    if (q.size() != model_.nq)
      throw InputError("q: must have " + std::to_string(model_.nq) + " entries, got " +
                       std::to_string(q.size()));
    if (!q.allFinite()) throw InputError("q: must be finite");
    q_ = q;
    return q_;
  }
  const VectorX& take(Input x, const char* name, VectorX& buffer) const {
    if (x.size() != model_.nv)
      throw InputError(std::string(name) + ": must have " + std::to_string(model_.nv) +
                       " entries, got " + std::to_string(x.size()));
    if (!x.allFinite()) throw InputError(std::string(name) + ": must be finite");
    buffer = x;
    return buffer;
  }

  Model model_;
  Data data_;
  std::vector<std::string> dof_names_;
  VectorX q_, v_, a_;
};

}  // namespace
}  // namespace sweep

PYBIND11_MODULE(sweep, m) {
  using namespace sweep;
  m.doc() = "Sweep: nonsmooth contact dynamics of multibody systems (docs/python.md)";
  m.attr("__version__") = "0.1.0";
  static py::exception<InputError> input_error(m, "InputError", PyExc_ValueError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const InputError& e) {
      input_error(e.what());
    }
  });

  m.def(
      "run",
      [](const py::object& scene, const std::optional<std::string>& out,
         const std::optional<py::dict>& overrides, const std::vector<std::string>& settings_files,
         const std::optional<std::string>& scheme, std::optional<double> dt,
         std::optional<double> t_end, const std::string& base_dir) {
        const SceneFile file =
            loadScene(scene, overrides, settings_files, scheme, dt, t_end, base_dir);
        const Scene built = buildSceneFile(file);
        RunOptions options;
        options.out_dir = out.value_or("");
        std::atomic<bool> stop{false};
        options.stop = &stop;
        RunSummary summary;
        runInterruptibly(stop, [&] { summary = runScene(built, file.run, options); });
        // as `sweep run` fails (its outputs written): a RuntimeError, not a summary to overlook
        if (!summary.failure.empty()) throw RunawayError(summary.failure);
        return toPython(summaryJson(summary));
      },
      py::arg("scene"), py::arg("out") = py::none(), py::arg("overrides") = py::none(),
      py::arg("settings_files") = std::vector<std::string>{}, py::arg("scheme") = py::none(),
      py::arg("dt") = py::none(), py::arg("t_end") = py::none(), py::arg("base_dir") = ".",
      "Run a scene (a file's path, or a dict of what the file would hold) as `sweep run` does "
      "(writing its results to `out` when given) and "
      "return the summary as summary.json holds it. overrides: {path: value}, as --set.");

  py::class_<EquationSystem>(m, "System",
                             "A system given by its equations: M(q) dv/dt = forces(t, q, v) "
                             "+ constraint impulses (docs/python.md)")
      .def(py::init(&systemFromPython), py::arg("name"), py::arg("nq"), py::arg("nv"),
           py::arg("mass"), py::arg("forces") = py::none(), py::arg("integrate") = py::none(),
           py::arg("potential") = py::none(), py::arg("constant_mass") = false,
           py::arg("reference") = py::none())
      .def_readonly("name", &EquationSystem::name)
      .def_readonly("nq", &EquationSystem::nq)
      .def_readonly("nv", &EquationSystem::nv);
  py::class_<ConstraintFunction>(m, "Constraint",
                                 "A constraint gap(q) >= 0 (bilateral: = 0) with its normal "
                                 "W_N(q) (dgap/dt = W_N . v) and, for friction, tangent W_T(q)")
      .def(py::init(&constraintFromPython), py::arg("name"), py::arg("gap"), py::arg("normal"),
           py::arg("tangent") = py::none(), py::arg("tangent2") = py::none(),
           py::arg("friction") = 0.0, py::arg("restitution") = 0.0, py::arg("bilateral") = false)
      .def_readonly("name", &ConstraintFunction::name);

  py::class_<Simulation>(m, "Simulation", "A scene stepped from Python.")
      .def(py::init<const py::object&, const std::optional<py::dict>&,
                    const std::vector<std::string>&, const std::optional<std::string>&,
                    std::optional<double>, const std::string&, const std::vector<EquationSystem>&,
                    const std::vector<ConstraintFunction>&>(),
           py::arg("scene"), py::arg("overrides") = py::none(),
           py::arg("settings_files") = std::vector<std::string>{}, py::arg("scheme") = py::none(),
           py::arg("dt") = py::none(), py::arg("base_dir") = ".",
           py::arg("systems") = std::vector<EquationSystem>{},
           py::arg("constraints") = std::vector<ConstraintFunction>{},
           "A scene (a file's path, or a dict of what the file would hold; relative file names "
           "from base_dir) ready to step; systems by their equations and constraints by "
           "functions join its bodies (their coordinates after the bodies', at their reference, "
           "at rest; set_state sets others)")
      .def_static(
          "from_equations",
          [](const std::vector<EquationSystem>& systems,
             const std::vector<ConstraintFunction>& constraints, const VectorX& q0,
             const VectorX& v0, double dt, double t_end, const std::string& scheme, int dimension,
             const std::string& normal_law) {
            ModelBuilder builder("equations");
            for (const EquationSystem& s : systems) builder.addSystem(s);
            for (const ConstraintFunction& c : constraints) builder.addConstraint(c);
            auto scene = std::make_unique<Scene>();
            scene->model = builder.build();
            if (dimension != 2 && dimension != 3)
              throw InputError("dimension: must be 2 or 3, got " + std::to_string(dimension));
            scene->cmodel.dimension = dimension;
            if (q0.size() != scene->model.nq || v0.size() != scene->model.nv)
              throw InputError("q0 and v0: must have " + std::to_string(scene->model.nq) + " and " +
                               std::to_string(scene->model.nv) + " entries");
            scene->q0 = q0;
            scene->v0 = v0;
            SceneFile file;
            file.path = "equations";
            file.spec.dimension = dimension;
            file.run.scheme.scheme = schemeFromName(scheme);
            const std::optional<NormalLaw> law = enumFromName<NormalLaw>(normal_law);
            if (!law)
              throw InputError("normal_law: must be " + enumChoices<NormalLaw>() + ", got '" +
                               normal_law + "'");
            file.run.scheme.normal_law = *law;
            if (!(dt > 0.0) || !std::isfinite(dt))
              throw InputError("dt: must be > 0, got " + exactNumber(dt));
            if (!(t_end > 0.0) || !std::isfinite(t_end))
              throw InputError("t_end: must be > 0, got " + exactNumber(t_end));
            file.run.scheme.h = dt;
            file.run.t_end = t_end;
            file.run.scheme.validate();
            stepCount(0.0, t_end, dt);
            // the start checked as set_state checks a state
            checkState(*scene, SavedState{0.0, q0, v0}, -1.0, "from_equations: q0, v0");
            return std::make_unique<Simulation>(std::move(file), std::move(scene));
          },
          py::arg("systems"), py::arg("constraints") = std::vector<ConstraintFunction>{},
          py::arg("q0"), py::arg("v0"), py::arg("dt"), py::arg("t_end") = 1.0,
          py::arg("scheme") = "catching-up", py::arg("dimension") = 2,
          py::arg("normal_law") = "vel",
          "A simulation of systems by their equations and constraints by functions, from "
          "(q0, v0) at t = 0, at the scheme's default settings.")
      .def(
          "constraint_impulses",
          [](const Simulation& s) {
            const auto& impulses = s.stepper().constraintImpulses();
            MatrixX out(impulses.size(), 3);
            for (std::size_t k = 0; k < impulses.size(); ++k) out.row(k) = impulses[k].transpose();
            return out;
          },
          "The last step's impulse (normal, tangents) of each constraint by functions")
      .def_property_readonly(
          "actuators",
          [](const Simulation& s) {
            std::vector<std::string> joints;
            for (const JointActuator& a : s.scene().model.actuators) joints.push_back(a.joint);
            return joints;
          },
          "The actuated joints' names, in the order of actuator_torques()")
      .def(
          "command",
          [](Simulation& s, const std::string& joint, std::optional<double> torque,
             std::optional<double> position, std::optional<double> velocity) {
            const auto& actuators = s.scene().model.actuators;
            for (std::size_t a = 0; a < actuators.size(); ++a) {
              if (actuators[a].joint != joint) continue;
              const std::string where = "command('" + joint + "')";
              for (const auto& [name, value] :
                   {std::pair{"torque", torque}, {"position", position}, {"velocity", velocity}})
                if (value && !std::isfinite(*value))
                  throw InputError(where + ": " + name + " = " + exactNumber(*value) +
                                   " must be finite");
              constexpr double none = std::numeric_limits<double>::quiet_NaN();
              if (actuators[a].prescribed) {
                // its motion from the next step: q(t) = position + velocity (t - now)
                if (torque)
                  throw InputError(where +
                                   ": the joint's motion is prescribed: command a position "
                                   "and a velocity, not a torque");
                const double q_now = s.stepper().q()[actuators[a].q_index];
                s.stepper().command(
                    static_cast<int>(a),
                    ActuatorCommand{none, position || velocity ? position.value_or(q_now) : none,
                                    velocity.value_or(none)});
                return;
              }
              if ((position || velocity) && !actuators[a].servo())
                throw InputError(where +
                                 ": the actuator has no servo gains (kp, kd) to follow "
                                 "a position or velocity");
              if (position && actuators[a].kp == 0.0)
                throw InputError(where + ": a position needs kp > 0");
              s.stepper().command(static_cast<int>(a),
                                  ActuatorCommand{torque.value_or(none), position.value_or(none),
                                                  velocity.value_or(none)});
              return;
            }
            throw InputError("command: no actuator on a joint named '" + joint + "'");
          },
          py::arg("joint"), py::arg("torque") = py::none(), py::arg("position") = py::none(),
          py::arg("velocity") = py::none(),
          "Commands the actuator of `joint` from the next step on, until the next command: a "
          "motor torque (force), and a servo's target position and velocity. What is left "
          "out (None) follows the scene's tables; a position without a velocity aims at rest. "
          "A prescribed joint moves as q(t) = position + velocity (t - now) (position: "
          "its q now when left out; velocity: 0); command(joint) alone hands it back to its "
          "table.")
      .def(
          "actuator_torques",
          [](const Simulation& s) {
            const auto& torques = s.stepper().actuatorTorques();
            return VectorX(Eigen::Map<const VectorX>(torques.data(),
                                                     static_cast<Eigen::Index>(torques.size())));
          },
          "The torque (force) each actuator applied over the last step, in the order of "
          "`actuators`")
      .def_property_readonly(
          "dof_names", [](const Simulation& s) { return s.scene().model.dofNames(); },
          "A name per entry of v: the joint's, with :x, :y, :theta (planar) or :vx ... :wz "
          "(floating) where it has several")
      .def("step", &Simulation::step, "One step; returns its statistics.")
      .def("run", &Simulation::run, py::arg("t_end") = py::none(), py::arg("callback") = py::none(),
           "Step to t_end (default: the scene's end); callback(sim) after each step may return "
           "False to stop. Returns the number of steps.")
      .def("set_state", &Simulation::setState, py::arg("t"), py::arg("q"), py::arg("v"))
      .def("contacts", &Simulation::contacts,
           "The last step's contacts as numpy arrays, and the bodies' names (name_a, name_b: a "
           "dynamic or driven body's, or a fixed shape's).")
      .def("body", &Simulation::body, py::arg("name"),
           "A body at the current state: position and rotation of its frame in world, the "
           "world velocity of its origin and its world angular velocity.")
      .def("joint", &Simulation::joint, py::arg("name"),
           "A joint at the current state: its q and v entries, their indices, its body.")
      .def("shapes", &Simulation::shapes,
           "Every bounded shape at the current state, in world coordinates: a dict each with "
           "name, type, kind (dynamic, driven, world), body, position, rotation, radius, and "
           "start / end (segments), size (boxes), length (cylinders, capsules), vertices "
           "(polygons).")
      .def_property_readonly("last_step",
                             [](const Simulation& s) { return stepStatsDict(s.stepper().stats()); })
      .def("energy", [](Simulation& s) { return s.stepper().energy(); })
      .def_property_readonly("t", [](const Simulation& s) { return s.stepper().time(); })
      .def_property_readonly("dt", [](const Simulation& s) { return s.file().run.scheme.h; })
      .def_property_readonly("t_end", [](const Simulation& s) { return s.file().run.t_end; })
      .def_property_readonly(
          "scheme", [](const Simulation& s) { return enumName(s.file().run.scheme.scheme); })
      .def_property_readonly("dimension",
                             [](const Simulation& s) { return s.file().spec.dimension; })
      .def_property_readonly("nq", [](const Simulation& s) { return s.scene().model.nq; })
      .def_property_readonly("nv", [](const Simulation& s) { return s.scene().model.nv; })
      .def_property_readonly(
          "q", [](py::object self) { return view(self.cast<Simulation&>().stepper().q(), self); },
          "Generalized coordinates (a read-only view, valid until the next step).")
      .def_property_readonly(
          "v", [](py::object self) { return view(self.cast<Simulation&>().stepper().v(), self); },
          "Generalized velocities (a read-only view, valid until the next step).");

  py::class_<Dynamics>(m, "Model", "The Lagrangian layer of a multibody model.")
      .def_static(
          "from_urdf",
          [](const std::string& path, bool floating_base,
             const std::vector<std::string>& package_paths) {
            UrdfOptions options;
            options.floating_base = floating_base;
            options.package_paths = package_paths;
            return Dynamics(loadUrdf(path, options));
          },
          py::arg("path"), py::arg("floating_base") = false,
          py::arg("package_paths") = std::vector<std::string>{})
      .def_property_readonly("nq", [](const Dynamics& d) { return d.model().nq; })
      .def_property_readonly("nv", [](const Dynamics& d) { return d.model().nv; })
      .def_property_readonly("gravity", [](const Dynamics& d) { return d.model().gravity; })
      .def_property_readonly("body_names",
                             [](const Dynamics& d) {
                               std::vector<std::string> names;
                               for (const Body& b : d.model().bodies) names.push_back(b.name);
                               return names;
                             })
      .def_property_readonly("dof_names", &Dynamics::dofNames,
                             "A name per entry of v: the joint's, with :x, :y, :theta (planar) "
                             "or :vx ... :wz (floating) where it has several")
      .def("dof_index", &Dynamics::dofIndex, py::arg("name"))
      .def("neutral_configuration",
           [](const Dynamics& d) { return d.model().neutralConfiguration(); })
      .def("mass_matrix", &Dynamics::massMatrix, py::arg("q"))
      .def("rnea", &Dynamics::rneaForces, py::arg("q"), py::arg("v"), py::arg("a"))
      .def("bias_forces", &Dynamics::bias, py::arg("q"), py::arg("v"),
           "Coriolis, centrifugal and gravity forces: M(q) a + bias = tau")
      .def("gravity_forces", &Dynamics::gravity, py::arg("q"))
      .def("coriolis_forces", &Dynamics::coriolis, py::arg("q"), py::arg("v"),
           "Coriolis and centrifugal forces, computed without gravity (not bias minus gravity)")
      .def("forward_dynamics", &Dynamics::acceleration, py::arg("q"), py::arg("v"), py::arg("tau"))
      .def("kinetic_energy", &Dynamics::kinetic, py::arg("q"), py::arg("v"))
      .def("potential_energy", &Dynamics::potential, py::arg("q"))
      .def("body_pose", &Dynamics::bodyPose, py::arg("q"), py::arg("body"),
           "(R, p): the body frame's rotation and origin in world")
      .def("center_of_mass", &Dynamics::com, py::arg("q"))
      .def("jacobian", &Dynamics::jacobian, py::arg("q"), py::arg("body"),
           py::arg("point") = Vector3::Zero(),
           "6 x nv: rows 0-2 map v to the body's angular velocity, rows 3-5 to the velocity of "
           "`point` (body-frame coordinates, default its origin), both in world axes")
      .def("velocity_to_body_frame", &Dynamics::toBodyFrame, py::arg("q"), py::arg("v"),
           "Floating joints' velocities as Pinocchio's free flyer takes them: the linear part "
           "in body axes (Sweep's is in the parent frame); other entries copied")
      .def("velocity_from_body_frame", &Dynamics::fromBodyFrame, py::arg("q"), py::arg("v_body"));
}
