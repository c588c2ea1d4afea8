// What the FFTW plan classes share: FFTW's planner and wisdom are process-wide state without
// locking of their own, so every planning, wisdom transfer and plan destruction holds one mutex.
#pragma once

#include <mutex>
#include <string>

#include "ioct/gpu/processing/fftw_r2c_plan.hpp"

namespace ioct::gpu {

std::mutex& planner_mutex();
unsigned planner_flags(FftRigor rigor);
// Reads wisdom from `path` (a missing file is fine). Throws ConfigError for an unreadable one.
void import_wisdom(const std::string& path);
// Writes all wisdom to `path` through a temporary file. Throws ConfigError when it cannot.
void export_wisdom(const std::string& path);

}  // namespace ioct::gpu
