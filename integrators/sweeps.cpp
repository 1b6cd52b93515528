#include "integrators/sweeps.hpp"

namespace sweep {

void nextOrder(const SolverSettings& settings, SolverWorkspace& ws, int iteration, int count) {
  if (!settings.shuffle) return;
  if (iteration == 0) ws.rng.seed(settings.seed);
  std::shuffle(ws.order.begin(), ws.order.begin() + count, ws.rng);
}

void colourIsland(const ContactProblem& p, SolverWorkspace& ws, int n) {
  const int blocks = (n + kColourChunk - 1) / kColourChunk;
  for (int block = 0; block < blocks; ++block) {
    const int first = block * kColourChunk, last = std::min(n, first + kColourChunk);
    std::uint64_t used = 0;
    bool wide = false;
    const int slots = static_cast<int>(ws.component_colours.size());
    for (int k = first; k < last; ++k) {
      const std::array<int, 2>& moved = p.row_components[ws.order[k]];
      // a workspace prepared without the model's component count may not reach every one:
      // such a block goes to the serial colour
      if (moved[0] < 0 || moved[0] >= slots || moved[1] >= slots) {
        wide = true;
        continue;
      }
      for (int comp : moved)
        if (comp >= 0) used |= ws.component_colours[comp];
    }
    int colour = kColours;
    if (!wide && ~used != 0) {
      colour = __builtin_ctzll(~used);
      for (int k = first; k < last; ++k)
        for (int comp : p.row_components[ws.order[k]])
          if (comp >= 0) ws.component_colours[comp] |= std::uint64_t{1} << colour;
    }
    ws.row_colour[block] = colour;  // per block here
  }
  for (int k = 0; k < n; ++k)  // the masks back to zero for the next island
    for (int comp : p.row_components[ws.order[k]])
      if (comp >= 0 && comp < static_cast<int>(ws.component_colours.size()))
        ws.component_colours[comp] = 0;
  // the blocks colour after colour (in their order within one): chunk j is the j-th
  int chunk = 0, row = 0;
  for (int colour = 0; colour <= kColours; ++colour) {
    ws.colour_chunk[colour] = chunk;
    for (int block = 0; block < blocks; ++block) {
      if (ws.row_colour[block] != colour) continue;
      ws.chunk_begin[chunk++] = row;
      const int first = block * kColourChunk, last = std::min(n, first + kColourChunk);
      for (int k = first; k < last; ++k) ws.coloured_order[row++] = ws.order[k];
    }
  }
  ws.colour_chunk[kColours + 1] = chunk;
  ws.chunk_begin[chunk] = row;
  std::copy(ws.coloured_order.begin(), ws.coloured_order.begin() + n, ws.order.begin());
}

void prepareNncg(const SolverSettings& settings, const ContactProblem& p, const VectorX& v,
                 SolverWorkspace& ws) {
  if (settings.acceleration == NlgsAcceleration::Nncg &&
      (ws.v_before.size() < v.size() ||
       ws.impulse_before.size() < 5 * static_cast<std::size_t>(p.size())))
    ws.prepare(p.size(), static_cast<int>(v.size()));
}

int selectIsland(const ContactProblem& p, int island, SolverWorkspace& ws) {
  if (p.island_begin.empty()) {
    for (int c = 0; c < p.size(); ++c) ws.order[c] = c;
    return p.size();
  }
  const int begin = p.island_begin[island], end = p.island_begin[island + 1];
  std::copy(p.island_rows.begin() + begin, p.island_rows.begin() + end, ws.order.begin());
  return end - begin;
}

void warmStartRollingRow(const ContactProblem& p, std::vector<Vector2>& R, int c, VectorX& v) {
  if (p.rolling_bound[c] > 0.0)
    p.applyRolling(c, R[c], v);
  else
    R[c].setZero();
}

void warmStartRolling(const ContactProblem& p, std::vector<Vector2>* R, VectorX& v) {
  if (R == nullptr || !p.rolling) return;
  for (int c = 0; c < p.size(); ++c) warmStartRollingRow(p, *R, c, v);
}

void warmStart(const ContactProblem& p, const std::vector<Vector3>& P, std::vector<Vector2>* R,
               const int* order, int count, VectorX& v) {
  for (int k = 0; k < count; ++k) p.applyImpulse(order[k], P[order[k]], v);
  if (R == nullptr || !p.rolling) return;
  for (int k = 0; k < count; ++k) warmStartRollingRow(p, *R, order[k], v);
}

void mergeIsland(SolverStats& total, const SolverStats& island) {
  total.iterations = std::max(total.iterations, island.iterations);
  total.updates += island.updates;
  total.residual = std::max(total.residual, island.residual);
  total.local_failures += island.local_failures;
  if (island.status == SolverStatus::Failed ||
      (island.status == SolverStatus::MaxIterations && total.status == SolverStatus::Converged))
    total.status = island.status;
}

}  // namespace sweep
