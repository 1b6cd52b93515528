#pragma once
// What a scene may allocate: Sweep estimates the memory an input asks for before allocating it
// and refuses it (InputError, exit 2) when the estimate exceeds what the process can have, rather
// than running into std::bad_alloc or the kernel's out-of-memory killer partway through.
#include <cstddef>
#include <string>

namespace sweep {

// The memory this process may use: the machine's physical memory, or the address-space or data
// limit (ulimit -v, ulimit -d) when one is lower.
std::size_t memoryLimitBytes();

// Throws InputError "<what> needs about X of memory, more than the Y this process may use (...)"
// when `bytes` exceeds memoryLimitBytes(). `what` names the file, field and value asking for it.
void requireMemory(double bytes, const std::string& what);

// A byte count as a message quotes it: "3.2 GB", "480 MB", "12 kB".
std::string formatBytes(double bytes);

}  // namespace sweep
