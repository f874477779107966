// run_beside (core/run_beside.h): both pieces of work run, at once with two threads, in order
// with one; errors come back after both have finished.
#include <gtest/gtest.h>

#include <omp.h>

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

#include "core/run_beside.h"

namespace authalic {
namespace {

// Restores the OpenMP thread count a test changed.
struct ThreadCount {
  int saved = omp_get_max_threads();
  explicit ThreadCount(int n) { omp_set_num_threads(n); }
  ~ThreadCount() { omp_set_num_threads(saved); }
};

TEST(RunBeside, TwoThreadsRunBothAtOnce) {
  const ThreadCount two(2);
  // a waits for b to start: one after the other, a would wait out its 20 s.
  std::atomic<bool> b_started{false};
  bool a_saw_b = false;
  run_beside(
      [&] {
        const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
        while (!b_started.load() && std::chrono::steady_clock::now() < until) std::this_thread::yield();
        a_saw_b = b_started.load();
      },
      [&] { b_started = true; });
  EXPECT_TRUE(a_saw_b);
}

TEST(RunBeside, OneThreadRunsThemInOrder) {
  const ThreadCount one(1);
  std::vector<char> order;
  run_beside([&] { order.push_back('a'); }, [&] { order.push_back('b'); });
  EXPECT_EQ(order, (std::vector<char>{'a', 'b'}));
}

TEST(RunBeside, InsideAParallelRegionItRunsInOrder) {
  const ThreadCount two(2);
  std::vector<char> order[2];
#pragma omp parallel for num_threads(2)
  for (int i = 0; i < 2; ++i) run_beside([&] { order[i].push_back('a'); }, [&] { order[i].push_back('b'); });
  for (const auto& o : order) EXPECT_EQ(o, (std::vector<char>{'a', 'b'}));
}

TEST(RunBeside, ErrorsComeBackAfterBothEndedTheFirstOne) {
  for (int threads : {1, 2}) {
    const ThreadCount n(threads);
    bool b_finished = false;
    try {
      run_beside([] { throw std::runtime_error("a failed"); },
                 [&] {
                   b_finished = true;
                   throw std::logic_error("b failed");
                 });
      ADD_FAILURE() << "no exception with " << threads << " threads";
    } catch (const std::runtime_error& e) {
      EXPECT_STREQ(e.what(), "a failed");
    }
    EXPECT_TRUE(b_finished) << threads << " threads";
    EXPECT_THROW(run_beside([] {}, [] { throw std::logic_error("b failed"); }), std::logic_error);
  }
}

}  // namespace
}  // namespace authalic
