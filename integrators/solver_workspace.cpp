#include "integrators/solver_workspace.hpp"

#include <algorithm>

namespace sweep {

void SolverWorkspace::prepare(int contacts, int nv, int components) {
  offset.resize(contacts);
  coupling.resize(contacts);
  schur.resize(contacts);
  order.resize(contacts);
  threshold.resize(contacts);
  held_normal.resize(contacts);
  for (int c = 0; c < contacts; ++c) order[c] = c;
  impulse_before.resize(5 * static_cast<std::size_t>(contacts));  // widest: P and R, 3 + 2
  impulse_direction.resize(5 * static_cast<std::size_t>(contacts));
  momentum_rows.resize(contacts);
  // coloured sweeps: at most 65 colours (64 and one swept by one thread), chunks of
  // kColourChunk rows; components are fewer than velocities
  row_colour.resize(contacts);
  coloured_order.resize(contacts);
  colour_chunk.resize(kColours + 2);
  const std::size_t chunks = contacts / kColourChunk + kColours + 1;
  chunk_begin.resize(chunks + 1);
  chunk_change2.resize(chunks);
  chunk_size2.resize(chunks);
  chunk_failures.resize(chunks);
  const std::size_t colour_slots = std::max(nv, components);
  if (component_colours.size() < colour_slots) component_colours.assign(colour_slots, 0);
  if (v_before.size() < nv) {
    v_before.resize(nv);
    v_direction.resize(nv);
    island_dofs.resize(nv);
    dof_stamp.assign(nv, 0);
    stamp = 0;
  }
}

}  // namespace sweep
