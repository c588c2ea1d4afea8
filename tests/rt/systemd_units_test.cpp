// The systemd units, users, tmpfiles and udev rules under systemd/: `systemd-analyze verify`
// accepts both services without a warning (and rejects a broken copy, so the check is real);
// the sysusers and tmpfiles entries create the users, groups and the control socket directory
// in a scratch root; the units keep what ioct-rt needs (notify + watchdog, restart, real-time
// limits, IPC kept); `systemd-analyze security` scores every unit's exposure at most 2.0. Tools
// this container lacks make the test skip, saying which and why.
#include <sys/stat.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "ioct/test_support/child_process.hpp"

namespace ioct {
namespace {

namespace fs = std::filesystem;

const fs::path kUnits = fs::path(IOCT_SYSTEMD_DIR);

std::string read(const fs::path& path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

struct Result {
  int status = -1;
  std::string output;  // stdout and stderr
};

Result run(const std::string& command) {
  Result r;
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return r;
  std::array<char, 4096> buffer{};
  while (std::fgets(buffer.data(), buffer.size(), pipe) != nullptr) r.output += buffer.data();
  const int status = ::pclose(pipe);
  r.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

std::string tool(const char* name) {
  for (const char* dir : {"/usr/bin", "/bin", "/usr/sbin", "/sbin"}) {
    const fs::path p = fs::path(dir) / name;
    if (::access(p.c_str(), X_OK) == 0) return p.string();
  }
  return {};
}

class Scratch {
 public:
  explicit Scratch(const char* tag)
      : path_(fs::temp_directory_path() /
              (std::string("ioct-systemd-") + tag + "-" + std::to_string(::getpid()))) {
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~Scratch() { fs::remove_all(path_); }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

// The unit with its ExecStart pointed at an executable that exists here (verify checks it).
fs::path installable_copy(const Scratch& dir, const char* unit) {
  std::string text = read(kUnits / unit);
  const auto replace = [&](const std::string& from, const std::string& to) {
    for (std::size_t at = text.find(from); at != std::string::npos;
         at = text.find(from, at + to.size())) {
      text.replace(at, from.size(), to);
    }
  };
  std::string rt;
  try {
    rt = test_support::sibling_executable("ioct-rt");
  } catch (const std::exception&) {
    rt = "/bin/true";
  }
  std::string gpu;
  try {
    gpu = test_support::sibling_executable("ioct-gpu");
  } catch (const std::exception&) {
    gpu = "/bin/true";  // the GPU process is not part of this build
  }
  std::string view;
  try {
    view = test_support::sibling_executable("ioct-view");
  } catch (const std::exception&) {
    view = "/bin/true";
  }
  replace("/usr/bin/ioct-rt", rt);
  replace("/usr/bin/ioct-gpu", gpu);
  replace("/usr/bin/ioct-view", view);
  std::string record;
  try {
    record = test_support::sibling_executable("ioct-record");
  } catch (const std::exception&) {
    record = "/bin/true";
  }
  replace("/usr/bin/ioct-record", record);
  const fs::path copy = dir.path() / unit;
  std::ofstream(copy) << text;
  return copy;
}

TEST(SystemdUnits, VerifyAcceptsBothServicesWithoutWarnings) {
  const std::string analyze = tool("systemd-analyze");
  if (analyze.empty()) {
    GTEST_SKIP() << "systemd-analyze is not installed here (apt-get install systemd)";
  }
  const Scratch dir("verify");
  const fs::path rt = installable_copy(dir, "ioct-rt.service");
  const fs::path gpu = installable_copy(dir, "ioct-gpu.service");
  const fs::path view = installable_copy(dir, "ioct-view.service");
  // The recorder is a template: verify an instance of it.
  const fs::path record_template = installable_copy(dir, "ioct-record@.service");
  const fs::path record = dir.path() / "ioct-record@session.service";
  fs::rename(record_template, record);
  const Result r = run(analyze + " verify " + rt.string() + " " + gpu.string() + " " +
                       view.string() + " " + record.string());
  if (r.status != 0 && (r.output.find("Failed to initialize manager") != std::string::npos ||
                        r.output.find("Failed to allocate manager") != std::string::npos ||
                        r.output.find("System has not been booted") != std::string::npos)) {
    GTEST_SKIP() << "systemd-analyze verify cannot run in this container: " << r.output;
  }
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(r.output, "") << "warnings are errors here";

  // The same verify rejects a broken unit: the check above is real.
  std::string broken = read(rt);
  broken.replace(broken.find("Type=notify"), 11, "Type=notfy");
  const fs::path bad = dir.path() / "ioct-broken.service";
  std::ofstream(bad) << broken;
  const Result b = run(analyze + " verify " + bad.string());
  EXPECT_NE(b.output.find("notfy"), std::string::npos) << b.output;
}

// `systemd-analyze security --offline=yes` scores each unit's sandbox from 0 (locked down) to 10;
// every unit stays at 2.0 or below ("OK"). Works without systemd as PID 1.
TEST(SystemdUnits, EveryUnitsExposureIsAtMostTwo) {
  const std::string analyze = tool("systemd-analyze");
  if (analyze.empty()) {
    GTEST_SKIP() << "systemd-analyze is not installed here (apt-get install systemd)";
  }
  const Scratch dir("security");
  const auto exposure_of = [&](const fs::path& unit) {
    const Result r = run(analyze + " security --offline=yes --no-pager " + unit.string());
    std::smatch level;
    if (!std::regex_search(r.output, level,
                           std::regex("Overall exposure level for [^:]+: ([0-9]+\\.[0-9]+)"))) {
      ADD_FAILURE() << unit << ": no \"Overall exposure level\" line in:\n" << r.output;
      return std::pair{10.0, r.output};
    }
    return std::pair{std::stod(level[1]), r.output};
  };
  // The measure is real: the same service without its sandbox scores far above.
  const fs::path bare = dir.path() / "ioct-bare.service";
  std::ofstream(bare) << "[Service]\nExecStart=/bin/true\n";
  EXPECT_GT(exposure_of(bare).first, 5.0);
  for (const char* unit : {"ioct-rt.service", "ioct-gpu.service", "ioct-view.service"}) {
    const auto [exposure, report] = exposure_of(installable_copy(dir, unit));
    EXPECT_LE(exposure, 2.0) << unit << " exposure " << exposure << ":\n" << report;
    std::cout << unit << ": exposure " << exposure << "\n";
  }
}

TEST(SystemdUnits, TheRtServiceKeepsWhatTheAcquisitionNeeds) {
  const std::string unit = read(kUnits / "ioct-rt.service");
  for (const char* line :
       {"Type=notify", "WatchdogSec=", "Restart=on-failure", "LimitRTPRIO=90",
        "LimitMEMLOCK=infinity", "RemoveIPC=no", "RestrictRealtime=no", "User=ioct-rt",
        "DeviceAllow=char-usb_device rw", "DeviceAllow=char-gpiochip rw", "KillSignal=SIGTERM",
        "ReadWritePaths=/run/ioct", "ExecStart=/usr/bin/ioct-rt --config /etc/ioct/rt.toml"}) {
    EXPECT_NE(unit.find(std::string("\n") + line), std::string::npos) << line;
  }
  EXPECT_EQ(unit.find("PrivateDevices=yes"), std::string::npos) << "would hide USB and GPIO";
  const std::string gpu = read(kUnits / "ioct-gpu.service");
  EXPECT_NE(gpu.find("\nRemoveIPC=no"), std::string::npos);
  EXPECT_NE(gpu.find("SupplementaryGroups=ioct-render"), std::string::npos);
}

TEST(SystemdUnits, SysusersAndTmpfilesCreateTheUsersAndTheSocketDirectory) {
  const std::string sysusers = tool("systemd-sysusers");
  const std::string tmpfiles = tool("systemd-tmpfiles");
  if (sysusers.empty() || tmpfiles.empty()) {
    GTEST_SKIP() << "systemd-sysusers or systemd-tmpfiles is not installed here";
  }
  const Scratch root("root");
  fs::create_directories(root.path() / "etc");
  fs::create_directories(root.path() / "run");
  fs::create_directories(root.path() / "dev/shm");
  const Result users = run(sysusers + " --root=" + root.path().string() + " " +
                           (kUnits / "ioct.sysusers.conf").string());
  ASSERT_EQ(users.status, 0) << users.output;
  const std::string group = "\n" + read(root.path() / "etc/group");
  const std::string passwd = "\n" + read(root.path() / "etc/passwd");
  // The ring's readers and its producer, in whatever order sysusers lists them.
  std::smatch render_members;
  ASSERT_TRUE(
      std::regex_search(group, render_members, std::regex("\nioct-render:x:\\d+:([^\n]*)\n")))
      << group;
  std::vector<std::string> members;
  std::istringstream member_list(render_members[1].str());
  for (std::string member; std::getline(member_list, member, ',');) members.push_back(member);
  std::sort(members.begin(), members.end());
  EXPECT_EQ(members, (std::vector<std::string>{"ioct-gpu", "ioct-record", "ioct-rt"})) << group;
  EXPECT_TRUE(std::regex_search(
      group, std::regex("\nioct-control:x:\\d+:(ioct-rt,ioct-view|ioct-view,ioct-rt)\n")))
      << group;
  EXPECT_TRUE(std::regex_search(
      group, std::regex("\nioct-frames:x:\\d+:(ioct-gpu,ioct-view|ioct-view,ioct-gpu)\n")))
      << group;
  std::smatch rt_user;
  ASSERT_TRUE(std::regex_search(passwd, rt_user, std::regex("\nioct-rt:x:(\\d+):(\\d+):")))
      << passwd;
  std::smatch control_group;
  ASSERT_TRUE(std::regex_search(group, control_group, std::regex("\nioct-control:x:(\\d+):")));

  const Result dirs = run(tmpfiles + " --root=" + root.path().string() + " --create " +
                          (kUnits / "ioct.tmpfiles.conf").string());
  ASSERT_EQ(dirs.status, 0) << dirs.output;
  struct stat st {};
  ASSERT_EQ(::stat((root.path() / "run/ioct").c_str(), &st), 0);
  EXPECT_TRUE(S_ISDIR(st.st_mode));
  EXPECT_EQ(st.st_mode & 0777, 0750u);
  EXPECT_EQ(st.st_uid, static_cast<uid_t>(std::stoul(rt_user[1])));
  EXPECT_EQ(st.st_gid, static_cast<gid_t>(std::stoul(control_group[1])));

  // The shared-memory namespace: only ioct-rt and the render group create entries (issue F10).
  std::smatch render_group;
  ASSERT_TRUE(std::regex_search(group, render_group, std::regex("\nioct-render:x:(\\d+):")));
  ASSERT_EQ(::stat((root.path() / "dev/shm/ioct").c_str(), &st), 0) << dirs.output;
  EXPECT_TRUE(S_ISDIR(st.st_mode));
  EXPECT_EQ(st.st_mode & 07777, 01770u);
  EXPECT_EQ(st.st_uid, static_cast<uid_t>(std::stoul(rt_user[1])));
  EXPECT_EQ(st.st_gid, static_cast<gid_t>(std::stoul(render_group[1])));
}

TEST(SystemdUnits, UdevRulesMatchTheInstrumentAndAreWellFormed) {
  const std::string rules = read(kUnits / "70-ioct-digitizer.rules");
  // Every rule line: comma-separated KEY op "value" pairs (continuations joined).
  std::string joined = std::regex_replace(rules, std::regex("\\\\\n\\s*"), "");
  std::istringstream lines(joined);
  const std::regex pair(R"(\s*[A-Z_]+(\{[A-Za-z_/]+\})?\s*(==|!=|\+=|=|:=)\s*"[^"]*"\s*)");
  int rules_seen = 0;
  for (std::string line; std::getline(lines, line);) {
    if (line.empty() || line[0] == '#') continue;
    ++rules_seen;
    std::istringstream parts(line);
    for (std::string part; std::getline(parts, part, ',');) {
      EXPECT_TRUE(std::regex_match(part, pair)) << "not a udev key: \"" << part << "\" in " << line;
    }
  }
  EXPECT_EQ(rules_seen, 3);
  // The placeholder IDs of the USB protocol (hal/usb: kPlaceholderVendorId 0x1209, product 0x0001).
  EXPECT_NE(joined.find(R"(ATTR{idVendor}=="1209", ATTR{idProduct}=="0001")"), std::string::npos);
  EXPECT_NE(joined.find(R"(GROUP="ioct-rt")"), std::string::npos);
}

}  // namespace
}  // namespace ioct
