// SpscQueue on one thread: exact capacity, the full and empty edges, wrap-around, items that own
// memory or cannot be copied, and what the destructor does with items still queued.
#include "ioct/concurrency/spsc_queue.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

namespace ioct {
namespace {

TEST(SpscQueue, HoldsExactlyItsCapacityAndRefusesWhenFull) {
  SpscQueue<int> q(3);
  EXPECT_EQ(q.capacity(), 3u);
  EXPECT_TRUE(q.empty());
  EXPECT_TRUE(q.push(1));
  EXPECT_TRUE(q.push(2));
  EXPECT_TRUE(q.push(3));
  EXPECT_FALSE(q.push(4)) << "full at 3 items";
  EXPECT_EQ(q.size(), 3u);
  EXPECT_EQ(q.pop(), 1);
  EXPECT_TRUE(q.push(5));
  EXPECT_EQ(q.pop(), 2);
  EXPECT_EQ(q.pop(), 3);
  EXPECT_EQ(q.pop(), 5);
  EXPECT_FALSE(q.pop().has_value());
  EXPECT_TRUE(q.empty());
}

TEST(SpscQueue, CapacityOneAlternatesFullAndEmpty) {
  SpscQueue<int> q(1);
  for (int i = 0; i < 10; ++i) {
    ASSERT_TRUE(q.push(i));
    ASSERT_FALSE(q.push(-1));
    EXPECT_EQ(q.size(), 1u);
    int out = -2;
    ASSERT_TRUE(q.pop(out));
    EXPECT_EQ(out, i);
    EXPECT_FALSE(q.pop(out));
    EXPECT_EQ(out, i) << "an empty pop leaves the output alone";
  }
}

TEST(SpscQueue, WrapsAroundManyTimesKeepingOrderAndSize) {
  SpscQueue<std::uint64_t> q(5);
  std::uint64_t pushed = 0;
  std::uint64_t popped = 0;
  // Fill levels vary so that the indices wrap at every offset of the slot array.
  for (int round = 0; round < 200; ++round) {
    const std::uint64_t burst = 1 + round % 5;
    while (q.size() + burst > q.capacity()) ASSERT_EQ(q.pop(), popped++);
    for (std::uint64_t i = 0; i < burst; ++i) ASSERT_TRUE(q.push(pushed++));
    ASSERT_EQ(q.size(), pushed - popped);
    for (std::uint64_t i = 0; i + round % 2 < burst; ++i) ASSERT_EQ(q.pop(), popped++);
    ASSERT_EQ(q.size(), pushed - popped);
  }
  while (popped < pushed) ASSERT_EQ(q.pop(), popped++);
  EXPECT_TRUE(q.empty());
}

TEST(SpscQueue, CarriesItemsThatOwnMemoryAndLeavesARefusedOneIntact) {
  SpscQueue<std::string> q(2);
  const std::string long_text(200, 'x');  // beyond the small-string buffer: owns heap memory
  ASSERT_TRUE(q.push(long_text + "1"));
  ASSERT_TRUE(q.emplace(long_text + "2"));
  std::string refused = long_text + "3";
  EXPECT_FALSE(q.push(std::move(refused)));
  EXPECT_EQ(refused, long_text + "3") << "a refused item is not moved from";
  EXPECT_EQ(q.pop(), long_text + "1");
  std::string out;
  ASSERT_TRUE(q.pop(out));
  EXPECT_EQ(out, long_text + "2");
}

TEST(SpscQueue, CarriesMoveOnlyItems) {
  SpscQueue<std::unique_ptr<int>> q(4);
  for (int i = 0; i < 4; ++i) ASSERT_TRUE(q.push(std::make_unique<int>(i)));
  for (int i = 0; i < 4; ++i) {
    const std::optional<std::unique_ptr<int>> item = q.pop();
    ASSERT_TRUE(item.has_value() && *item != nullptr);
    EXPECT_EQ(**item, i);
  }
}

TEST(SpscQueue, DestroysEveryItemItHoldsOnceAndOnlyOnce) {
  const auto tracker = std::make_shared<int>(0);
  {
    SpscQueue<std::shared_ptr<int>> q(8);
    for (int i = 0; i < 5; ++i) ASSERT_TRUE(q.push(tracker));
    EXPECT_EQ(tracker.use_count(), 6);
    EXPECT_TRUE(q.pop().has_value());
    EXPECT_EQ(tracker.use_count(), 5) << "a popped item's slot is destroyed";
  }
  EXPECT_EQ(tracker.use_count(), 1) << "the queue's destructor destroys what is still queued";
}

TEST(SpscQueue, RefusesCapacityZeroAndImpossibleSizesNamingTheValue) {
  try {
    SpscQueue<int> q(0);
    FAIL() << "capacity 0 was taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("capacity = 0"), std::string::npos) << e.what();
  }
  EXPECT_THROW(SpscQueue<int>(std::numeric_limits<std::size_t>::max()), std::length_error);
}

TEST(SpscQueue, KeepsTheProducersAndConsumersWordsOnSeparateCacheLines) {
  // The class is aligned to the false-sharing range, so its producer and consumer halves never
  // share a line with each other or with a neighbouring object.
  EXPECT_GE(alignof(SpscQueue<int>), kFalseSharingRange);
  EXPECT_GE(sizeof(SpscQueue<int>), 4 * kFalseSharingRange);
}

}  // namespace
}  // namespace ioct
