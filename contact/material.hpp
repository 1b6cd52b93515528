#pragma once
// Contact laws per pair of materials: Coulomb friction coefficient mu, Newton restitution e, a
// rolling-resistance coefficient mu_r (the impulsive rolling torque is bounded by mu_r R* P_N,
// with R* the reduced radius of the pair; powder models rely on it) and adhesion.
//
// Adhesion (docs/schemes.md, "Adhesion"): a pull-off force F per contact point,
//   F = adhesion_force + 4 pi surface_energy R*     (DMT: Derjaguin, Muller & Toporov 1975),
// acting on the contacts of the solve whose gap is below adhesion_range, as a tension the
// normal impulse may reach: P_N >= -h F, with the friction and rolling thresholds taken from
// P_N + h F (the cohesive Coulomb law of LMGC90's IQS_WET_DS_CLB with cohesion F).
#include <string>
#include <vector>

namespace sweep {

struct ContactLaw {
  double friction = 0.0;        // mu >= 0
  double restitution = 0.0;     // e in [0, 1]
  double rolling = 0.0;         // mu_r >= 0 (dimensionless)
  double adhesion_force = 0.0;  // N per contact point (2D: per unit thickness), >= 0
  double surface_energy = 0.0;  // J/m^2, >= 0; 3D pairs with a ball only (R* > 0)
  double adhesion_range = 0.0;  // m, >= 0
  bool adhesive() const { return adhesion_force > 0.0 || surface_energy > 0.0; }
};

// R* of a pair: r_a r_b / (r_a + r_b) for two balls, the ball's radius against anything else (a
// flat or large surface), 0 when neither is a ball (radius < 0 for a shape that is not a ball)
double reducedRadius(double radius_a, double radius_b);
// the law's pull-off force F for a pair of these ball radii (above)
double pullOffForce(const ContactLaw& law, double radius_a, double radius_b);

// Material 0 is "default". A pair without its own law uses the default law.
class MaterialTable {
 public:
  MaterialTable();

  int add(const std::string& name);       // returns the id; InputError if the name exists
  int id(const std::string& name) const;  // InputError if absent
  const std::string& name(int id) const { return names_[id]; }
  int size() const { return static_cast<int>(names_.size()); }

  void setDefaultLaw(const ContactLaw& law);
  void setLaw(int a, int b, const ContactLaw& law);  // symmetric
  const ContactLaw& law(int a, int b) const;

  // true when no pair that may meet has friction: the friction stage can be skipped
  bool frictionless() const;
  // true when some pair has mu_r > 0: the rolling rows are assembled
  bool hasRolling() const;

 private:
  std::vector<std::string> names_;
  ContactLaw default_law_;
  std::vector<int> pair_law_;  // size()^2 entries; -1: default law
  std::vector<ContactLaw> laws_;
};

// InputError unless mu >= 0, 0 <= e <= 1, mu_r >= 0 and the adhesion parameters >= 0, all
// finite. `owner` names the pair.
void validateContactLaw(const ContactLaw& law, const std::string& owner);

}  // namespace sweep
