#pragma once
// Contact laws per pair of materials: Coulomb friction coefficient mu and Newton restitution e.
#include <string>
#include <vector>

namespace sweep {

struct ContactLaw {
  double friction = 0.0;     // mu >= 0
  double restitution = 0.0;  // e in [0, 1]
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

 private:
  std::vector<std::string> names_;
  ContactLaw default_law_;
  std::vector<int> pair_law_;  // size()^2 entries; -1: default law
  std::vector<ContactLaw> laws_;
};

// InputError unless mu >= 0 and 0 <= e <= 1, both finite. `owner` names the pair.
void validateContactLaw(const ContactLaw& law, const std::string& owner);

}  // namespace sweep
