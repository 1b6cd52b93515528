#pragma once
// SIGINT, SIGTERM and SIGHUP stop every command within about a second, with exit code 128 + the
// signal (130, 143, 129) and its outputs whole or absent:
//   - a run's or a bench's loop polls stopFlag() between steps and ends cleanly (the summary
//     written, the files renamed into place), inside a CooperativeStop scope;
//   - anywhere else (check, export, view, building a scene) and in a step that does not end
//     within kStopGrace, a watchdog thread removes the partial files that are open
//     (PartialFile) and ends the process with that code.
#include <atomic>
#include <chrono>
#include <string>

namespace sweep {

inline constexpr std::chrono::milliseconds kStopGrace{1000};

// The handlers and the watchdog; call once, before the command starts.
void installStopSignals();
// Set by the first signal; what the loops poll.
std::atomic<bool>& stopFlag();
// 128 + the signal received (0 while none).
int stopExitCode();

// While one lives, a signal gives the command kStopGrace to stop by itself.
class CooperativeStop {
 public:
  CooperativeStop();
  ~CooperativeStop();
  CooperativeStop(const CooperativeStop&) = delete;
  CooperativeStop& operator=(const CooperativeStop&) = delete;
};

// Removes every partial file open now: before a process ends another way (MPI_Abort).
void removePartialFiles();

// A file being written under a temporary name: removed by the watchdog if the process is
// stopped before the owner renames it into place (or removes it).
class PartialFile {
 public:
  explicit PartialFile(std::string path);
  ~PartialFile();
  PartialFile(const PartialFile&) = delete;
  PartialFile& operator=(const PartialFile&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

}  // namespace sweep
