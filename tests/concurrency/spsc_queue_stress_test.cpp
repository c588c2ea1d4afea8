// SpscQueue with a producer and a consumer thread: every item arrives once, in order, intact,
// through a small queue (always near full or empty, so the cached indices are refreshed all the
// time) and the one-slot edge. CI-sized; run under ThreadSanitizer too.
#include <gtest/gtest.h>

#include <cstdint>
#include <memory>
#include <thread>

#include "ioct/concurrency/spsc_queue.hpp"

namespace ioct {
namespace {

// Several words, so a torn hand-over (an item read before it was completely written) shows.
struct Item {
  std::uint64_t sequence = 0;
  std::uint64_t square = 0;
  std::uint64_t complement = 0;
};

void pass_items_in_order(std::size_t capacity, std::uint64_t items) {
  SpscQueue<Item> q(capacity);
  std::thread producer([&] {
    for (std::uint64_t i = 0; i < items;) {
      if (q.push(Item{i, i * i, ~i})) {
        ++i;
      } else {
        std::this_thread::yield();  // full: let the consumer run on a machine of few cores
      }
    }
  });
  std::uint64_t expected = 0;
  std::uint64_t bad = 0;
  std::uint64_t over_capacity = 0;
  while (expected < items) {
    if (q.size() > capacity) ++over_capacity;
    Item item;
    if (!q.pop(item)) {
      std::this_thread::yield();
      continue;
    }
    if (item.sequence != expected || item.square != expected * expected ||
        item.complement != ~expected) {
      ++bad;
    }
    ++expected;
  }
  producer.join();
  EXPECT_EQ(bad, 0u) << "items out of order or torn (capacity " << capacity << ")";
  EXPECT_EQ(over_capacity, 0u);
  EXPECT_TRUE(q.empty());
  Item extra;
  EXPECT_FALSE(q.pop(extra)) << "nothing arrives twice";
}

TEST(SpscQueueStress, ThreeHundredThousandItemsThroughSixtyFourSlots) {
  pass_items_in_order(64, 300'000);
}

TEST(SpscQueueStress, OneHundredThousandItemsThroughOneSlot) {
  pass_items_in_order(1, 100'000);
}

TEST(SpscQueueStress, OwnedItemsAreHandedOverAndFreedExactlyOnce) {
  constexpr int kItems = 100'000;
  SpscQueue<std::unique_ptr<std::uint64_t>> q(16);
  std::thread producer([&] {
    for (int i = 0; i < kItems;) {
      auto item = std::make_unique<std::uint64_t>(static_cast<std::uint64_t>(i));
      while (!q.push(std::move(item))) std::this_thread::yield();
      ++i;
    }
  });
  std::uint64_t expected = 0;
  std::uint64_t bad = 0;
  while (expected < static_cast<std::uint64_t>(kItems)) {
    std::unique_ptr<std::uint64_t> item;
    if (!q.pop(item)) {
      std::this_thread::yield();
      continue;
    }
    if (item == nullptr || *item != expected) ++bad;
    ++expected;
  }
  producer.join();
  EXPECT_EQ(bad, 0u);
}

}  // namespace
}  // namespace ioct
