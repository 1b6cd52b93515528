#include "contact/detection.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <new>
#include <stdexcept>
#include <type_traits>

#include "contact/fcl_scene.hpp"
#include "contact/narrowphase_analytic.hpp"
#include "framework/parallel.hpp"

namespace sweep {

namespace {

bool isBall(ShapeType t) {
  return t == ShapeType::Sphere || t == ShapeType::Disk;
}

// R* of the rolling-resistance bound: r_a r_b / (r_a + r_b) for two balls, the ball's radius
// against anything else (a flat or large surface), 0 when neither is a ball (no rolling row)
double reducedRadius(double radius_a, double radius_b) {
  if (radius_a > 0.0 && radius_b > 0.0) return radius_a * radius_b / (radius_a + radius_b);
  return std::max({radius_a, radius_b, 0.0});
}

// Balls of the grid path: bounded, on a moving body, and not much larger than the typical
// ball, so that the cell size stays near one grain diameter.
void classifyForGrid(const ContactModel& cmodel, ContactData& cdata) {
  std::vector<double> radii;
  for (const Geometry& g : cmodel.geometries)
    if (isBall(g.shape.type) && g.body.hasDofs()) radii.push_back(g.shape.radius);
  double median = 0.0;
  if (!radii.empty()) {
    std::nth_element(radii.begin(), radii.begin() + radii.size() / 2, radii.end());
    median = radii[radii.size() / 2];
  }
  for (int i = 0; i < cmodel.size(); ++i) {
    const Geometry& g = cmodel.geometries[i];
    const bool particle =
        isBall(g.shape.type) && g.body.hasDofs() && g.shape.radius <= 4.0 * median;
    (particle ? cdata.particles : cdata.large).push_back(i);
  }
  for (std::size_t l = 0; l < cdata.large.size(); ++l)
    if (cmodel.traits[cdata.large[l]].moving) cdata.large_moving.push_back(static_cast<int>(l));
}

}  // namespace

ContactData::ContactData(const Model& model, const ContactModel& cmodel)
    : geometry_pose(cmodel.size()), dof_slot(model.nv, -1) {
  jacobian.dimension = cmodel.dimension;
  if (cmodel.path == DetectionPath::Fcl) {
    fcl = std::make_unique<FclScene>(cmodel);
  } else {
    classifyForGrid(cmodel, *this);
    particle_center.resize(particles.size());
    particle_radius.resize(particles.size());
    for (std::size_t k = 0; k < particles.size(); ++k)
      particle_radius[k] = cmodel.geometries[particles[k]].shape.radius;
  }
}

ContactData::~ContactData() = default;
ContactData::ContactData(ContactData&&) noexcept = default;
ContactData& ContactData::operator=(ContactData&&) noexcept = default;

void updateGeometryPoses(const Model& model, const Data& data, const ContactModel& cmodel, double t,
                         ContactData& cdata) {
  const int n = cmodel.size();
  forEachIndex(n, data.threads, [&](int i) {
    const Geometry& g = cmodel.geometries[i];
    switch (g.body.kind) {
      case BodyRef::Kind::World:
        cdata.geometry_pose[i] = g.placement;
        break;
      case BodyRef::Kind::Dynamic:
        cdata.geometry_pose[i] = data.world_pose[g.body.index] * g.placement;
        break;
      case BodyRef::Kind::Driven:
        cdata.geometry_pose[i] = model.driven_bodies[g.body.index].pose(t) * g.placement;
        break;
    }
  });
}

double fastestShapeSpeed(const Model& model, const Data& data, const ContactModel& cmodel,
                         double t) {
  // std::max(fastest, x) leaves a NaN x out, in any order: chunks on threads change nothing
  return reduceInChunks(
      cmodel.size(), data.threads, 0.0,
      [&](long i, double& fastest) {
        const Geometry& g = cmodel.geometries[i];
        Vector6 twist = Vector6::Zero();
        if (g.body.kind == BodyRef::Kind::Dynamic) twist = data.velocity[g.body.index];
        if (g.body.kind == BodyRef::Kind::Driven)
          twist = model.driven_bodies[g.body.index].twist(t);
        // |v_origin| + |w| * (distance of any shape point from the body origin)
        const double reach =
            isUnbounded(g.shape) ? 0.0 : g.placement.translation.norm() + boundingRadius(g.shape);
        fastest = std::max(fastest, twist.tail<3>().norm() + twist.head<3>().norm() * reach);
      },
      [](double& fastest, double part) { fastest = std::max(fastest, part); });
}

double ballClosingSpeed(const Model& model, const Data& data, const ContactModel& cmodel,
                        double t) {
  // A ball's surface moves with its centre whatever it spins, so the centres' velocities
  // bound every gap between two balls; any common velocity u drops out of their differences.
  auto centreVelocity = [&](int i) -> Vector3 {
    const Geometry& g = cmodel.geometries[i];
    const BodyRef& body = cmodel.traits[i].body_ref;
    if (body.kind == BodyRef::Kind::Dynamic) {
      const Vector6& twist = data.velocity[body.index];  // body coordinates
      const Vector3 local =
          twist.tail<3>() + twist.head<3>().cross(Vector3(g.placement.translation));
      return data.world_pose[body.index].rotation * local;
    }
    if (body.kind == BodyRef::Kind::Driven) {
      const DrivenBody& driven = model.driven_bodies[body.index];
      return driven.pointVelocity(driven.pose(t).apply(g.placement.translation), t);
    }
    return Vector3::Zero();
  };
  // min and max leave NaN entries out, in any order: chunks on threads change nothing
  struct Bounds {
    Vector3 low, high;
    double fastest;
  };
  const Vector3 none = Vector3::Constant(std::numeric_limits<double>::infinity());
  const auto [low, high, fastest] = reduceInChunks(
      cmodel.size(), data.threads, Bounds{none, -none, 0.0},
      [&](long i, Bounds& part) {
        if (!(cmodel.traits[i].ball_radius > 0.0)) return;
        const Vector3 c = centreVelocity(static_cast<int>(i));
        part.low = part.low.cwiseMin(c);
        part.high = part.high.cwiseMax(c);
        part.fastest = std::max(part.fastest, c.norm());
      },
      [](Bounds& total, const Bounds& part) {
        total.low = total.low.cwiseMin(part.low);
        total.high = total.high.cwiseMax(part.high);
        total.fastest = std::max(total.fastest, part.fastest);
      });
  if (!(low.x() <= high.x())) return 0.0;  // no balls
  const double spread = 0.5 * (high - low).norm();
  // a non-finite spread compares false and leaves the absolute bound, as fastestShapeSpeed
  // leaves non-finite speeds out
  return spread < fastest ? spread : fastest;
}

double detectionMargin(const Model& model, const Data& data, const ContactModel& cmodel, double h,
                       double t) {
  return cmodel.settings.speed_factor * h * fastestShapeSpeed(model, data, cmodel, t) +
         cmodel.margin_floor;
}

DetectionMargins detectionMargins(const Model& model, const Data& data, const ContactModel& cmodel,
                                  double h, double t) {
  const double others = detectionMargin(model, data, cmodel, h, t);
  if (cmodel.settings.margin_rule == MarginRule::Absolute) return DetectionMargins::uniform(others);
  const double balls = cmodel.settings.speed_factor * h * ballClosingSpeed(model, data, cmodel, t) +
                       cmodel.margin_floor;
  return {std::min(balls, others), others};
}

namespace {

Vector3 outwardNormal(const Shape& s, const Pose& pose) {
  return s.type == ShapeType::HalfSpace ? Vector3(pose.rotation.col(2))
                                        : Vector3(pose.rotation.col(1));
}

// FCL 0.7 answers a sphere against a triangle mesh with a negative depth and witness points in
// the shapes' own frames; Sweep's closed form takes the pair on every path.
bool meshAndSphere(const Shape& a, const Shape& b) {
  return (a.type == ShapeType::TriangleMesh && b.type == ShapeType::Sphere) ||
         (b.type == ShapeType::TriangleMesh && a.type == ShapeType::Sphere);
}

// The closed forms take the pair in one order (container first, ball second); `flipped`
// says the geometries came the other way round.
void analyticPair(const Shape& sa, const Pose& pa, const Shape& sb, const Pose& pb, double margin,
                  std::vector<ContactPoint>& out) {
  const std::size_t first = out.size();
  const bool flipped = isUnbounded(sb) || (isBall(sa.type) && !isBall(sb.type));
  const Shape& s1 = flipped ? sb : sa;
  const Shape& s2 = flipped ? sa : sb;
  const Pose& p1 = flipped ? pb : pa;
  const Pose& p2 = flipped ? pa : pb;
  switch (s1.type) {
    case ShapeType::HalfSpace:
    case ShapeType::HalfPlane:
      halfSpaceShape(p1.translation, outwardNormal(s1, p1), s2, p2, margin,
                     [&](const ContactPoint& c) { out.push_back(c); });
      break;
    case ShapeType::Sphere:
    case ShapeType::Disk:
      out.push_back(ballBall(p1.translation, s1.radius, p2.translation, s2.radius));
      break;
    case ShapeType::Segment:
      out.push_back(segmentBall(p1.apply(s1.segment_start), p1.apply(s1.segment_end), s1.radius,
                                p2.translation, s2.radius));
      break;
    case ShapeType::Box:
      out.push_back(boxBall(p1, s1.half_extents, p2.translation, s2.radius));
      break;
    case ShapeType::TriangleMesh:  // FCL's sphere-mesh pair is not used: see meshBall
      if (s2.type == ShapeType::Sphere)
        meshBall(p1, *s1.mesh, p2.translation, s2.radius, margin,
                 [&](const ContactPoint& c) { out.push_back(c); });
      break;
    case ShapeType::Capsule:  // a segment along the local z axis, rounded by the radius
      out.push_back(segmentBall(p1.apply(Vector3(0.0, 0.0, -0.5 * s1.length)),
                                p1.apply(Vector3(0.0, 0.0, 0.5 * s1.length)), s1.radius,
                                p2.translation, s2.radius));
      break;
    default:
      break;
  }
  if (!flipped) return;
  for (std::size_t k = first; k < out.size(); ++k) {
    out[k].normal = -out[k].normal;
    std::swap(out[k].point_a, out[k].point_b);
  }
}

void setFrame(Contact& c, int dimension, const Contact* previous) {
  if (dimension == 2) {
    c.tangent1 = Vector3(-c.normal.y(), c.normal.x(), 0.0);
    c.tangent2.setZero();
    return;
  }
  // carry the previous tangent along: a persistent contact keeps its frame
  if (previous != nullptr) {
    const Vector3 t = previous->tangent1 - c.normal * c.normal.dot(previous->tangent1);
    if (t.norm() > 1e-3) {
      c.tangent1 = t.normalized();
      c.tangent2 = c.normal.cross(c.tangent1);
      return;
    }
  }
  int axis = 0;
  c.normal.cwiseAbs().minCoeff(&axis);
  const Vector3 e = Vector3::Unit(axis);
  c.tangent1 = (e - c.normal * c.normal.dot(e)).normalized();
  c.tangent2 = c.normal.cross(c.tangent1);
}

// Pairs carry the periodic image of their second geometry in the two low bits of `second`:
// (b << 2) | image, image 0 for b itself, 1 for b shifted by +period, 2 for -period. Sorting
// the encoded pairs sorts by (a, b, image), the order of contact keys.
constexpr int kImageBits = 2;
std::pair<int, int> encodePair(int a, int b, int image = 0) {
  return {a, (b << kImageBits) | image};
}
int pairGeometry(int encoded) {
  return encoded >> kImageBits;
}
int pairImage(int encoded) {
  return encoded & ((1 << kImageBits) - 1);
}

Vector3 imageShift(const Periodicity& periodic, int image) {
  Vector3 shift = Vector3::Zero();
  if (image != 0) shift[periodic.axis] = image == 1 ? periodic.period() : -periodic.period();
  return shift;
}

void broadphaseGrid(const ContactModel& cmodel, ContactData& cdata, const DetectionMargins& margins,
                    int threads) {
  const double margin = margins.balls;  // the grid holds balls only
  const int n = static_cast<int>(cdata.particles.size());
  double largest = 0.0;
  cdata.particle_center.resize(n);
  cdata.particle_radius.resize(n);
  for (int k = 0; k < n; ++k) {
    cdata.particle_center[k] = cdata.geometry_pose[cdata.particles[k]].translation;
    largest = std::max(largest, cdata.particle_radius[k]);
  }
  const double reach = 2.0 * largest + margin;
  // periodic boundaries: grains within reach of a boundary get an image beyond the other one
  cdata.ghost_of.clear();
  const Periodicity& periodic = cmodel.settings.periodic;
  if (periodic.enabled()) {
    if (!(2.0 * reach < periodic.period()))
      throw std::runtime_error("periodic detection: the search reach " + std::to_string(reach) +
                               " m exceeds half the period; the step is too large for it");
    for (int k = 0; k < n; ++k) {
      const double x = cdata.particle_center[k][periodic.axis];
      for (int image = 1; image <= 2; ++image) {
        const bool near = image == 1 ? x - periodic.low < reach : periodic.high - x < reach;
        if (!near) continue;
        cdata.ghost_of.emplace_back(k, image);
        cdata.particle_center.push_back(cdata.particle_center[k] + imageShift(periodic, image));
        cdata.particle_radius.push_back(cdata.particle_radius[k]);
      }
    }
  }
  cdata.grid.build(cdata.particle_center, cdata.particle_radius, reach, cmodel.dimension);
  const std::size_t first = cdata.pairs.size();
  cdata.grid.findPairs(margin, cdata.pairs, threads, &cdata.run_pairs);
  std::size_t kept = first;
  for (std::size_t k = first; k < cdata.pairs.size(); ++k) {
    int i = cdata.pairs[k].first, j = cdata.pairs[k].second;
    if (i >= n && j >= n) continue;  // two images: the pair of their originals is found as is
    if (i < n && j < n) {
      i = cdata.particles[i];
      j = cdata.particles[j];
      cdata.pairs[kept++] = encodePair(std::min(i, j), std::max(i, j));
      continue;
    }
    if (i >= n) std::swap(i, j);
    // a grain against an image: found once from each side; kept where the image is of the
    // larger geometry
    const auto [original, image] = cdata.ghost_of[j - n];
    const int real = cdata.particles[i], imaged = cdata.particles[original];
    if (real < imaged) cdata.pairs[kept++] = encodePair(real, imaged, image);
  }
  cdata.pairs.resize(kept);
  // walls, blades, planes: against the particles their box can reach, and each other
  for (std::size_t l = 0; l < cdata.large.size(); ++l) {
    const int g = cdata.large[l];
    const Shape& shape = cmodel.geometries[g].shape;
    auto add = [&](int k) {
      if (k >= n) return;  // images meet only grains
      const int p = cdata.particles[k];
      cdata.pairs.push_back(encodePair(std::min(g, p), std::max(g, p)));
    };
    if (isUnbounded(shape)) {
      // the grains within the margin of its face: the narrowphase's gap, with room for its
      // rounding. A powder bed's floor and end walls each met every grain, half the pairs.
      const Vector3 origin = cdata.geometry_pose[g].translation;
      const Vector3 outward = outwardNormal(shape, cdata.geometry_pose[g]);
      const double face_margin = std::max(margins.balls, margins.others);
      for (int k = 0; k < n; ++k) {
        const Vector3 offset = cdata.particle_center[k] - origin;
        const double radius = cdata.particle_radius[k];
        const double slack = 1e-9 * (offset.cwiseAbs().sum() + radius);
        // a NaN gap is kept: the narrowphase decides as before
        if (!(offset.dot(outward) - radius >= face_margin + slack)) add(k);
      }
    } else {
      const Vector3 center = cdata.geometry_pose[g].translation;
      // a large ball meets the particles with the balls' margin, which a check of the end
      // velocities may have raised above the other one
      const Vector3 half = Vector3::Constant(boundingRadius(shape) + largest +
                                             std::max(margins.balls, margins.others));
      cdata.grid.query(center - half, center + half, add);
    }
    // the same pairs in the same order as over every m > l, skipping frozen-frozen ones
    const bool moving = cmodel.traits[g].moving;
    const auto first_moving =
        std::upper_bound(cdata.large_moving.begin(), cdata.large_moving.end(), static_cast<int>(l));
    const std::size_t count =
        moving ? cdata.large.size() - l - 1
               : static_cast<std::size_t>(cdata.large_moving.end() - first_moving);
    for (std::size_t k = 0; k < count; ++k) {
      const int other = cdata.large[moving ? l + 1 + k : first_moving[k]];
      if (cmodel.mayCollide(g, other)) cdata.pairs.push_back(encodePair(g, other));
    }
  }
}

void broadphaseFcl(const ContactModel& cmodel, ContactData& cdata,
                   const DetectionMargins& margins) {
  cdata.fcl->update(cdata.geometry_pose, std::max(margins.balls, margins.others));
  cdata.fcl->findPairs(cdata.pairs);
  for (auto& pair : cdata.pairs) pair = encodePair(pair.first, pair.second);
  // FCL holds no half-spaces: they meet every geometry
  for (int h = 0; h < cmodel.size(); ++h) {
    if (cdata.fcl->has(h)) continue;
    for (int g = 0; g < cmodel.size(); ++g)
      if (g != h && cmodel.mayCollide(g, h))
        cdata.pairs.push_back(encodePair(std::min(g, h), std::max(g, h)));
  }
}

// The first of `count` items in run r of `runs` (runs of equal length, in order).
std::size_t runBegin(std::size_t count, int r, int runs) {
  return count * static_cast<std::size_t>(r) / static_cast<std::size_t>(runs);
}

// Sorts pairs (a < b): counting sort on a, then each run on b. A grain's run holds a
// handful of neighbours and is insertion-sorted; a plate's or a wall's holds every grain
// near it (thousands under a powder layer), where insertion sort was quadratic and took
// 80 % of detection (docs/powder_bed.md): those runs go to std::sort.
// On threads, the counting sort counts and scatters the pairs cut into one range per thread,
// range r's pairs of a geometry after range r - 1's: the stable order of one thread's scatter.
// Runs are sorted each on its own: on threads, the same order.
void sortPairs(int geometries, ContactData& cdata, int threads) {
  std::vector<int>& start = cdata.pair_start;
  const std::size_t pair_count = cdata.pairs.size();
  const bool parallel = threads > 1 && pair_count >= static_cast<std::size_t>(kParallelItems);
  const int ranges = parallel ? threads : 1;
  const std::size_t stride = static_cast<std::size_t>(geometries) + 1;
  // range r's count, then its cursor, of geometry g at range_start[r * stride + g + 1]
  std::vector<int>& range_start = cdata.pair_range_start;
  range_start.assign(ranges * stride, 0);
  cdata.sorted_pairs.resize(pair_count);
  const auto& unsorted = cdata.pairs;
  auto& sorted = cdata.sorted_pairs;
  auto countRange = [&](int r) {
    int* count = range_start.data() + r * stride;
    for (std::size_t k = runBegin(pair_count, r, ranges); k < runBegin(pair_count, r + 1, ranges);
         ++k)
      ++count[unsorted[k].first + 1];
  };
  auto placeRanges = [&] {
    // geometry g's pairs: range 0's, range 1's, ...; each range's cursor at its first slot
    int next = 0;
    for (int g = 0; g < geometries; ++g)
      for (int r = 0; r < ranges; ++r) {
        int& slot = range_start[r * stride + g + 1];
        const int count = slot;
        slot = next;
        next += count;
      }
  };
  auto scatterRange = [&](int r) {
    int* cursor = range_start.data() + r * stride;
    for (std::size_t k = runBegin(pair_count, r, ranges); k < runBegin(pair_count, r + 1, ranges);
         ++k)
      sorted[cursor[unsorted[k].first + 1]++] = unsorted[k];
  };
  if (parallel) {
#pragma omp parallel num_threads(ranges)
    {
#pragma omp for schedule(static, 1)
      for (int r = 0; r < ranges; ++r) countRange(r);
#pragma omp single
      placeRanges();
#pragma omp for schedule(static, 1)
      for (int r = 0; r < ranges; ++r) scatterRange(r);
    }
  } else {
    countRange(0);
    placeRanges();
    scatterRange(0);
  }
  // the end of each geometry's run: the last range's cursor after its scatter
  start.resize(stride);
  for (int g = 0; g < geometries; ++g) start[g] = range_start[(ranges - 1) * stride + g + 1];
  std::swap(cdata.pairs, cdata.sorted_pairs);
  auto& pairs = cdata.pairs;
  constexpr int kInsertionRun = 32;
  auto sortRun = [&](int g) {
    const int run_begin = g == 0 ? 0 : start[g - 1], run_end = start[g];
    if (run_end - run_begin > kInsertionRun) {
      // a plate's run comes in grain order already
      if (!std::is_sorted(pairs.begin() + run_begin, pairs.begin() + run_end))
        std::sort(pairs.begin() + run_begin, pairs.begin() + run_end);
    } else {
      for (int k = run_begin + 1; k < run_end; ++k)
        for (int m = k; m > run_begin && pairs[m] < pairs[m - 1]; --m)
          std::swap(pairs[m], pairs[m - 1]);
    }
  };
  if (parallel) {
#pragma omp parallel for schedule(dynamic, 1024) num_threads(threads)
    for (int g = 0; g < geometries; ++g) sortRun(g);
  } else {
    for (int g = 0; g < geometries; ++g) sortRun(g);
  }
}

// Where a run of the narrowphase on threads puts its contacts: first counted, each pair's
// kept in one scratch element (ContactCount), then written at their place in the one list
// (ContactSlots), by the same code. The list is written once: a list per run, copied into
// the one list afterwards, moved its 60 MB (on a wide powder bed) through memory twice more.
struct ContactCount {
  Contact scratch;
  std::size_t count = 0;
  std::size_t size() const { return count; }
  Contact& emplace_back() {
    ++count;
    return scratch;
  }
  Contact& operator[](std::size_t) { return scratch; }
};
// The count and the writes share narrowphasePair and its input, so they agree; a write past
// the count would go to `spill`, and the caller checks.
struct ContactSlots {
  ContactSlots(Contact* slots, std::size_t slot_count) : first(slots), capacity(slot_count) {}
  Contact* first;
  std::size_t capacity;
  std::size_t count = 0;
  Contact spill;
  std::size_t size() const { return count; }
  Contact& emplace_back() {  // as std::vector's: a new element in the old one's place
    static_assert(std::is_trivially_destructible_v<Contact>);
    if (count >= capacity) {
      ++count;
      return spill;
    }
    return *::new (static_cast<void*>(first + count++)) Contact();
  }
  Contact& operator[](std::size_t k) { return k < capacity ? first[k] : spill; }
};

// The narrowphase of one pair: its contacts (gap < margin), appended to `out` (a
// std::vector<Contact> or the two above) in feature order with their law; `points` is scratch.
template <class Contacts>
void narrowphasePair(const Model& model, const ContactModel& cmodel, const ContactData& cdata,
                     double t, const DetectionMargins& margins, const std::pair<int, int>& pair,
                     Contacts& out, std::vector<ContactPoint>& points, int& broadphase_pairs) {
  // named copies, not structured bindings: C++17 lambdas cannot capture those (clang)
  const int a = pair.first, b = pairGeometry(pair.second), image = pairImage(pair.second);
  // a driven body past its removal time (a pulled shutter) meets nothing
  auto removed = [&](int g) {
    const BodyRef& body = cmodel.traits[g].body_ref;
    return body.kind == BodyRef::Kind::Driven && !model.driven_bodies[body.index].presentAt(t);
  };
  if (!cmodel.mayCollide(a, b) || removed(a) || removed(b)) return;
  const Vector3 shift = imageShift(cmodel.settings.periodic, image);
  ++broadphase_pairs;
  const ContactModel::Traits& ta = cmodel.traits[a];
  const ContactModel::Traits& tb = cmodel.traits[b];
  const std::size_t first = out.size();
  const bool balls = ta.ball_radius > 0.0 && tb.ball_radius > 0.0;
  const double margin = balls ? margins.balls : margins.others;
  auto emit = [&](const ContactPoint& p) {
    if (!(p.gap < margin)) return;
    Contact& c = out.emplace_back();
    c.key = ContactKey{a, b, p.feature};
    c.body_a = ta.body_ref;
    c.body_b = tb.body_ref;
    c.gap = p.gap;
    c.normal = p.normal;
    c.point_a = p.point_a;
    c.point_b = p.point_b - shift;  // on b itself: its Jacobian's lever arm
  };
  if (balls && cmodel.path == DetectionPath::Analytic) {
    // grain against grain, the bulk of a granular step: nothing but centres and radii; the
    // feature of a periodic pair is the image it meets
    ContactPoint p = ballBall(cdata.geometry_pose[a].translation, ta.ball_radius,
                              cdata.geometry_pose[b].translation + shift, tb.ball_radius);
    p.feature = image;
    emit(p);
  } else {
    points.clear();
    if (cmodel.path == DetectionPath::Analytic || ta.unbounded || tb.unbounded ||
        meshAndSphere(cmodel.geometries[a].shape, cmodel.geometries[b].shape))
      analyticPair(cmodel.geometries[a].shape, cdata.geometry_pose[a], cmodel.geometries[b].shape,
                   cdata.geometry_pose[b], margin, points);
    else
      cdata.fcl->narrowphase(a, b, margin, points);
    for (const ContactPoint& p : points) emit(p);
    // a pair's several points are put in feature order (pairs already are sorted)
    for (std::size_t k = first + 1; k < out.size(); ++k)
      for (std::size_t m = k; m > first && out[m].key < out[m - 1].key; --m)
        std::swap(out[m], out[m - 1]);
  }
  if (first == out.size()) return;
  const ContactLaw& law = cmodel.materials.law(ta.material, tb.material);
  const double rolling = law.rolling * reducedRadius(ta.ball_radius, tb.ball_radius);
  for (std::size_t k = first; k < out.size(); ++k) {
    Contact& c = out[k];
    if (cmodel.dimension == 2) {
      // FCL's prisms may report witness points off the scene plane
      c.normal.z() = 0.0;
      c.normal.normalize();
      c.point_a.z() = cdata.geometry_pose[a].translation.z();
      c.point_b.z() = cdata.geometry_pose[b].translation.z();
    }
    c.friction = law.friction;
    c.restitution = law.restitution;
    c.rolling = rolling;
  }
}

// Identity across steps and frames of the contacts [begin, end): both lists are sorted by key,
// so the walk starts where the first key would go in the previous list (a later range can
// be matched on its own).
int matchPrevious(ContactData& cdata, int dimension, std::size_t begin, std::size_t end) {
  if (begin == end) return 0;
  const auto byKey = [](const Contact& c, const ContactKey& key) { return c.key < key; };
  std::size_t previous = std::lower_bound(cdata.previous.begin(), cdata.previous.end(),
                                          cdata.contacts[begin].key, byKey) -
                         cdata.previous.begin();
  int matched_count = 0;
  for (std::size_t k = begin; k < end; ++k) {
    Contact& c = cdata.contacts[k];
    while (previous < cdata.previous.size() && cdata.previous[previous].key < c.key) ++previous;
    const bool matched = previous < cdata.previous.size() && cdata.previous[previous].key == c.key;
    c.previous = matched ? static_cast<int>(previous) : -1;
    matched_count += matched ? 1 : 0;
    setFrame(c, dimension, matched ? &cdata.previous[previous] : nullptr);
  }
  return matched_count;
}

}  // namespace

void detectContacts(const Model& model, const Data& data, const ContactModel& cmodel,
                    ContactData& cdata, double t, const DetectionMargins& margins, int threads) {
  std::swap(cdata.contacts, cdata.previous);
  cdata.pairs.clear();
  updateGeometryPoses(model, data, cmodel, t, cdata);

  // broadphase
  if (cmodel.path == DetectionPath::Analytic)
    broadphaseGrid(cmodel, cdata, margins, threads);
  else
    broadphaseFcl(cmodel, cdata, margins);
  sortPairs(cmodel.size(), cdata, threads);
  cdata.stats = DetectionStats{};

  // narrowphase, then identity across steps and frames
  const std::size_t pair_count = cdata.pairs.size();
  const int runs = cmodel.path == DetectionPath::Analytic && pair_count >= kParallelItems
                       ? std::max(1, threads)
                       : 1;  // FCL's scene is not shared between threads
  if (runs == 1) {
    cdata.contacts.clear();
    for (const auto& pair : cdata.pairs)
      narrowphasePair(model, cmodel, cdata, t, margins, pair, cdata.contacts, cdata.points,
                      cdata.stats.broadphase_pairs);
    cdata.stats.matched = matchPrevious(cdata, cmodel.dimension, 0, cdata.contacts.size());
    cdata.stats.candidates = static_cast<int>(cdata.contacts.size());
    return;
  }
  // Pairs cut into one run per thread count their contacts, pair by pair; the pairs are then
  // cut again, by work, into one run per thread that writes its contacts at their place in
  // the one list and matches them to the previous detection: the same list as one thread's.
  // The list keeps the elements of two detections ago and constructs only the ones it gains
  // (a cleared list constructed every element, 60 MB on a wide powder bed, on one thread).
  if (cdata.run_points.size() < static_cast<std::size_t>(runs)) cdata.run_points.resize(runs);
  // contacts of pairs [0, k) at pair_contacts[k] (after the count: of pair k - 1 alone)
  std::vector<int>& pair_contacts = cdata.pair_contacts;
  pair_contacts.resize(pair_count + 1);
  pair_contacts[0] = 0;
  std::vector<std::size_t> split(runs + 1, pair_count);
  std::vector<int> broadphase_pairs(runs, 0), matched(runs, 0), miscounted(runs, 0);
#pragma omp parallel num_threads(runs)
  {
#pragma omp for schedule(static, 1)
    for (int r = 0; r < runs; ++r) {
      // the run's count on its own stack while it runs: the counts, side by side, share a
      // cache line that every pair would write
      ContactCount counted;
      std::vector<ContactPoint> points = std::move(cdata.run_points[r]);
      int visited = 0;
      for (std::size_t k = runBegin(pair_count, r, runs); k < runBegin(pair_count, r + 1, runs);
           ++k) {
        const std::size_t before = counted.size();
        narrowphasePair(model, cmodel, cdata, t, margins, cdata.pairs[k], counted, points, visited);
        pair_contacts[k + 1] = static_cast<int>(counted.size() - before);
      }
      cdata.run_points[r] = std::move(points);
    }
#pragma omp single
    {
      for (std::size_t k = 0; k < pair_count; ++k) pair_contacts[k + 1] += pair_contacts[k];
      cdata.contacts.resize(pair_contacts[pair_count]);
      // A pair costs about one unit and each of its contacts two more (written, then matched).
      // In a powder bed the walls and plates come first and meet many grains for few
      // contacts: cut by pairs, one thread got the walls and the other the grains.
      auto work = [&](std::size_t k) { return k + 2 * static_cast<std::size_t>(pair_contacts[k]); };
      split[0] = 0;
      for (int r = 1; r < runs; ++r) {
        const std::size_t target = work(pair_count) * r / runs;
        std::size_t low = split[r - 1], high = pair_count;  // the first k with work(k) >= target
        while (low < high) {
          const std::size_t mid = low + (high - low) / 2;
          if (work(mid) < target)
            low = mid + 1;
          else
            high = mid;
        }
        split[r] = low;
      }
    }
#pragma omp for schedule(static, 1)
    for (int r = 0; r < runs; ++r) {
      const std::size_t begin = pair_contacts[split[r]], end = pair_contacts[split[r + 1]];
      ContactSlots slots(cdata.contacts.data() + begin, end - begin);
      std::vector<ContactPoint> points = std::move(cdata.run_points[r]);
      int visited = 0;
      for (std::size_t k = split[r]; k < split[r + 1]; ++k)
        narrowphasePair(model, cmodel, cdata, t, margins, cdata.pairs[k], slots, points, visited);
      cdata.run_points[r] = std::move(points);
      broadphase_pairs[r] = visited;
      miscounted[r] = slots.size() != end - begin;
      matched[r] = matchPrevious(cdata, cmodel.dimension, begin, end);
    }
  }
  if (std::find(miscounted.begin(), miscounted.end(), 1) != miscounted.end())
    throw std::logic_error("detection: the narrowphase wrote other contacts than it counted");
  for (int r = 0; r < runs; ++r) {
    cdata.stats.broadphase_pairs += broadphase_pairs[r];
    cdata.stats.matched += matched[r];
  }
  cdata.stats.candidates = static_cast<int>(cdata.contacts.size());
}

void evaluateContactGaps(const Model& model, const Data& data, const ContactModel& cmodel,
                         ContactData& cdata, double t, std::vector<double>& gaps) {
  updateGeometryPoses(model, data, cmodel, t, cdata);
  const double far = std::numeric_limits<double>::infinity();
  if (cdata.fcl) cdata.fcl->update(cdata.geometry_pose, 0.0);
  const long m = static_cast<long>(cdata.contacts.size());
  gaps.resize(m);
  // a pair of balls has one contact, its feature the image it meets: the gap of ballBall
  // alone, the bulk of a powder step's candidates, each on its own (threads)
  auto ballPair = [&](long c) {
    const ContactModel::Traits& ta = cmodel.traits[cdata.contacts[c].key.geometry_a];
    const ContactModel::Traits& tb = cmodel.traits[cdata.contacts[c].key.geometry_b];
    return ta.ball_radius > 0.0 && tb.ball_radius > 0.0 && cmodel.path == DetectionPath::Analytic;
  };
  forEachIndex(m, data.threads, [&](long c) {
    gaps[c] = far;
    if (!ballPair(c)) return;
    const int a = cdata.contacts[c].key.geometry_a, b = cdata.contacts[c].key.geometry_b;
    const Vector3 center_b = cdata.geometry_pose[b].translation +
                             imageShift(cmodel.settings.periodic, cdata.contacts[c].key.feature);
    gaps[c] = (center_b - cdata.geometry_pose[a].translation).norm() -
              cmodel.traits[a].ball_radius - cmodel.traits[b].ball_radius;
  });
  // the other pairs on this thread, their contacts together (one narrowphase per pair); found
  // by their gaps, still `far`: reading each contact's key took a cache line per ball pair
  std::size_t c = 0;
  while (c < cdata.contacts.size()) {
    if (gaps[c] != far) {  // a ball pair's, set above
      ++c;
      continue;
    }
    const int a = cdata.contacts[c].key.geometry_a, b = cdata.contacts[c].key.geometry_b;
    const ContactModel::Traits& ta = cmodel.traits[a];
    const ContactModel::Traits& tb = cmodel.traits[b];
    if (ballPair(static_cast<long>(c))) {
      ++c;
      continue;
    }
    cdata.points.clear();
    if (cmodel.path == DetectionPath::Analytic || ta.unbounded || tb.unbounded ||
        meshAndSphere(cmodel.geometries[a].shape, cmodel.geometries[b].shape))
      analyticPair(cmodel.geometries[a].shape, cdata.geometry_pose[a], cmodel.geometries[b].shape,
                   cdata.geometry_pose[b], far, cdata.points);
    else
      cdata.fcl->narrowphase(a, b, far, cdata.points);
    // every contact of this pair takes the gap of its feature
    for (; c < cdata.contacts.size() && cdata.contacts[c].key.geometry_a == a &&
           cdata.contacts[c].key.geometry_b == b;
         ++c)
      for (const ContactPoint& p : cdata.points)
        if (p.feature == cdata.contacts[c].key.feature) gaps[c] = p.gap;
  }
}

}  // namespace sweep
