// forEachIndex: every piece once, on the threads asked for, and errors as a loop would give them.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include "autocal/parallel.h"

namespace {

TEST(Parallel, EveryIndexRunsOnceOnTheThreadsAskedFor) {
  for (const size_t threads : {1u, 2u, 3u, 8u}) {
    std::vector<std::atomic<int>> runs(7);
    const size_t together = std::min(runs.size(), threads);
    std::mutex mutex;
    std::condition_variable all_started;
    size_t started = 0;
    bool met = true;
    std::set<std::thread::id> ids;
    autocal::forEachIndex(runs.size(), static_cast<int>(threads), [&](size_t i) {
      ++runs[i];
      std::unique_lock<std::mutex> lock(mutex);
      ids.insert(std::this_thread::get_id());
      // The first pieces wait until as many run at once as there are threads: run one after
      // the other, they would wait in vain.
      if (i < together) {
        ++started;
        all_started.notify_all();
        met = all_started.wait_for(lock, std::chrono::seconds(30), [&] {
          return started >= together;
        }) && met;
      }
    });
    EXPECT_TRUE(met) << together << " pieces never ran at once on " << threads << " threads";
    for (const auto& r : runs) EXPECT_EQ(r.load(), 1) << threads << " threads";
    EXPECT_EQ(ids.size(), together);
    EXPECT_EQ(ids.count(std::this_thread::get_id()), 1u);  // the caller works too
  }
  EXPECT_EQ(autocal::threadCount(3, 0),
            std::min(3u, std::max(1u, std::thread::hardware_concurrency())));
  EXPECT_EQ(autocal::threadCount(0, 4), 1u);
  autocal::forEachIndex(0, 2, [](size_t) { FAIL() << "no piece to run"; });
}

TEST(Parallel, TheLowestIndexsErrorIsRethrownAfterEveryPieceRan) {
  std::vector<std::atomic<int>> runs(6);
  try {
    autocal::forEachIndex(runs.size(), 3, [&](size_t i) {
      ++runs[i];
      if (i == 4) throw std::logic_error("four");
      if (i == 1) throw std::runtime_error("one");
    });
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "one");
  }
  for (const auto& r : runs) EXPECT_EQ(r.load(), 1);
}

}  // namespace
