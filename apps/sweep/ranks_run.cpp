#include "apps/sweep/ranks_run.hpp"

#include <chrono>
#include <cstdlib>
#include <stdexcept>
#include <vector>

#include "apps/sweep/run_recorder.hpp"
#include "apps/sweep/signals.hpp"
#include "framework/energy.hpp"
#include "framework/error.hpp"

namespace sweep {

int launchedRanks(std::string* variable) {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "MV2_COMM_WORLD_SIZE"}) {
    const char* value = std::getenv(name);
    if (value == nullptr) continue;
    const long size = std::atol(value);
    if (size < 1 || size > 1 << 20) continue;
    if (variable != nullptr) *variable = std::string(name) + "=" + value;
    return static_cast<int>(size);
  }
  return 1;
}

void agreeOnRanks(const RankGroup& ranks, const std::exception_ptr& error) {
  std::string message;
  double code = 0.0;  // 2: an InputError, 1: any other failure
  if (error) {
    try {
      std::rethrow_exception(error);
    } catch (const InputError& e) {
      message = e.what();
      code = 2.0;
    } catch (const std::exception& e) {
      message = e.what();
      code = 1.0;
    } catch (...) {
      message = "an unknown failure";
      code = 1.0;
    }
  }
  if (ranks.size() == 1) {
    if (error) std::rethrow_exception(error);
    return;
  }
  const std::vector<double> codes = ranks.gather({code});
  int failing = -1;
  for (std::size_t r = 0; r < codes.size() && failing < 0; ++r)
    if (codes[r] > 0.0) failing = static_cast<int>(r);
  if (failing < 0) return;
  ranks.broadcast(message, failing);
  const std::string where = failing == 0 ? "" : "rank " + std::to_string(failing) + ": ";
  if (codes[static_cast<std::size_t>(failing)] > 1.0) throw InputError(where + message);
  throw std::runtime_error(where + message);
}

namespace {

// The whole state's energy (kinetic + potential), as TimeStepper::energy computes it.
double energyOf(const Model& model, const VectorX& q, const VectorX& v) {
  Data data(model);
  return kineticEnergy(model, data, q, v) + potentialEnergy(model, data, q);
}

// A failure on this rank alone: every rank ends, and this one's partial files go first.
[[noreturn]] void abortRanks(const RankGroup& ranks, const std::string& message, int code) {
  removePartialFiles();
  ranks.abort(("sweep: failed on rank " + std::to_string(ranks.rank()) + ": " + message).c_str(),
              code);
}

}  // namespace

RunSummary runSceneOnRanks(const RankGroup& ranks, const Scene& scene, const RunSettings& settings,
                           const RunOptions& options, const DistributedSettings& distributed) {
  const bool root = ranks.rank() == 0;
  const double t_start = options.start ? options.start->t : 0.0;
  std::unique_ptr<DistributedStepper> stepper;
  std::unique_ptr<RunRecorder> recorder;
  RunOptions rank_options = options;
  if (!root) {
    rank_options.progress = false;
    rank_options.log = nullptr;
  }
  long steps = 0;
  {
    std::exception_ptr error;
    try {
      settings.scheme.validate();
      steps = stepCount(t_start, settings.t_end, settings.scheme.h);
      stepper = std::make_unique<DistributedStepper>(ranks, scene.model, scene.cmodel,
                                                     settings.scheme, distributed);
      // rank 0 writes the files: only it checks and opens them
      recorder = std::make_unique<RunRecorder>(
          scene, settings, rank_options, t_start, steps, root,
          std::vector<std::string>{"bytes_sent", "shared_bodies", "imbalance", "carried",
                                   "handed_over"});
    } catch (...) {
      error = std::current_exception();
    }
    agreeOnRanks(ranks, error);
  }
  // snapshots are due on every rank alike (the same settings), and gathered from all
  const bool snapshots = !options.out_dir.empty() &&
                         (settings.output.vtk_every > 0 || settings.output.vtk_interval > 0.0);
  VectorX q, v;
  std::vector<Contact> contacts;
  std::vector<Vector3> impulses;
  auto snapshot = [&] {
    stepper->gatherState(q, v);
    stepper->gatherContacts(contacts, impulses);
    if (root)
      recorder->snapshot(
          SnapshotView{stepper->time(), settings.scheme.h, q, v, contacts, impulses});
  };
  RunSummary& summary = recorder->summary();
  summary.ranks = ranks.size();
  try {
    if (options.start)
      stepper->reset(t_start, options.start->q, options.start->v);
    else
      stepper->reset(0.0, scene.q0, scene.v0);
    if (root)
      summary.energy_initial = options.start
                                   ? energyOf(scene.model, options.start->q, options.start->v)
                                   : energyOf(scene.model, scene.q0, scene.v0);
    if (snapshots) snapshot();
  } catch (const InputError&) {
    throw;  // the distributed step's checks at reset: on every rank alike
  } catch (const std::exception& e) {
    abortRanks(ranks, e.what(), 1);
  }

  recorder->startClock();
  double bytes = 0.0, shared = 0.0;
  std::vector<double> verdict(2);
  for (long k = 0; k < steps; ++k) {
    try {
      stepper->step();
    } catch (const RunawayError& e) {  // thrown on every rank (DistributedStepper::step)
      summary.failure = e.what();
      break;
    } catch (const CollectiveError&) {
      throw;
    } catch (const std::exception& e) {
      abortRanks(ranks, e.what(), 1);
    }
    const StepStats& s = stepper->stats();
    // the reduced statistics, the same on every rank: every rank throws
    if (divergedSolve(s)) throw CollectiveError(divergedSolveMessage(s));
    const DistributedStats& d = stepper->distributedStats();
    bytes += static_cast<double>(d.bytes_sent);
    shared += static_cast<double>(d.shared_bodies);
    summary.imbalance_max = std::max(summary.imbalance_max, d.imbalance);
    bool due = false;
    try {
      due = recorder->addStep(
          s, {static_cast<double>(d.bytes_sent), static_cast<double>(d.shared_bodies), d.imbalance,
              static_cast<double>(d.carried), static_cast<double>(d.handed_over)});
    } catch (const std::exception& e) {
      abortRanks(ranks, e.what(), 1);  // a stats.csv rank 0 cannot write
    }
    // one verdict for every rank: a snapshot (rank 0's recorder says), and a stop (a signal
    // reaches the ranks at different steps)
    verdict[0] = due ? 1.0 : 0.0;
    verdict[1] = options.stop != nullptr && options.stop->load() ? 1.0 : 0.0;
    ranks.max(verdict);
    if (verdict[0] > 0.0) {
      try {
        snapshot();
      } catch (const std::exception& e) {
        abortRanks(ranks, e.what(), 1);
      }
    }
    const bool stopping = verdict[1] > 0.0;
    recorder->progress(s.step, s.t, k + 1 == steps || stopping);
    if (stopping) {
      summary.interrupted = true;
      break;
    }
  }
  if (summary.steps > 0) {
    summary.bytes_per_step = bytes / static_cast<double>(summary.steps);
    summary.shared_bodies_per_step = shared / static_cast<double>(summary.steps);
  }
  try {
    stepper->gatherState(q, v);
    const double energy = root ? energyOf(scene.model, q, v) : 0.0;
    // the other ranks' CPU time too: the run's cost, as the single process's counts every
    // thread
    const std::vector<double> cpu = ranks.gather({recorder->cpuSeconds()});
    double others = 0.0;
    for (int r = 1; r < ranks.size(); ++r) others += cpu[static_cast<std::size_t>(r)];
    recorder->finish(energy, stepper->time(), q, v, others);
  } catch (const std::exception& e) {
    abortRanks(ranks, e.what(), 1);
  }
  return summary;
}

}  // namespace sweep
