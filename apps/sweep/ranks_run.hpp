#pragma once
// `mpirun -np N sweep run SCENE`: a run on N MPI ranks (integrators/distributed_stepper.hpp).
// Every rank reads the scene and holds the whole model; rank 0 writes the same files as the
// single process (stats.csv with three more columns, summary.json with a "ranks" entry,
// final_state.csv, the layer's files, the VTK snapshots and their collections) from the state
// gathered from the ranks, and prints the progress. A saved state starts a run on any number
// of ranks.
#include <exception>
#include <string>

#include "apps/sweep/run.hpp"
#include "contact/domain_decomposition.hpp"
#include "integrators/distributed_stepper.hpp"

namespace sweep {

// The number of processes the MPI launcher that started this one names in the environment
// (Open MPI, MPICH's Hydra, MVAPICH, Slurm's PMI); 1 when none does. `variable`, when given,
// gets the name and value that said so ("OMPI_COMM_WORLD_SIZE=4").
int launchedRanks(std::string* variable = nullptr);

// Every rank's outcome of a phase each runs by itself (reading files, building the scene):
// collective. When any rank failed, every rank throws the lowest failing rank's error, an
// InputError as an InputError and anything else as std::runtime_error, so that they all end
// the same way rather than some waiting for the others in the next collective.
void agreeOnRanks(const RankGroup& ranks, const std::exception_ptr& error);

// Collective: runs `scene` on the ranks from t = 0 (or options.start's t) to settings.t_end.
// Throws InputError (on every rank alike) for a scene outside the distributed step's scope or
// bad settings. A body that runs away ends the run as in runScene (summary.failure, the
// outputs written). A state no longer finite or a solve that diverged throws on every rank. A
// failure found on one rank only (an output that cannot be written, a periodic reach beyond
// half the period) ends every rank through MPI_Abort, after the message on standard error and
// with the partial files removed. The summary is whole on rank 0.
RunSummary runSceneOnRanks(const RankGroup& ranks, const Scene& scene, const RunSettings& settings,
                           const RunOptions& options, const DistributedSettings& distributed = {});

}  // namespace sweep
