// The HDF5 recording's write rate at the default geometry against a plain sequential write of
// the same bytes to the same directory, in the same run: RingRecordingWriter::append +
// write_counters (direct chunk write, checksum, flush per group) versus write(2) of each group
// and its slot header to a flat file. Both end with fsync, timed apart, so the figures show the
// rate the page cache takes and the rate the disk sustains. Target: 262 MB/s (22.5 MB per
// 86.1 ms group at 100 kHz).
#include <fcntl.h>
#include <unistd.h>
#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "ioct/ringrec/ring_recording_writer.hpp"

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

struct Rate {
  double write_s = 0.0;  // the writes
  double sync_s = 0.0;   // the fsync after them
};

void vary(std::vector<std::byte>& payload, std::uint64_t group) {
  std::memcpy(payload.data(), &group, sizeof group);  // each group differs, as on the ring
}

Rate plain_write(const fs::path& path, std::vector<std::byte>& payload, std::uint64_t groups) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw std::runtime_error(path.string() + ": " + std::strerror(errno));
  ioct::shm::SlotHeader header{};
  Rate rate;
  const auto start = Clock::now();
  for (std::uint64_t g = 0; g < groups; ++g) {
    vary(payload, g);
    header.group_index = g;
    for (const auto& [data, bytes] :
         {std::pair<const void*, std::size_t>{payload.data(), payload.size()},
          std::pair<const void*, std::size_t>{&header, sizeof header}}) {
      std::size_t done = 0;
      while (done < bytes) {
        const ssize_t n = ::write(fd, static_cast<const char*>(data) + done, bytes - done);
        if (n <= 0) throw std::runtime_error(path.string() + ": write: " + std::strerror(errno));
        done += static_cast<std::size_t>(n);
      }
    }
  }
  rate.write_s = seconds_since(start);
  const auto sync_start = Clock::now();
  ::fsync(fd);
  rate.sync_s = seconds_since(sync_start);
  ::close(fd);
  return rate;
}

Rate hdf5_write(const fs::path& path, const ioct::shm::RingGeometry& geometry,
                std::vector<std::byte>& payload, std::uint64_t groups) {
  ioct::ringrec::RecordingDescription description;
  description.geometry = geometry;
  description.producer = "record_rate_bench";
  ioct::ringrec::RingRecordingWriter writer(path, description, true);
  ioct::ringrec::CounterValues counters{};
  ioct::shm::SlotHeader header{};
  Rate rate;
  const auto start = Clock::now();
  for (std::uint64_t g = 0; g < groups; ++g) {
    vary(payload, g);
    header.group_index = g;
    writer.append(header, payload);
    counters[0] = g + 1;
    writer.write_counters(counters);
  }
  rate.write_s = seconds_since(start);
  writer.close(counters);
  const auto sync_start = Clock::now();
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  ::fsync(fd);
  ::close(fd);
  rate.sync_s = seconds_since(sync_start);
  return rate;
}

}  // namespace

int main(int argc, char** argv) {
  ioct::shm::RingGeometry geometry;  // the default: 1376 x 512 x 16 x 2 bytes
  std::uint64_t groups = 40;
  std::string dir = fs::temp_directory_path().string();
  int repeats = 2;
  CLI::App app{"record_rate_bench: HDF5 recording rate against a plain sequential write"};
  app.add_option("--dir", dir, "directory on the disk to measure");
  app.add_option("--groups", groups, "groups per write (22.5 MB each at the default geometry)");
  app.add_option("--repeats", repeats, "alternating runs of each writer");
  app.add_option("--samples", geometry.samples_per_ascan);
  app.add_option("--ascans", geometry.ascans_per_bscan);
  app.add_option("--bscans-per-group", geometry.bscans_per_group);
  CLI11_PARSE(app, argc, argv);
  geometry.validate();

  const std::uint64_t group_bytes = geometry.group_payload_bytes();
  const double total_mb =
      static_cast<double>(groups * (group_bytes + sizeof(ioct::shm::SlotHeader))) * 1e-6;
  std::vector<std::byte> payload(group_bytes);
  for (std::size_t i = 0; i < payload.size(); ++i) {
    payload[i] = static_cast<std::byte>((i * 2654435761u) >> 13);
  }
  const fs::path plain =
      fs::path(dir) / ("ioct-record-bench-" + std::to_string(::getpid()) + ".raw");
  const fs::path h5 = fs::path(dir) / ("ioct-record-bench-" + std::to_string(::getpid()) + ".h5");
  std::printf("record_rate_bench: %llu groups of %.2f MB (%.0f MB) per run into %s\n",
              static_cast<unsigned long long>(groups), static_cast<double>(group_bytes) * 1e-6,
              total_mb, dir.c_str());
  std::printf("%-8s %-26s %12s %16s\n", "run", "writer", "MB/s written", "MB/s incl. fsync");
  for (int r = 0; r < repeats; ++r) {
    const Rate a = plain_write(plain, payload, groups);
    fs::remove(plain);
    const Rate b = hdf5_write(h5, geometry, payload, groups);
    fs::remove(h5);
    std::printf("%-8d %-26s %12.0f %16.0f\n", r, "plain write(2) (anchor)", total_mb / a.write_s,
                total_mb / (a.write_s + a.sync_s));
    std::printf("%-8d %-26s %12.0f %16.0f   (%.0f %% / %.0f %% of the anchor)\n", r,
                "HDF5 recording", total_mb / b.write_s, total_mb / (b.write_s + b.sync_s),
                100.0 * a.write_s / b.write_s,
                100.0 * (a.write_s + a.sync_s) / (b.write_s + b.sync_s));
  }
  std::printf("target: 262 MB/s (the default geometry at 100 kHz)\n");
  return 0;
}
