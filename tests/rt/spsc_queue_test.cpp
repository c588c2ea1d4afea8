// The single-producer single-consumer queue between the housekeeping and acquisition threads:
// order, capacity, and a producer and a consumer on two threads (also run under TSan).
#include "spsc_queue.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <thread>

namespace ioct::rt {
namespace {

TEST(SpscQueue, KeepsOrderAndRefusesWhenFull) {
  SpscQueue<int, 3> q;
  EXPECT_TRUE(q.empty());
  EXPECT_TRUE(q.push(1));
  EXPECT_TRUE(q.push(2));
  EXPECT_TRUE(q.push(3));
  EXPECT_FALSE(q.push(4)) << "full";
  EXPECT_EQ(q.size(), 3u);
  EXPECT_EQ(q.pop(), 1);
  EXPECT_TRUE(q.push(5));
  EXPECT_EQ(q.pop(), 2);
  EXPECT_EQ(q.pop(), 3);
  EXPECT_EQ(q.pop(), 5);
  EXPECT_FALSE(q.pop().has_value());
}

TEST(SpscQueue, TwoThreadsPassEveryItemOnceInOrder) {
  SpscQueue<std::uint64_t, 16> q;
  constexpr std::uint64_t kItems = 200'000;
  std::thread producer([&] {
    for (std::uint64_t i = 0; i < kItems;) {
      if (q.push(i)) ++i;
    }
  });
  std::uint64_t expected = 0;
  while (expected < kItems) {
    if (const auto v = q.pop()) {
      ASSERT_EQ(*v, expected);
      ++expected;
    }
  }
  producer.join();
  EXPECT_TRUE(q.empty());
}

}  // namespace
}  // namespace ioct::rt
