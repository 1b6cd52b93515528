#include "contact/detection.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <new>
#include <stdexcept>
#include <type_traits>

#include "contact/fcl_scene.hpp"
#include "contact/narrowphase_analytic.hpp"
#include "contact/narrowphase_mesh.hpp"
#include "contact/pair_search.hpp"
#include "framework/parallel.hpp"

namespace sweep {

namespace {

bool isBall(ShapeType t) {
  return t == ShapeType::Sphere || t == ShapeType::Disk;
}

// Balls of the grid path: bounded, on a moving body, and not much larger than the typical
// ball, so that the cell size stays near one grain diameter.
void classifyForGrid(const ContactModel& cmodel, ContactData& cdata) {
  std::vector<double> radii;
  for (int i = 0; i < cmodel.size(); ++i)
    if (isBall(cmodel.geometries[i].shape.type) && cmodel.traits[i].moving)
      radii.push_back(cmodel.geometries[i].shape.radius);
  double median = 0.0;
  if (!radii.empty()) {
    std::nth_element(radii.begin(), radii.begin() + radii.size() / 2, radii.end());
    median = radii[radii.size() / 2];
  }
  for (int i = 0; i < cmodel.size(); ++i) {
    const Geometry& g = cmodel.geometries[i];
    const bool particle =
        isBall(g.shape.type) && cmodel.traits[i].moving && g.shape.radius <= 4.0 * median;
    (particle ? cdata.particles : cdata.large).push_back(i);
  }
  for (std::size_t l = 0; l < cdata.large.size(); ++l)
    if (cmodel.traits[cdata.large[l]].moving) cdata.large_moving.push_back(static_cast<int>(l));
}

}  // namespace

ContactData::ContactData(const Model& /*model*/, const ContactModel& cmodel)
    : geometry_pose(cmodel.size()) {
  jacobian.dimension = cmodel.dimension;
  if (cmodel.path == DetectionPath::Fcl) {
    fcl = std::make_unique<FclScene>(cmodel);
  } else {
    classifyForGrid(cmodel, *this);
    every_particle = particles;
    particle_center.resize(particles.size());
    particle_radius.resize(particles.size());
    for (std::size_t k = 0; k < particles.size(); ++k)
      particle_radius[k] = cmodel.geometries[particles[k]].shape.radius;
  }
}

void restrictParticles(const ContactModel& cmodel, const std::vector<char>& body_marked,
                       ContactData& cdata, const std::vector<int>* body_rank, int rank) {
  if (cdata.fcl) return;
  cdata.particles.clear();
  cdata.particle_radius.clear();
  cdata.particle_rank.clear();
  cdata.pair_rank = body_rank != nullptr ? rank : -1;
  for (const int g : cdata.every_particle) {
    const BodyRef& body = cmodel.geometries[g].body;
    const bool dynamic = body.kind == BodyRef::Kind::Dynamic;
    if (!body_marked.empty() && !(dynamic && body_marked[body.index])) continue;
    cdata.particles.push_back(g);
    cdata.particle_radius.push_back(cmodel.geometries[g].shape.radius);
    if (body_rank != nullptr)
      cdata.particle_rank.push_back(dynamic ? (*body_rank)[body.index] : -1);
  }
}

ContactData::~ContactData() = default;
ContactData::ContactData(ContactData&&) noexcept = default;
ContactData& ContactData::operator=(ContactData&&) noexcept = default;

namespace {

// FCL 0.7 answers a sphere against a triangle mesh with a negative depth and witness points in
// the shapes' own frames, a box or capsule with one point per triangle, and a box against a
// box or capsule with gaps that let a capsule sink 8 mm into a box and POS throw a box off
// another, and capsule-capsule with normals off the axes' common normal (capsules sank into
// each other); Sweep's closed forms take these pairs on every path (a box as its surface
// mesh).
bool ownClosedForm(const Shape& a, const Shape& b) {
  auto held = [](ShapeType t) {
    return t == ShapeType::Sphere || t == ShapeType::Box || t == ShapeType::Capsule;
  };
  auto surface = [](ShapeType t) {
    return t == ShapeType::TriangleMesh || t == ShapeType::ConvexMesh;
  };
  auto box_surface = [](const Shape& box, const Shape& other) {
    return box.type == ShapeType::Box && box.mesh &&
           (other.type == ShapeType::Box || other.type == ShapeType::Capsule);
  };
  return (surface(a.type) && held(b.type)) || (surface(b.type) && held(a.type)) ||
         box_surface(a, b) || box_surface(b, a) ||
         (a.type == ShapeType::Capsule && b.type == ShapeType::Capsule);
}

// The closed forms take the pair in one order (container first, ball second); `flipped`
// says the geometries came the other way round.
void analyticPair(const Shape& sa, const Pose& pa, const Shape& sb, const Pose& pb, double margin,
                  std::vector<ContactPoint>& out) {
  const std::size_t first = out.size();
  const bool flipped =
      isUnbounded(sb) ||
      (!isUnbounded(sa) &&
       ((isBall(sa.type) && !isBall(sb.type)) ||
        ((sb.type == ShapeType::TriangleMesh || sb.type == ShapeType::ConvexMesh) &&
         sa.type != sb.type) ||
        (sb.type == ShapeType::Box && sa.type == ShapeType::Capsule)));
  const Shape& s1 = flipped ? sb : sa;
  const Shape& s2 = flipped ? sa : sb;
  const Pose& p1 = flipped ? pb : pa;
  const Pose& p2 = flipped ? pa : pb;
  // a capsule's end (side -1 or +1) along its local z axis
  auto end = [](const Shape& capsule, const Pose& pose, double side) {
    return pose.apply(Vector3(0.0, 0.0, 0.5 * side * capsule.length));
  };
  // s2 (a box or capsule) against a triangle mesh at p1: a triangle mesh's or a box's surface
  auto meshShape = [&](const TriangleMesh& mesh) {
    if (s2.type == ShapeType::Box)
      meshBox(p1, mesh, p2, s2.half_extents, margin, out);
    else if (s2.type == ShapeType::Capsule)
      meshCapsule(p1, mesh, end(s2, p2, -1.0), end(s2, p2, 1.0), s2.radius, margin, out);
  };
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
      if (isBall(s2.type))
        out.push_back(boxBall(p1, s1.half_extents, p2.translation, s2.radius));
      else if (s1.mesh)  // its surface, as a triangle mesh
        meshShape(*s1.mesh);
      break;
    case ShapeType::ConvexMesh:    // its surface: a closed triangle mesh
    case ShapeType::TriangleMesh:  // FCL's pairs with these are not used: see ownClosedForm
      if (s2.type == ShapeType::Sphere)
        meshBall(p1, *s1.mesh, p2.translation, s2.radius, margin,
                 [&](const ContactPoint& c) { out.push_back(c); });
      else
        meshShape(*s1.mesh);
      break;
    case ShapeType::Capsule:  // a segment along the local z axis, rounded by the radius
      if (s2.type == ShapeType::Capsule)
        segmentSegment(end(s1, p1, -1.0), end(s1, p1, 1.0), s1.radius, end(s2, p2, -1.0),
                       end(s2, p2, 1.0), s2.radius, margin,
                       [&](const ContactPoint& c) { out.push_back(c); });
      else
        out.push_back(
            segmentBall(end(s1, p1, -1.0), end(s1, p1, 1.0), s1.radius, p2.translation, s2.radius));
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
  if (!cmodel.mayCollide(a, b) || removedAt(model, cmodel, a, t) || removedAt(model, cmodel, b, t))
    return;
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
        ownClosedForm(cmodel.geometries[a].shape, cmodel.geometries[b].shape))
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
    broadphaseGrid(model, cmodel, cdata, margins, t, threads);
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
  // Pairs cut into one run per thread count their contacts, pair by pair, and add the counts
  // up (each run its own, from the runs before it); the pairs are then cut again, by work,
  // into one run per thread that writes the contacts of the pairs that have any at their place
  // in the one list and matches them to the previous detection: the same list as one
  // thread's. Most pairs of a granular step have none and are not looked at again.
  // The list keeps the elements of two detections ago and constructs only the ones it gains
  // (a cleared list constructed every element, 60 MB on a wide powder bed, on one thread).
  if (cdata.run_points.size() < static_cast<std::size_t>(runs)) cdata.run_points.resize(runs);
  // contacts of pairs [0, k) at pair_contacts[k] (after the count: of pair k - 1 alone)
  std::vector<int>& pair_contacts = cdata.pair_contacts;
  pair_contacts.resize(pair_count + 1);
  pair_contacts[0] = 0;
  std::vector<std::size_t> split(runs + 1, pair_count);
  std::vector<int> broadphase_pairs(runs, 0), matched(runs, 0), miscounted(runs, 0);
  std::vector<std::size_t> run_contacts(runs, 0);
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
      run_contacts[r] = counted.size();
      broadphase_pairs[r] = visited;
    }
#pragma omp for schedule(static, 1)
    for (int r = 0; r < runs; ++r) {
      std::size_t sum = 0;
      for (int s = 0; s < r; ++s) sum += run_contacts[s];
      for (std::size_t k = runBegin(pair_count, r, runs); k < runBegin(pair_count, r + 1, runs);
           ++k) {
        sum += static_cast<std::size_t>(pair_contacts[k + 1]);
        pair_contacts[k + 1] = static_cast<int>(sum);
      }
    }
#pragma omp single
    {
      cdata.contacts.resize(pair_contacts[pair_count]);
      // Each contact costs about three units (found again, written, matched), a pair without
      // one an eighth (its count read). In a powder bed the walls and plates come first and
      // meet many grains for few contacts: cut by pairs, one thread got the walls and the
      // other the grains.
      auto work = [&](std::size_t k) {
        return k / 8 + 3 * static_cast<std::size_t>(pair_contacts[k]);
      };
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
      int visited = 0;  // counted in the first pass
      for (std::size_t k = split[r]; k < split[r + 1]; ++k)
        if (pair_contacts[k + 1] != pair_contacts[k])
          narrowphasePair(model, cmodel, cdata, t, margins, cdata.pairs[k], slots, points, visited);
      cdata.run_points[r] = std::move(points);
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
    // a mesh pair within an unbounded margin is every triangle's feature: its overlaps only
    // (and for the other closed forms of ownClosedForm)
    const bool own = ownClosedForm(cmodel.geometries[a].shape, cmodel.geometries[b].shape);
    if (cmodel.path == DetectionPath::Analytic || ta.unbounded || tb.unbounded || own)
      analyticPair(cmodel.geometries[a].shape, cdata.geometry_pose[a], cmodel.geometries[b].shape,
                   cdata.geometry_pose[b], own ? 0.0 : far, cdata.points);
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
