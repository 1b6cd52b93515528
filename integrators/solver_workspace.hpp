#pragma once
// The memory every contact solver works in, sized between steps (prepare) so that no sweep or
// iteration allocates.
#include <cstdint>
#include <random>
#include <vector>

#include "framework/data.hpp"
#include "integrators/interior_point.hpp"
#include "integrators/mprgp.hpp"
#include "integrators/projected_newton.hpp"

namespace sweep {

// Coloured sweeps: blocks of kColourChunk consecutive rows in kColours colours of blocks that
// share no component (a bit each in a 64-bit mask), then one colour swept by one thread for
// the rest. A block is about 3 us of work on the 2D funnel: long beside a barrier, short
// enough to give each thread several per colour.
constexpr int kColours = 64;
constexpr int kColourChunk = 128;

struct SolverWorkspace {
  // components: the model's count (Model::components), for the coloured sweeps
  void prepare(int contacts, int nv = 0, int components = 0);
  std::vector<int> order;
  std::mt19937 rng;
  std::vector<double> threshold;    // friction stage: mu lambda_N per contact
  std::vector<double> held_normal;  // friction stage: normal velocity after stage 5a
  std::vector<Vector2> offset;      // friction stage: W_T^T v_N per contact
  std::vector<Vector2> coupling;    // friction stage: W_TN / W_NN per contact
  std::vector<Matrix2> schur;       // friction stage: W_TT - W_TN W_NT / W_NN per contact
  // NNCG: the iterate before the sweep and the search direction, per contact and per dof of
  // the island (island_dofs; dof_stamp marks them without clearing between islands)
  std::vector<double> impulse_before, impulse_direction;
  std::vector<int> momentum_rows;  // the rows of those slots: order at the start (shuffles move it)
  VectorX v_before, v_direction;
  std::vector<int> island_dofs, dof_stamp;
  int stamp = 0;
  // coloured sweeps (SolverSettings::parallel_rows): the colours taken at each component (a
  // bit each), each block's colour, the blocks in colour order as chunks (colour_chunk[k] ..
  // colour_chunk[k + 1] for colour k, the serial one k = 64 the last; chunk j is
  // order[chunk_begin[j], chunk_begin[j + 1])) and each chunk's sums
  std::vector<std::uint64_t> component_colours;
  std::vector<int> row_colour, coloured_order;
  std::vector<int> colour_chunk, chunk_begin;
  std::vector<double> chunk_change2, chunk_size2;
  std::vector<int> chunk_failures;
  // the convex stage solvers' (every StageSolver but Nlgs): the program's variables and sets,
  // and per row its variables (-1: none) and their scales
  struct Convex {
    MprgpWorkspace mprgp;
    // one per program, so that a pattern that holds from step to step keeps its analysis
    ProjectedNewtonWorkspace newton_normal, newton_projection, newton_friction;
    InteriorPointWorkspace interior_point;
    SeparableSet set;
    std::vector<double> x;
    std::vector<int> normal_var, tangent_var, rolling_var;
    std::vector<double> normal_scale, rolling_scale, target;
    std::vector<Matrix2> tangent_map;  // physical tangential impulse = tangent_map * x_T
    VectorX v_normal;
    std::vector<int> dofs;  // the velocities the rows reach (QpOperator::dofs)
    std::vector<int> dof_stamp;
    int stamp = 0;
  } convex;
};

}  // namespace sweep
