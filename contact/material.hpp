#pragma once
// Contact laws per pair of materials: Coulomb friction coefficient mu, Newton restitution e and
// a rolling-resistance coefficient mu_r (the impulsive rolling torque is bounded by
// mu_r R* P_N, with R* the reduced radius of the pair; powder models rely on it).
#include <string>
#include <vector>

namespace sweep {

struct ContactLaw {
  double friction = 0.0;     // mu >= 0
  double restitution = 0.0;  // e in [0, 1]
  double rolling = 0.0;      // mu_r >= 0 (dimensionless)
};

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

// InputError unless mu >= 0, 0 <= e <= 1 and mu_r >= 0, all finite. `owner` names the pair.
void validateContactLaw(const ContactLaw& law, const std::string& owner);

}  // namespace sweep
