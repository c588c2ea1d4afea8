// The search along a B-scan against the classic shortest path through the same graph (one node
// per A-scan and depth with its cost, edges between neighbouring A-scans whose depths differ by at
// most the step bound, weighted by the step penalty), computed here the plain way: one pass from
// the left, every edge relaxed. solve_path, which runs from both ends and joins in the middle,
// must find a path of the same total that keeps the step bound.
#include <gtest/gtest.h>

#include <algorithm>
#include <climits>
#include <cstdint>
#include <random>
#include <vector>

#include "ioct/gpu/segmentation/column_math.hpp"
#include "ioct/gpu/segmentation/cpu_segmenter.hpp"

namespace ioct::gpu::segmentation {
namespace {

struct Graph {
  std::int32_t columns = 0;
  std::int32_t states = 0;
  std::int32_t max_step = 0;
  std::int32_t penalty = 0;
  std::vector<std::int32_t> origin;
  std::vector<std::int32_t> cost;
};

// Least total over every path, by relaxing every edge once from the left.
std::int64_t shortest_path_total(const Graph& g) {
  constexpr std::int64_t kInfinity = LLONG_MAX / 4;
  std::vector<std::int64_t> best(g.cost.begin(), g.cost.begin() + g.states);
  for (std::int32_t a = 1; a < g.columns; ++a) {
    std::vector<std::int64_t> next(static_cast<std::size_t>(g.states), kInfinity);
    for (std::int32_t s = 0; s < g.states; ++s) {
      for (std::int32_t from = 0; from < g.states; ++from) {
        const std::int32_t step = (g.origin[a] + s) - (g.origin[a - 1] + from);
        if (std::abs(step) > g.max_step || best[from] >= kInfinity) continue;
        next[s] = std::min(next[s], best[from] + std::int64_t{g.penalty} * std::abs(step) +
                                        g.cost[a * g.states + s]);
      }
    }
    best.swap(next);
  }
  return *std::min_element(best.begin(), best.end());
}

// The total of a given path, failing the test when it breaks the graph's rules.
std::int64_t path_total(const Graph& g, const std::vector<std::int32_t>& path) {
  std::int64_t total = 0;
  for (std::int32_t a = 0; a < g.columns; ++a) {
    const std::int32_t s = path[a] - g.origin[a];
    EXPECT_GE(s, 0) << "column " << a;
    EXPECT_LT(s, g.states) << "column " << a;
    if (s < 0 || s >= g.states) return LLONG_MAX;
    total += g.cost[a * g.states + s];
    if (a > 0) {
      const std::int32_t step = path[a] - path[a - 1];
      EXPECT_LE(std::abs(step), g.max_step) << "column " << a;
      total += std::int64_t{g.penalty} * std::abs(step);
    }
  }
  return total;
}

Graph random_graph(std::mt19937& rng, std::int32_t columns, std::int32_t states,
                   std::int32_t max_step, bool moving_band) {
  Graph g;
  g.columns = columns;
  g.states = states;
  g.max_step = max_step;
  g.penalty = std::uniform_int_distribution<std::int32_t>(0, 12)(rng);
  g.origin.resize(static_cast<std::size_t>(columns));
  std::int32_t o = 100;
  for (std::int32_t a = 0; a < columns; ++a) {
    if (moving_band) o += std::uniform_int_distribution<std::int32_t>(-max_step, max_step)(rng);
    g.origin[a] = o;
  }
  // Costs in the range the evidence takes, with many ties (coarse values).
  std::uniform_int_distribution<std::int32_t> cost(-60, 20);
  g.cost.resize(static_cast<std::size_t>(columns) * states);
  for (std::int32_t& c : g.cost) c = cost(rng) * 4;
  return g;
}

// solve_path over a graph, with workspaces of its own.
std::vector<std::int32_t> solve(const Graph& g) {
  std::vector<std::int32_t> forward, backward, next, path(static_cast<std::size_t>(g.columns));
  std::vector<std::int8_t> steps;
  solve_path(g.columns, g.states, g.origin.data(), g.cost.data(), g.max_step, g.penalty,
             path.data(), forward, backward, next, steps);
  return path;
}

TEST(PathSearch, FindsTheShortestPathOfTheClassicGraph) {
  const unsigned seed = std::random_device{}();
  SCOPED_TRACE("seed " + std::to_string(seed));
  std::mt19937 rng(seed);
  std::vector<std::int32_t> forward, backward, next;
  std::vector<std::int8_t> steps;
  for (int trial = 0; trial < 300; ++trial) {
    const std::int32_t columns = std::uniform_int_distribution<std::int32_t>(1, 70)(rng);
    const std::int32_t states = std::uniform_int_distribution<std::int32_t>(1, 40)(rng);
    const std::int32_t max_step = std::uniform_int_distribution<std::int32_t>(1, 6)(rng);
    const Graph g = random_graph(rng, columns, states, max_step, trial % 2 == 1);
    std::vector<std::int32_t> path(static_cast<std::size_t>(columns));
    solve_path(columns, states, g.origin.data(), g.cost.data(), max_step, g.penalty, path.data(),
               forward, backward, next, steps);
    ASSERT_EQ(path_total(g, path), shortest_path_total(g))
        << "trial " << trial << ": " << columns << " columns, " << states << " states, step "
        << max_step << ", penalty " << g.penalty;
  }
}

TEST(PathSearch, FollowsAStepWithinTheBoundAndBridgesAFlatGap) {
  // A bright line at depth 10 that steps to 13 at column 20, with no evidence at all in columns
  // 30..39: the path follows the step and stays at 13 across the gap (every step costs).
  Graph g;
  g.columns = 60;
  g.states = 30;
  g.max_step = 3;
  g.penalty = 4;
  g.origin.assign(60, 0);
  g.cost.assign(60 * 30, 0);
  for (std::int32_t a = 0; a < 60; ++a) {
    if (a >= 30 && a < 40) continue;
    g.cost[a * 30 + (a < 20 ? 10 : 13)] = -100;
  }
  const std::vector<std::int32_t> path = solve(g);
  for (std::int32_t a = 0; a < 60; ++a) EXPECT_EQ(path[a], a < 20 ? 10 : 13) << "column " << a;
}

TEST(PathSearch, DoesNotStepFurtherThanTheBoundEvenForMuchEvidence) {
  // The evidence jumps by 10 states; with a bound of 2 the path may not follow it in one step.
  Graph g;
  g.columns = 2;
  g.states = 20;
  g.max_step = 2;
  g.penalty = 0;
  g.origin.assign(2, 0);
  g.cost.assign(40, 0);
  g.cost[0 * 20 + 2] = -50;
  g.cost[1 * 20 + 12] = -1000;
  const std::vector<std::int32_t> path = solve(g);
  EXPECT_EQ(path[1], 12);
  EXPECT_LE(std::abs(path[1] - path[0]), 2);
  EXPECT_EQ(path_total(g, path), shortest_path_total(g));
}

TEST(PathSearch, ABandThatJumpsPastEveryStateLeavesThePathInTheBand) {
  // Between columns 1 and 2 the band moves 100 px deeper with 10 states and a bound of 2: no
  // state of column 2 on is reachable from the left, and none reaches the middle from both
  // sides. There is no path; the trace back must still stay in the band (and in the steps).
  const Graph g{.columns = 8,
                .states = 10,
                .max_step = 2,
                .penalty = 1,
                .origin = {0, 0, 100, 100, 100, 100, 100, 100},
                .cost = std::vector<std::int32_t>(8 * 10, 0)};
  const std::vector<std::int32_t> path = solve(g);
  for (std::int32_t a = 0; a < g.columns; ++a) {
    EXPECT_GE(path[a], g.origin[a]) << "column " << a;
    EXPECT_LT(path[a], g.origin[a] + g.states) << "column " << a;
  }
  EXPECT_EQ(detail::state_before(3, 100, 0, 10), 9);
  EXPECT_EQ(detail::state_before(3, -100, 0, 10), 0);
  EXPECT_EQ(detail::state_before(3, 2, 1, 10), 4);
}

TEST(PathSearch, BestStepPrefersTheSmallestStepAmongEqualTotals) {
  const std::int32_t previous[5] = {7, 7, 7, 7, 7};
  int step = 99;
  EXPECT_EQ(detail::best_step(previous, 5, 2, 0, 2, 0, &step), 7);
  EXPECT_EQ(step, 0);
  const std::int32_t lower[5] = {7, 3, 9, 3, 7};
  EXPECT_EQ(detail::best_step(lower, 5, 2, 0, 2, 0, &step), 3);
  // States 1 and 3 tie; the step is this depth minus the neighbour's, tried in the order 0, -1,
  // +1: -1 (from state 3) comes first.
  EXPECT_EQ(step, -1);
}

// The CUDA kernels step over keys in padded rows (best_step_key), the CPU over totals (best_step):
// the same total, the same step (as its place in the order tried), for totals up to the largest a
// search can reach, unreachable states, ties, and shifts that put every candidate outside the band.
template <int kStep>
void expect_keyed_steps_equal(std::mt19937& rng) {
  SCOPED_TRACE("step bound " + std::to_string(kStep));
  constexpr int kStates = 40;
  constexpr int kPad = detail::kStepKeyPad;
  constexpr auto kLargest = static_cast<std::int32_t>(detail::kLargestHalfTotal);
  std::vector<std::int32_t> totals(kStates);
  std::vector<std::int32_t> keys(kStates + 2 * kPad, detail::kUnreachableKey);
  for (int trial = 0; trial < 2000; ++trial) {
    // Few distinct values and small penalties in some trials (ties between steps of different
    // sizes), the whole range in others.
    const bool ties = trial % 3 == 0;
    const std::int32_t spread = ties ? 4 : kLargest;
    std::uniform_int_distribution<std::int32_t> total(-spread, spread);
    for (int s = 0; s < kStates; ++s) {
      totals[s] = rng() % 7 == 0 ? detail::kUnreachable : total(rng);
      keys[kPad + s] = detail::step_key_of(totals[s]);
    }
    const int s = static_cast<int>(rng() % kStates);
    const int shift =
        std::uniform_int_distribution<int>(-kStates - 3 * kStep, kStates + 3 * kStep)(rng);
    const int penalty = std::uniform_int_distribution<int>(0, ties ? 4 : 2 * kMaxStepPenalty)(rng);
    const std::int32_t cost =
        std::uniform_int_distribution<std::int32_t>(-5000, detail::kOutsideCost)(rng);
    int order = 99;
    int step = 99;
    const std::int32_t key = detail::best_step_key<kStep>(
        keys.data() + kPad, detail::step_key_base<kStep>(kStates, s, shift),
        detail::step_key_offsets<kStep>(penalty), &order);
    const std::int32_t best =
        detail::best_step(totals.data(), kStates, s, shift, kStep, penalty, &step);
    ASSERT_EQ(detail::total_of_step_key(key), best)
        << "trial " << trial << ", state " << s << ", shift " << shift << ", penalty " << penalty;
    // The step as its place in the order tried (0 where none reaches the state, as best_step's 0).
    ASSERT_GE(order, 0) << "trial " << trial;
    ASSERT_LT(order, 2 * kStep + 1) << "trial " << trial;
    ASSERT_EQ(detail::nearest_first(order), step) << "trial " << trial;
    ASSERT_EQ(detail::total_of_step_key(detail::add_cost_key(key, cost)),
              detail::add_cost(best, cost))
        << "trial " << trial;
  }
}

TEST(PathSearch, KeyedStepsGiveWhatTheTotalsGive) {
  const unsigned seed = std::random_device{}();
  SCOPED_TRACE("seed " + std::to_string(seed));
  std::mt19937 rng(seed);
  expect_keyed_steps_equal<1>(rng);
  expect_keyed_steps_equal<2>(rng);
  expect_keyed_steps_equal<3>(rng);
  expect_keyed_steps_equal<6>(rng);
  expect_keyed_steps_equal<8>(rng);
}

}  // namespace
}  // namespace ioct::gpu::segmentation
