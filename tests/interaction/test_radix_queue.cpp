// The radix heap behind region growing's front against std::priority_queue: the same keys come out
// in the same order for a random monotone search (every push at least the last key taken).
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <queue>
#include <random>

#include "interaction/radix_queue.h"

using namespace handson;

TEST(RadixQueue, TakesKeysInTheOrderAHeapDoes) {
  std::mt19937 rng(7);
  RadixQueue<int> radix;
  std::priority_queue<std::uint32_t, std::vector<std::uint32_t>, std::greater<>> heap;
  std::uint32_t last = 0;
  int id = 0;
  for (int step = 0; step < 20000; ++step) {
    const int pushes = int(rng() % 4);
    for (int p = 0; p < pushes; ++p) {
      // Equal keys, small steps and jumps across many bits, all >= the last key taken.
      const std::uint64_t jumps[3] = {0, rng() % 16, (rng() % 1000u) << (rng() % 20)};
      const std::uint32_t key = std::uint32_t(std::min<std::uint64_t>(last + jumps[rng() % 3], 0xfffffffeu));
      radix.push(key, id++);
      heap.push(key);
    }
    ASSERT_EQ(radix.size(), heap.size());
    if (heap.empty() || rng() % 3 == 0) continue;
    ASSERT_EQ(radix.top().first, heap.top());
    last = heap.top();
    radix.pop();
    heap.pop();
  }
  while (!heap.empty()) {
    ASSERT_EQ(radix.top().first, heap.top());
    radix.pop();
    heap.pop();
  }
  EXPECT_TRUE(radix.empty());
  radix.push(5, 1);
  radix.clear();
  EXPECT_TRUE(radix.empty());
  radix.push(0, 2);  // after clear() any key may come first again
  EXPECT_EQ(radix.top().second, 2);
}
