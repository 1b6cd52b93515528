#include "framework/memory.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>

#include "framework/error.hpp"

namespace sweep {

namespace {

double physicalMemoryBytes() {
  const long pages = sysconf(_SC_PHYS_PAGES);
  const long page_size = sysconf(_SC_PAGE_SIZE);
  if (pages <= 0 || page_size <= 0) return 1e18;  // unknown: let the allocator decide
  return static_cast<double>(pages) * static_cast<double>(page_size);
}

double resourceLimitBytes(int resource) {
  rlimit limit{};
  if (getrlimit(resource, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return 1e18;
  return static_cast<double>(limit.rlim_cur);
}

const char* limitingResource() {
  const double physical = physicalMemoryBytes();
  const double address = resourceLimitBytes(RLIMIT_AS);
  const double data = resourceLimitBytes(RLIMIT_DATA);
  if (address < physical && address <= data) return "the address-space limit, ulimit -v";
  if (data < physical) return "the data-segment limit, ulimit -d";
  return "the machine's physical memory";
}

}  // namespace

std::size_t memoryLimitBytes() {
  const double bytes = std::min(
      {physicalMemoryBytes(), resourceLimitBytes(RLIMIT_AS), resourceLimitBytes(RLIMIT_DATA)});
  return static_cast<std::size_t>(std::min(bytes, 1e18));
}

std::string formatBytes(double bytes) {
  const char* units[] = {"bytes", "kB", "MB", "GB", "TB", "PB", "EB"};
  int unit = 0;
  while (bytes >= 1000.0 && unit < 6) {
    bytes /= 1000.0;
    ++unit;
  }
  char text[48];
  std::snprintf(text, sizeof text, unit == 0 ? "%.0f %s" : "%.3g %s", bytes, units[unit]);
  return text;
}

void requireMemory(double bytes, const std::string& what) {
  const double limit = static_cast<double>(memoryLimitBytes());
  if (!(bytes <= limit))
    throw InputError(what + " needs about " + formatBytes(bytes) + " of memory, more than the " +
                     formatBytes(limit) + " this process may use (" + limitingResource() + ")");
}

}  // namespace sweep
