#pragma once
// Step 2 of both schemes: candidate contacts at the detection configuration.
//
//   forwardKinematics(model, data, q_m);
//   const double margin = detectionMargin(model, data, cmodel, cdata, v, h, t_m);
//   detectContacts(model, data, cmodel, cdata, t_m, margin);   // cdata.contacts
//   assembleContactJacobian(model, data, cmodel, cdata, t);    // cdata.jacobian
#include <limits>
#include <memory>
#include <utility>
#include <vector>

#include "contact/contact.hpp"
#include "contact/contact_jacobian.hpp"
#include "contact/grid_broadphase.hpp"
#include "contact/narrowphase_analytic.hpp"
#include "framework/data.hpp"

namespace sweep {

class FclScene;

struct DetectionStats {
  int broadphase_pairs = 0;  // pairs handed to the narrowphase
  int candidates = 0;        // contacts with gap below the margin
  int matched = 0;           // of which were already in contact at the previous detection
};

// Everything detection and assembly write, sized from the models; reused from step to step.
struct ContactData {
  ContactData(const Model& model, const ContactModel& cmodel);
  ~ContactData();
  ContactData(ContactData&&) noexcept;
  ContactData& operator=(ContactData&&) noexcept;

  std::vector<Pose> geometry_pose;  // world pose of each geometry
  std::vector<Contact> contacts;    // sorted by key
  std::vector<Contact> previous;    // the contacts of the previous detection
  // Per contact, set by the stepper after detection (empty elsewhere): whether it carried a
  // normal impulse at the last step. VEL keeps such a contact closed up to heldGap.
  std::vector<char> held;
  ContactJacobian jacobian;
  DetectionStats stats;

  // workspaces
  std::vector<std::pair<int, int>> pairs;
  std::vector<std::pair<int, int>> sorted_pairs;
  std::vector<int> pair_start;
  std::vector<int> pair_range_start;  // the counting sort's per-thread counts and cursors
  std::vector<ContactPoint> points;
  // threaded broadphase: each thread's pairs
  std::vector<std::vector<std::pair<int, int>>> run_pairs;
  // threaded narrowphase: each thread's points of one pair; each pair's contact count
  // and their sums (pair_contacts[k]: contacts of pairs [0, k))
  std::vector<std::vector<ContactPoint>> run_points;
  std::vector<int> pair_contacts;
  std::vector<int> particles;       // grid path: geometries binned in the grid
  std::vector<int> every_particle;  // grid path: the particles before restrictParticles
  std::vector<int> large;           // grid path: every other geometry
  // grid path: positions in `large` of the geometries with dofs, ascending. Two frozen shapes
  // never collide, and a scene may hold thousands (a rough plate's spheres): the wall-wall
  // pairs are looked for only where one side moves.
  std::vector<int> large_moving;
  std::vector<Vector3> particle_center;
  std::vector<double> particle_radius;
  std::vector<std::pair<int, int>> ghost_of;  // periodic images: (particle, image) per ghost
  // grid path, a rank of a distributed run: the owner rank of each binned particle's body, and
  // this rank (-1: every pair is kept). Pairs whose lowest owner is another rank are not
  // this rank's contacts and are left out before the narrowphase.
  std::vector<int> particle_rank;
  int pair_rank = -1;
  GridBroadphase grid;
  std::unique_ptr<FclScene> fcl;
};

// World poses of every geometry: bodies from data (after forwardKinematics), driven bodies
// at time t.
void updateGeometryPoses(const Model& model, const Data& data, const ContactModel& cmodel, double t,
                         ContactData& cdata);

// Grid path: bins only the particles whose body is marked (a rank's own and ghost grains in
// a distributed run, integrators/distributed_stepper.hpp); an empty mark bins every particle.
// With body_rank (each body's owner rank), the pairs are those whose lowest owner is `rank`:
// a particle's pairs with the other geometries where it is the rank's own, two particles'
// where either is. The other geometries are not restricted.
void restrictParticles(const ContactModel& cmodel, const std::vector<char>& body_marked,
                       ContactData& cdata, const std::vector<int>* body_rank = nullptr,
                       int rank = -1);

// Largest speed of a shape point at (q, v) and t: |v_origin| + |w| * reach per geometry.
// Needs forwardKinematics(model, data, q, v).
double fastestShapeSpeed(const Model& model, const Data& data, const ContactModel& cmodel,
                         double t);

// Largest speed of a point of a driven body's shapes at t (0 without driven bodies): a grain
// such a body strikes takes up its speed within the step.
double fastestDrivenShapeSpeed(const Model& model, const ContactModel& cmodel, double t);

// The speed that bounds how fast two balls (spheres, disks) close on each other, at (q, v)
// and t: the largest |c_i - u| over the balls' centre velocities c_i, with u the middle of
// their bounding box, or the largest |c_i| if that is smaller. Two balls close by at most
// h/2 |c_i - c_j| <= h * this over the half step from q_m. Needs forwardKinematics.
double ballClosingSpeed(const Model& model, const Data& data, const ContactModel& cmodel, double t);

// The margins of one detection: pairs of two balls, and every other pair.
struct DetectionMargins {
  double balls = 0.0;
  double others = 0.0;
  static DetectionMargins uniform(double margin) { return {margin, margin}; }
};

// margin = speed_factor * h * fastestShapeSpeed + floor.
// Needs forwardKinematics(model, data, q, v).
double detectionMargin(const Model& model, const Data& data, const ContactModel& cmodel, double h,
                       double t);

// The margins under detection.margin_rule: `absolute`, detectionMargin for every pair;
// `relative`, pairs of two balls from ballClosingSpeed instead (never above the other margin).
DetectionMargins detectionMargins(const Model& model, const Data& data, const ContactModel& cmodel,
                                  double h, double t);

// The speeds the margins are made of, over the geometries of the bodies that `counted` marks
// (every body where null; the world's and driven bodies' geometries always count), in a form
// that parts of a scene combine into the whole's: a distributed step's ranks each measure the
// bodies they own. Needs forwardKinematics(model, data, q, v).
struct MarginSpeeds {
  double fastest_shape = 0.0;  // fastestShapeSpeed
  Vector3 ball_low = Vector3::Constant(std::numeric_limits<double>::infinity());
  Vector3 ball_high = -ball_low;           // the box of the balls' centre velocities (none: empty)
  double ball_fastest = 0.0;               // the largest |centre velocity| of a ball
  void combine(const MarginSpeeds& part);  // max, min and max: any order, the same bits
  double ballClosing() const;              // ballClosingSpeed
};
MarginSpeeds marginSpeeds(const Model& model, const Data& data, const ContactModel& cmodel,
                          double t, const std::vector<char>* counted = nullptr);
// detectionMargins from the speeds
DetectionMargins detectionMargins(const ContactModel& cmodel, double h, const MarginSpeeds& speeds);

// Fills cdata.contacts with every pair of geometries closer than their margin, sorted by key,
// with frames and contact laws, each matched to the previous detection's contacts. On the
// grid path the broadphase, the pairs' sort, the narrowphase and the matching run on up to
// `threads` threads; the list is the same for every count.
void detectContacts(const Model& model, const Data& data, const ContactModel& cmodel,
                    ContactData& cdata, double t, const DetectionMargins& margins, int threads = 1);
inline void detectContacts(const Model& model, const Data& data, const ContactModel& cmodel,
                           ContactData& cdata, double t, double margin) {
  detectContacts(model, data, cmodel, cdata, t, DetectionMargins::uniform(margin));
}

// Gaps of the contacts of the last detection, re-evaluated on the true geometry at the
// configuration in `data` (after forwardKinematics) and time t: the end-of-step penetration
// max(0, -gap) of the diagnostics. A feature that left the narrowphase gets +inf, and so does
// a triangle mesh's feature that does not overlap.
void evaluateContactGaps(const Model& model, const Data& data, const ContactModel& cmodel,
                         ContactData& cdata, double t, std::vector<double>& gaps);

}  // namespace sweep
