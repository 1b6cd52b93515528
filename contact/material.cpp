#include "contact/material.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <utility>

#include "framework/error.hpp"

namespace sweep {

MaterialTable::MaterialTable() : names_{"default"}, pair_law_{-1} {}

int MaterialTable::add(const std::string& name) {
  for (const std::string& existing : names_)
    if (existing == name) throw InputError("material '" + name + "' is defined twice");
  const int n = size();
  std::vector<int> grown((n + 1) * (n + 1), -1);
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) grown[a * (n + 1) + b] = pair_law_[a * n + b];
  pair_law_ = std::move(grown);
  names_.push_back(name);
  return n;
}

int MaterialTable::id(const std::string& name) const {
  for (int i = 0; i < size(); ++i)
    if (names_[i] == name) return i;
  throw InputError("unknown material '" + name + "'");
}

void MaterialTable::setDefaultLaw(const ContactLaw& law) {
  validateContactLaw(law, "default contact law");
  default_law_ = law;
}

void MaterialTable::setLaw(int a, int b, const ContactLaw& law) {
  if (a < 0 || b < 0 || a >= size() || b >= size())
    throw InputError("contact law between materials " + std::to_string(a) + " and " +
                     std::to_string(b) + ": no such material");
  validateContactLaw(law, "contact law '" + names_[a] + "'-'" + names_[b] + "'");
  const int n = size();
  laws_.push_back(law);
  pair_law_[a * n + b] = pair_law_[b * n + a] = static_cast<int>(laws_.size()) - 1;
}

const ContactLaw& MaterialTable::law(int a, int b) const {
  const int index = pair_law_[a * size() + b];
  return index < 0 ? default_law_ : laws_[index];
}

bool MaterialTable::frictionless() const {
  for (int a = 0; a < size(); ++a)
    for (int b = a; b < size(); ++b)
      if (law(a, b).friction > 0.0 || law(a, b).rolling > 0.0) return false;
  return true;
}

bool MaterialTable::hasRolling() const {
  for (int a = 0; a < size(); ++a)
    for (int b = a; b < size(); ++b)
      if (law(a, b).rolling > 0.0) return true;
  return false;
}

void validateContactLaw(const ContactLaw& law, const std::string& owner) {
  const auto show = formatValue;
  if (!(std::isfinite(law.friction) && law.friction >= 0.0))
    throw InputError(owner + ": friction must be >= 0, got " + show(law.friction));
  if (!(std::isfinite(law.restitution) && law.restitution >= 0.0 && law.restitution <= 1.0))
    throw InputError(owner + ": restitution must be in [0, 1], got " + show(law.restitution));
  if (!(std::isfinite(law.rolling) && law.rolling >= 0.0))
    throw InputError(owner + ": rolling_resistance must be >= 0, got " + show(law.rolling));
  const std::pair<const char*, double> adhesion[] = {{"adhesion_force", law.adhesion_force},
                                                     {"surface_energy", law.surface_energy},
                                                     {"adhesion_range", law.adhesion_range}};
  for (const auto& [name, value] : adhesion)
    if (!(std::isfinite(value) && value >= 0.0))
      throw InputError(owner + ": " + name + " must be >= 0, got " + show(value));
}

double reducedRadius(double radius_a, double radius_b) {
  if (radius_a > 0.0 && radius_b > 0.0) return radius_a * radius_b / (radius_a + radius_b);
  return std::max({radius_a, radius_b, 0.0});
}

double pullOffForce(const ContactLaw& law, double radius_a, double radius_b) {
  double force = law.adhesion_force;
  if (law.surface_energy > 0.0)
    force += 4.0 * M_PI * law.surface_energy * reducedRadius(radius_a, radius_b);
  return force;
}

}  // namespace sweep
