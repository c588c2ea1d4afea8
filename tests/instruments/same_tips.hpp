// Two tips the same to the bit, every field (NaN where both have none): the detection's CUDA and
// CPU backends, and its steps taken apart or back to back, must agree on all of it.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <string>

#include "ioct/gpu/instruments/instrument_findings.hpp"

namespace ioct::instruments_test {

inline void expect_same_tip(const gpu::instruments::InstrumentTip& a,
                            const gpu::instruments::InstrumentTip& b, const std::string& what) {
  using Tip = gpu::instruments::InstrumentTip;
  EXPECT_EQ(a.footprint_ascans, b.footprint_ascans) << what;
  EXPECT_EQ(a.translucent, b.translucent) << what;
  EXPECT_EQ(a.source, b.source) << what;
  struct Field {
    const char* name;
    double Tip::*value;
  };
  static constexpr Field kFields[] = {
      {"bscan", &Tip::bscan},   {"ascan", &Tip::ascan},         {"depth_px", &Tip::depth_px},
      {"x_um", &Tip::x_um},     {"y_um", &Tip::y_um},           {"z_um", &Tip::z_um},
      {"axis_x", &Tip::axis_x}, {"axis_y", &Tip::axis_y},       {"ilm_px", &Tip::ilm_px},
      {"rpe_px", &Tip::rpe_px}, {"to_ilm_um", &Tip::to_ilm_um}, {"to_rpe_um", &Tip::to_rpe_um}};
  for (const Field& field : kFields) {
    const double x = a.*field.value, y = b.*field.value;
    EXPECT_TRUE(std::memcmp(&x, &y, sizeof x) == 0 || (std::isnan(x) && std::isnan(y)))
        << what << ": " << field.name << " " << x << " against " << y;
  }
}

}  // namespace ioct::instruments_test
