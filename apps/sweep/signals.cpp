#include "apps/sweep/signals.hpp"

#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <mutex>
#include <set>
#include <thread>

namespace sweep {

namespace {

std::atomic<int> g_signal{0};
std::atomic<int> g_cooperative{0};

// never destroyed: the watchdog may read them while the process exits
std::mutex& partialMutex() {
  static auto* mutex = new std::mutex;
  return *mutex;
}
std::multiset<std::string>& partialFiles() {
  static auto* files = new std::multiset<std::string>;
  return *files;
}

extern "C" void onStopSignal(int signal) {
  int none = 0;
  g_signal.compare_exchange_strong(none, signal);
  stopFlag().store(true);
}

}  // namespace

void removePartialFiles() {
  std::lock_guard<std::mutex> lock(partialMutex());
  for (const std::string& path : partialFiles()) std::remove(path.c_str());
}

namespace {

[[noreturn]] void stopNow() {
  removePartialFiles();
  std::fflush(nullptr);
  _exit(stopExitCode());
}

// Polls for a signal (a handler may only set flags); then stops the process at once outside
// a cooperative scope, or after the grace inside one, unless the process ended first.
void watchdog() {
  constexpr auto kPoll = std::chrono::milliseconds(20);
  while (g_signal.load() == 0) std::this_thread::sleep_for(kPoll);
  const auto deadline = std::chrono::steady_clock::now() + kStopGrace;
  while (g_cooperative.load() > 0 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(kPoll);
  stopNow();
}

}  // namespace

std::atomic<bool>& stopFlag() {
  static std::atomic<bool> flag{false};
  return flag;
}

int stopExitCode() {
  const int signal = g_signal.load();
  return signal == 0 ? 0 : 128 + signal;
}

void installStopSignals() {
  stopFlag();
  partialMutex();
  partialFiles();
  struct sigaction action {};
  action.sa_handler = onStopSignal;
  action.sa_flags = SA_RESTART;  // a write in progress goes on; the flag is polled
  sigemptyset(&action.sa_mask);
  for (int signal : {SIGINT, SIGTERM, SIGHUP}) sigaction(signal, &action, nullptr);
  std::thread(watchdog).detach();
}

CooperativeStop::CooperativeStop() {
  g_cooperative.fetch_add(1);
}
CooperativeStop::~CooperativeStop() {
  g_cooperative.fetch_sub(1);
}

PartialFile::PartialFile(std::string path) : path_(std::move(path)) {
  std::lock_guard<std::mutex> lock(partialMutex());
  partialFiles().insert(path_);
}

PartialFile::~PartialFile() {
  std::lock_guard<std::mutex> lock(partialMutex());
  partialFiles().erase(partialFiles().find(path_));
}

}  // namespace sweep
