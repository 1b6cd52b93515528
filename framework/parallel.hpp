#pragma once

#include <algorithm>
#include <vector>

#include "framework/model.hpp"

namespace sweep {

// Loops whose items each write only their own entries run on threads from this many items on:
// any split of them gives the same bits, and smaller loops do not pay for a parallel region
// (docs/architecture.md, "Threads are OpenMP").
constexpr long kParallelItems = 8192;

// body(i) for i in [0, n), split statically over `threads` threads, or a plain loop on this
// one for threads <= 1. A serial loop never enters a parallel construct: an OpenMP `if(false)`
// region still makes a one-thread team, which libgomp allocates and ends with a futex system
// call, a third of the step time of a 20-contact scene (docs/architecture.md, "Threads are
// OpenMP").
template <class Index, class Body>
void parallelFor(Index n, int threads, Body&& body) {
  if (threads <= 1) {
    for (Index i = 0; i < n; ++i) body(i);
    return;
  }
#pragma omp parallel for schedule(static) num_threads(threads)
  for (Index i = 0; i < n; ++i) body(i);
}

// body(i) for i in [0, n), on up to `threads` threads from kParallelItems items on: for loops
// whose items write only their own entries.
template <class Index, class Body>
void forEachIndex(Index n, int threads, Body&& body) {
  parallelFor(n, n >= kParallelItems ? threads : 1, body);
}

// visit(c) for each component c with bodies (the trees; systems by their equations, which
// may call back into an interpreter, are left to the caller), on up to `threads` threads once
// there are kParallelItems of them: a granular scene, a particle each.
// With a subset (Data::componentSubset), the trees it lists only.
template <class Visit>
void forEachBodyComponent(const Model& model, const std::vector<int>* subset, int threads,
                          Visit&& visit) {
  if (subset != nullptr) {
    const int count = static_cast<int>(subset->size());
    forEachIndex(count, threads, [&](int i) { visit((*subset)[i]); });
    return;
  }
  const int count = static_cast<int>(model.components.size() - model.systems.size());
  forEachIndex(count, threads, visit);
}
template <class Visit>
void forEachBodyComponent(const Model& model, int threads, Visit&& visit) {
  forEachBodyComponent(model, nullptr, threads, visit);
}

// Folds add(i, part) over i in [0, n) chunk by chunk (kReduceChunk items each, every part
// starting from `init`), then combine(total, part) over the chunks in their order, total
// starting from `init`: the same bits for every thread count, and those of a plain loop when
// n <= kReduceChunk. The chunks go on threads from kParallelItems items on.
constexpr long kReduceChunk = 4096;
// `parts` keeps the chunks' parts (no allocation once its capacity suffices: for the loops
// inside a solver's iterations). `chunk` items per part: a loop run many times over a few
// thousand items (a solver's) takes smaller chunks than kReduceChunk, so that its parts split
// evenly over the threads.
template <class T, class Add, class Combine>
T reduceInChunks(long n, int threads, const T& init, std::vector<T>& parts, Add&& add,
                 Combine&& combine, long chunk = kReduceChunk) {
  const long chunks = (n + chunk - 1) / chunk;
  T total = init;
  if (threads <= 1 || n < kParallelItems) {
    for (long c = 0; c < chunks; ++c) {
      T part = init;
      for (long i = c * chunk; i < std::min(n, (c + 1) * chunk); ++i) add(i, part);
      combine(total, part);
    }
    return total;
  }
  parts.assign(chunks, init);
  // each part summed in a local and stored once: parts of neighbouring chunks share a cache
  // line, which two threads writing at every item would pass back and forth
#pragma omp parallel for schedule(static) num_threads(threads)
  for (long c = 0; c < chunks; ++c) {
    T part = init;
    for (long i = c * chunk; i < std::min(n, (c + 1) * chunk); ++i) add(i, part);
    parts[c] = part;
  }
  for (const T& part : parts) combine(total, part);
  return total;
}
template <class T, class Add, class Combine>
T reduceInChunks(long n, int threads, const T& init, Add&& add, Combine&& combine) {
  std::vector<T> parts;
  return reduceInChunks(n, threads, init, parts, add, combine);
}

// reduceInChunks for one sum: add(i, sum) adds item i's terms to sum
template <class Add>
double sumInChunks(long n, int threads, Add&& add) {
  return reduceInChunks(n, threads, 0.0, add, [](double& total, double part) { total += part; });
}
template <class Add>
double sumInChunks(long n, int threads, std::vector<double>& parts, Add&& add) {
  return reduceInChunks(n, threads, 0.0, parts, add,
                        [](double& total, double part) { total += part; });
}

}  // namespace sweep
