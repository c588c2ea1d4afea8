// Scan patterns: golden waveforms and markers of each kind on tiny geometries, the properties
// every trajectory has (one sample per sweep, continuous position, velocity and acceleration,
// lines at constant speed), and infeasible patterns refused with the limit and the excess.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "ioct/common/config_error.hpp"
#include "ioct/scan/quintic_transition.hpp"
#include "ioct/scan/scan_builder.hpp"
#include "ioct/scan/scan_infeasible.hpp"

namespace ioct::rt {
namespace {

scan::GalvoLimits unlimited() {
  return {1e9, 1e15};
}

scan::ScanSpec spec(scan::ScanKind kind, double extent = 0.5) {
  scan::ScanSpec s;
  s.kind = kind;
  s.extent_x = extent;
  s.extent_y = extent;
  return s;
}

void expect_trajectory(const scan::ScanPattern& pattern,
                       const std::vector<hal::GalvoSample>& golden) {
  ASSERT_EQ(pattern.trajectory.size(), golden.size());
  for (std::size_t i = 0; i < golden.size(); ++i) {
    EXPECT_NEAR(pattern.trajectory[i].x, golden[i].x, 2e-6) << "sweep " << i;
    EXPECT_NEAR(pattern.trajectory[i].y, golden[i].y, 2e-6) << "sweep " << i;
  }
}

// Golden values computed independently (a separate implementation of the documented rules).
TEST(ScanPattern, RasterGoldenWaveformAndMarkers) {
  const scan::ScanPattern p =
      scan::build_scan_pattern(spec(scan::ScanKind::raster), {5, 3, 2, 1.0}, unlimited());
  expect_trajectory(p, {{-0.5f, -0.5f},
                        {-0.25f, -0.5f},
                        {0.0f, -0.5f},
                        {0.25f, -0.5f},
                        {0.5f, -0.5f},
                        {0.542969f, -0.396484f},
                        {0.0f, 0.0f},
                        {-0.542969f, 0.396484f},
                        {-0.5f, 0.5f},
                        {-0.25f, 0.5f},
                        {0.0f, 0.5f},
                        {0.25f, 0.5f},
                        {0.5f, 0.5f},
                        {0.542969f, 0.396484f},
                        {0.0f, 0.0f},
                        {-0.542969f, -0.396484f}});
  ASSERT_EQ(p.bscans.size(), 2u);
  EXPECT_FALSE(p.bscans[0].reversed);
  EXPECT_EQ(p.bscans[0].start, (hal::GalvoSample{-0.5f, -0.5f}));
  EXPECT_EQ(p.bscans[0].end, (hal::GalvoSample{0.5f, -0.5f}));
  EXPECT_EQ(p.bscans[1].start, (hal::GalvoSample{-0.5f, 0.5f}));
  EXPECT_EQ(p.active_begin, 0u);
  EXPECT_EQ(p.active_end, 5u);
  EXPECT_EQ(p.pattern_id(), 1u);  // hal::ScanPatternKind::raster
}

TEST(ScanPattern, BidirectionalGoldenWaveformReversesEveryOtherLine) {
  const scan::ScanPattern p =
      scan::build_scan_pattern(spec(scan::ScanKind::bidirectional), {4, 2, 2, 1.0}, unlimited());
  expect_trajectory(p, {{-0.5f, -0.5f},
                        {-0.166667f, -0.5f},
                        {0.166667f, -0.5f},
                        {0.5f, -0.5f},
                        {0.771605f, -0.290123f},
                        {0.771605f, 0.290123f},
                        {0.5f, 0.5f},
                        {0.166667f, 0.5f},
                        {-0.166667f, 0.5f},
                        {-0.5f, 0.5f},
                        {-0.771605f, 0.290123f},
                        {-0.771605f, -0.290123f}});
  EXPECT_FALSE(p.bscans[0].reversed);
  EXPECT_TRUE(p.bscans[1].reversed);
  EXPECT_EQ(p.bscans[1].start, (hal::GalvoSample{0.5f, 0.5f}));
  EXPECT_EQ(p.bscans[1].end, (hal::GalvoSample{-0.5f, 0.5f}));
  EXPECT_EQ(p.pattern_id(), 2u);
}

TEST(ScanPattern, CrosshairGoldenWaveformRotatedAndOffset) {
  scan::ScanSpec s = spec(scan::ScanKind::crosshair);
  s.rotation_deg = 90.0;
  s.offset_x = 0.1;
  s.offset_y = -0.2;
  const scan::ScanPattern p = scan::build_scan_pattern(s, {3, 2, 2, 1.0}, unlimited());
  expect_trajectory(p, {{0.1f, -0.7f},
                        {0.1f, -0.2f},
                        {0.1f, 0.3f},
                        {0.316049f, 0.491358f},
                        {0.791358f, 0.016049f},
                        {0.6f, -0.2f},
                        {0.1f, -0.2f},
                        {-0.4f, -0.2f},
                        {-0.591358f, -0.416049f},
                        {-0.116049f, -0.891358f}});
  EXPECT_EQ(p.pattern_id(), 3u);
}

TEST(ScanPattern, RadialGoldenWaveform) {
  const scan::ScanPattern p =
      scan::build_scan_pattern(spec(scan::ScanKind::radial, 0.4), {3, 3, 2, 1.0}, unlimited());
  expect_trajectory(p, {{-0.4f, 0.0f},
                        {0.0f, 0.0f},
                        {0.4f, 0.0f},
                        {0.653906f, -0.102344f},
                        {0.45f, -0.45f},
                        {0.102344f, -0.653906f},
                        {0.0f, -0.4f},
                        {0.0f, 0.0f},
                        {0.0f, 0.4f},
                        {-0.102344f, 0.653906f},
                        {-0.45f, 0.45f},
                        {-0.653906f, 0.102344f}});
  EXPECT_EQ(p.pattern_id(), 4u);
}

TEST(ScanPattern, InactiveAscansNarrowTheActiveRangeAndJoinTheTransition) {
  scan::ScanSpec s = spec(scan::ScanKind::raster);
  s.inactive_ascans = 1;
  const scan::ScanPattern p = scan::build_scan_pattern(s, {6, 2, 2, 1.0}, unlimited());
  expect_trajectory(p, {{-0.67888f, -0.44208f},
                        {-0.5f, -0.5f},
                        {-0.166667f, -0.5f},
                        {0.166667f, -0.5f},
                        {0.5f, -0.5f},
                        {0.67888f, -0.44208f},
                        {0.32016f, -0.18256f},
                        {-0.32016f, 0.18256f},
                        {-0.67888f, 0.44208f},
                        {-0.5f, 0.5f},
                        {-0.166667f, 0.5f},
                        {0.166667f, 0.5f},
                        {0.5f, 0.5f},
                        {0.67888f, 0.44208f},
                        {0.32016f, 0.18256f},
                        {-0.32016f, -0.18256f}});
  EXPECT_EQ(p.active_begin, 1u);
  EXPECT_EQ(p.active_end, 5u);
  // The markers are the commanded positions at the first and last *active* A-scan.
  EXPECT_EQ(p.bscans[0].start, (hal::GalvoSample{-0.5f, -0.5f}));
  EXPECT_EQ(p.bscans[0].end, (hal::GalvoSample{0.5f, -0.5f}));
}

TEST(ScanPattern, RepeatsScanEachLineSeveralTimes) {
  scan::ScanSpec s = spec(scan::ScanKind::raster);
  s.repeats = 3;
  const scan::ScanPattern p = scan::build_scan_pattern(s, {8, 4, 6, 1.0}, unlimited());
  ASSERT_EQ(p.bscans.size(), 6u);
  for (std::uint32_t b = 0; b < 6; ++b) {
    EXPECT_FLOAT_EQ(p.bscans[b].start.y, b < 3 ? -0.5f : 0.5f) << b;
    EXPECT_FLOAT_EQ(p.bscans[b].start.x, -0.5f) << b;
  }
  // Crosshair with repeats: H, H, V, V.
  scan::ScanSpec c = spec(scan::ScanKind::crosshair);
  c.repeats = 2;
  const scan::ScanPattern q = scan::build_scan_pattern(c, {8, 4, 4, 1.0}, unlimited());
  EXPECT_FLOAT_EQ(q.bscans[1].start.y, 0.0f);
  EXPECT_FLOAT_EQ(q.bscans[2].start.x, 0.0f);
  EXPECT_FLOAT_EQ(q.bscans[2].start.y, -0.5f);
}

// The default geometry for every kind: one sample per sweep, lines at constant speed, smooth
// transitions, the markers match the trajectory at the active ends, everything inside the field.
class EveryKind : public testing::TestWithParam<scan::ScanKind> {};

TEST_P(EveryKind, DefaultGeometryTrajectoryIsSmoothAndMatchesItsMarkers) {
  scan::ScanSpec s;
  s.kind = GetParam();
  s.repeats = s.kind == scan::ScanKind::crosshair ? 2 : 1;
  const scan::ScanTiming timing;  // 512 + 26 sweeps, 128 B-scans, 100 kHz
  const scan::ScanPattern p = scan::build_scan_pattern(s, timing, scan::GalvoLimits{});
  ASSERT_EQ(p.trajectory.size(), timing.sweeps_per_volume());
  ASSERT_EQ(p.bscans.size(), 128u);
  std::size_t reversed = 0;
  for (std::uint32_t b = 0; b < 128; ++b) {
    const std::uint64_t first = b * timing.sweeps_per_bscan();
    EXPECT_EQ(p.trajectory[first + p.active_begin], p.bscans[b].start) << b;
    EXPECT_EQ(p.trajectory[first + p.active_end - 1], p.bscans[b].end) << b;
    reversed += p.bscans[b].reversed ? 1 : 0;
    // Constant speed along the line: equal steps.
    const float dx = p.trajectory[first + 1].x - p.trajectory[first].x;
    const float dy = p.trajectory[first + 1].y - p.trajectory[first].y;
    for (std::uint32_t a = 1; a + 1 < timing.records_per_bscan; ++a) {
      ASSERT_NEAR(p.trajectory[first + a + 1].x - p.trajectory[first + a].x, dx, 1e-5f) << b;
      ASSERT_NEAR(p.trajectory[first + a + 1].y - p.trajectory[first + a].y, dy, 1e-5f) << b;
    }
  }
  EXPECT_EQ(reversed, s.kind == scan::ScanKind::bidirectional ? 64u : 0u);
  // Continuity across the whole volume (and across its wrap into the next): the second
  // difference (acceleration per sweep^2) stays within the planned peak.
  const double rate = timing.sweep_rate_hz;
  const double allowed = p.usage.peak_acceleration / (rate * rate) * 1.05 + 1e-6;
  const std::size_t n = p.trajectory.size();
  for (std::size_t i = 0; i < n; ++i) {
    const hal::GalvoSample a = p.trajectory[(i + n - 1) % n];
    const hal::GalvoSample b = p.trajectory[i];
    const hal::GalvoSample c = p.trajectory[(i + 1) % n];
    ASSERT_LE(std::fabs(a.x - 2 * b.x + c.x), allowed) << "sweep " << i;
    ASSERT_LE(std::fabs(a.y - 2 * b.y + c.y), allowed) << "sweep " << i;
    ASSERT_LE(std::fabs(b.x), 1.0f);
    ASSERT_LE(std::fabs(b.y), 1.0f);
  }
  EXPECT_LE(p.usage.peak_velocity, scan::GalvoLimits{}.max_velocity);
  EXPECT_LE(p.usage.peak_acceleration, scan::GalvoLimits{}.max_acceleration);
}

INSTANTIATE_TEST_SUITE_P(Kinds, EveryKind,
                         testing::Values(scan::ScanKind::raster, scan::ScanKind::bidirectional,
                                         scan::ScanKind::crosshair, scan::ScanKind::radial),
                         [](const testing::TestParamInfo<scan::ScanKind>& kind) {
                           return std::string(to_string(kind.param));
                         });

// The simulator's tools drive their galvo with plan_raster(): on every recorded A-scan the planned
// trajectory is where the ideal beam of the same field (hal::RasterScan) stands, reversed lines
// included, for volumes of even and odd B-scan counts.
TEST(ScanPattern, PlannedRasterPlacesEachRecordedAscanWhereTheIdealBeamDoes) {
  for (const auto kind : {scan::ScanKind::raster, scan::ScanKind::bidirectional}) {
    for (const std::uint32_t bscans : {8u, 7u}) {
      hal::RasterScan field;
      field.ascans_per_bscan = 64;
      field.bscans_per_volume = bscans;
      field.center_x = 0.1f;
      field.center_y = -0.05f;
      field.extent_x = 0.8f;
      field.extent_y = 0.5f;
      hal::DigitizerConfig digitizer;
      digitizer.ascans_per_bscan = 64;
      digitizer.flyback_sweeps = 16;
      const scan::ScanPattern pattern = scan::plan_raster(field, digitizer, kind, unlimited());
      const std::uint64_t per_bscan = pattern.timing.sweeps_per_bscan();
      for (std::uint32_t b = 0; b < bscans; ++b) {
        const bool reversed = kind == scan::ScanKind::bidirectional && b % 2 == 1;
        ASSERT_EQ(pattern.bscans[b].reversed, reversed) << b;
        for (std::uint32_t i = 0; i < field.ascans_per_bscan; ++i) {
          const hal::BeamPosition ideal = field.position(b, reversed ? 63 - i : i);
          const hal::GalvoSample planned = pattern.at(b * per_bscan + i);
          ASSERT_NEAR(planned.x, ideal.x, 1e-6) << to_string(kind) << " B-scan " << b << " " << i;
          ASSERT_NEAR(planned.y, ideal.y, 1e-6) << to_string(kind) << " B-scan " << b << " " << i;
        }
      }
    }
  }
  hal::RasterScan other;
  other.ascans_per_bscan = 32;
  try {
    (void)scan::plan_raster(other, hal::DigitizerConfig{}, scan::ScanKind::raster, unlimited());
    ADD_FAILURE() << "a field of other A-scans than the digitizer's was planned";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "scan.ascans_per_bscan");
  }
}

TEST(QuinticTransition, MatchesItsEndsAndFindsItsPeaks) {
  const scan::QuinticTransition t(1.0, 0.5, -1.0, 0.5, 10.0);
  EXPECT_DOUBLE_EQ(t.position(0.0), 1.0);
  EXPECT_NEAR(t.position(10.0), -1.0, 1e-12);
  EXPECT_NEAR(t.velocity(0.0), 0.5, 1e-12);
  EXPECT_NEAR(t.velocity(10.0), 0.5, 1e-12);
  EXPECT_NEAR(t.acceleration(0.0), 0.0, 1e-12);
  EXPECT_NEAR(t.acceleration(10.0), 0.0, 1e-12);
  double v = 0.0, a = 0.0;
  for (int i = 0; i <= 100000; ++i) {
    v = std::max(v, std::fabs(t.velocity(i * 1e-4)));
    a = std::max(a, std::fabs(t.acceleration(i * 1e-4)));
  }
  EXPECT_NEAR(t.peak_velocity(), v, 1e-6);
  EXPECT_NEAR(t.peak_acceleration(), a, 1e-6);
  // Rest to rest: the minimum-jerk profile's known peaks, 1.875 d/T and 5.7735 d/T^2.
  const scan::QuinticTransition r(0.0, 0.0, 2.0, 0.0, 4.0);
  EXPECT_NEAR(r.peak_velocity(), 1.875 * 2.0 / 4.0, 1e-12);
  EXPECT_NEAR(r.peak_acceleration(), 10.0 / std::sqrt(3.0) * 2.0 / 16.0, 1e-9);
}

TEST(ScanPattern, RefusesAnAccelerationBeyondTheLimitSayingByHowMuchAndWhatWouldDo) {
  scan::GalvoLimits limits;
  limits.max_acceleration = 1e8;
  try {
    scan::build_scan_pattern(scan::ScanSpec{}, scan::ScanTiming{}, limits);
    FAIL() << "accepted";
  } catch (const scan::ScanInfeasible& e) {
    EXPECT_EQ(e.limit(), "galvo.max_acceleration");
    EXPECT_DOUBLE_EQ(e.allowed(), 1e8);
    EXPECT_NEAR(e.required(), 1.584e8, 0.001e8);
    const std::string what = e.what();
    EXPECT_NE(what.find("flyback after B-scan"), std::string::npos) << what;
    EXPECT_NE(what.find("58."), std::string::npos) << "the excess in percent: " << what;
    EXPECT_NE(what.find("at least 34 flyback sweeps"), std::string::npos) << what;
    // The suggestion holds: with 34 flyback sweeps it is feasible, with 33 not.
    scan::ScanTiming longer;
    longer.flyback_sweeps = 34;
    EXPECT_NO_THROW(scan::build_scan_pattern(scan::ScanSpec{}, longer, limits));
    longer.flyback_sweeps = 33;
    EXPECT_THROW(scan::build_scan_pattern(scan::ScanSpec{}, longer, limits), scan::ScanInfeasible);
  }
}

TEST(ScanPattern, RefusesALineFasterThanTheVelocityLimit) {
  scan::GalvoLimits limits;
  limits.max_velocity = 300.0;  // the default line needs 371 units/s
  // A flyback so long that its own peak (89 units/s) stays below the limit: the line is the worst.
  const scan::ScanTiming slow_flyback{512, 4000, 128, 100'000.0};
  try {
    scan::build_scan_pattern(scan::ScanSpec{}, slow_flyback, limits);
    FAIL() << "accepted";
  } catch (const scan::ScanInfeasible& e) {
    EXPECT_EQ(e.limit(), "galvo.max_velocity");
    EXPECT_NEAR(e.required(), 1.9 / 511 * 1e5, 0.01);
    EXPECT_NE(std::string(e.what()).find("line's constant speed"), std::string::npos) << e.what();
  }
}

TEST(ScanPattern, RefusesAFieldThatLeavesTheScannerRange) {
  scan::ScanSpec s;
  s.kind = scan::ScanKind::bidirectional;
  s.extent_x = 1.0;  // the turn-around overshoots the line's end
  try {
    scan::build_scan_pattern(s, scan::ScanTiming{}, scan::GalvoLimits{});
    FAIL() << "accepted";
  } catch (const scan::ScanInfeasible& e) {
    EXPECT_EQ(e.limit(), "scan.field");
    EXPECT_GT(e.required(), 1.0);
    EXPECT_NE(std::string(e.what()).find("beyond the field [-1, 1] by"), std::string::npos);
  }
  scan::ScanSpec rotated;
  rotated.extent_x = rotated.extent_y = 0.9;
  rotated.rotation_deg = 45.0;  // the corners reach 0.9 * sqrt(2)
  EXPECT_THROW(scan::build_scan_pattern(rotated, scan::ScanTiming{}, scan::GalvoLimits{}),
               scan::ScanInfeasible);
}

TEST(ScanPattern, RefusesSpecsThatDoNotFitTheVolume) {
  const auto key_of = [](const scan::ScanSpec& s, const scan::ScanTiming& t) -> std::string {
    try {
      scan::build_scan_pattern(s, t, scan::GalvoLimits{});
    } catch (const ConfigError& e) {
      return e.key();
    }
    return "accepted";
  };
  scan::ScanSpec s;
  s.repeats = 3;  // 128 is not a multiple of 3
  EXPECT_EQ(key_of(s, scan::ScanTiming{}), "scan.repeats");
  s = scan::ScanSpec{};
  s.kind = scan::ScanKind::crosshair;
  s.repeats = 128;  // one line per volume: not a pair
  EXPECT_EQ(key_of(s, scan::ScanTiming{}), "scan.repeats");
  s = scan::ScanSpec{};
  s.inactive_ascans = 256;  // leaves none of 512 active
  EXPECT_EQ(key_of(s, scan::ScanTiming{}), "scan.inactive_ascans");
  s = scan::ScanSpec{};
  s.extent_x = 1.5;
  EXPECT_EQ(key_of(s, scan::ScanTiming{}), "scan.extent_x");
  s = scan::ScanSpec{};
  s.rotation_deg = std::nan("");
  EXPECT_EQ(key_of(s, scan::ScanTiming{}), "scan.rotation_deg");
}

}  // namespace
}  // namespace ioct::rt
