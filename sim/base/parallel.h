#pragma once
// A minimal parallel loop for the simulation's element passes: [0, n) split into `threads`
// contiguous chunks, one std::thread each (the calling thread takes the first). Each chunk gets its
// index, so a pass can accumulate into per-thread buffers instead of locking.
#include <algorithm>
#include <cstddef>
#include <exception>
#include <thread>
#include <vector>

namespace handson {

/// Threads to use for the simulation's parallel passes: `requested` when > 0, else the machine's
/// hardware threads (at least 1, at most 16).
inline int simulationThreads(int requested = 0) {
  if (requested > 0) return std::min(requested, 64);
  return int(std::clamp(std::thread::hardware_concurrency(), 1u, 16u));
}

/// Calls fn(begin, end, chunk) for `threads` chunks covering [0, n); returns when all are done. An
/// exception thrown in any chunk is rethrown here (the first one).
template <class Fn>
void parallelChunks(std::size_t n, int threads, Fn&& fn) {
  threads = std::max(1, std::min<int>(threads, int(std::max<std::size_t>(n, 1))));
  if (threads == 1) {
    fn(std::size_t(0), n, 0);
    return;
  }
  std::vector<std::exception_ptr> errors(static_cast<std::size_t>(threads));
  std::vector<std::thread> pool;
  auto chunk = [&](int t) {
    try {
      fn(n * std::size_t(t) / std::size_t(threads), n * std::size_t(t + 1) / std::size_t(threads), t);
    } catch (...) {
      errors[std::size_t(t)] = std::current_exception();
    }
  };
  for (int t = 1; t < threads; ++t) pool.emplace_back(chunk, t);
  chunk(0);
  for (auto& th : pool) th.join();
  for (auto& e : errors)
    if (e) std::rethrow_exception(e);
}

}  // namespace handson
