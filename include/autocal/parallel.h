// Independent pieces of work on several threads, with the result of running them in order.
#pragma once

#include <cstddef>
#include <functional>

namespace autocal {

/// The threads forEachIndex uses for `n` pieces of work when asked for `threads` (0: one per
/// core): at least 1, at most `n`.
size_t threadCount(size_t n, int threads);

/// Runs work(0) .. work(n - 1), each once, on threadCount(n, threads) threads (the calling thread
/// alone when that is 1). The pieces must not share anything they change. When pieces throw, the
/// exception of the lowest index is rethrown once every piece has ended, as a loop in index order
/// would have thrown it first.
void forEachIndex(size_t n, int threads, const std::function<void(size_t)>& work);

}  // namespace autocal
