#include <sweep/framework/crba.hpp>
#include <sweep/models/kinematic_trees.hpp>

int main() {
  const sweep::Model model = sweep::doublePendulum();
  sweep::Data data(model);
  sweep::crba(model, data, model.neutralConfiguration());
  // hanging straight down, M_00 = m1 l1^2 + m2 (2 l)^2 = 5
  return data.mass_blocks[0](0, 0) == 5.0 ? 0 : 1;
}
