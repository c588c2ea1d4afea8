// The appliance as installed, without root: the service users and groups come from
// systemd/ioct.sysusers.conf, the directories from systemd/ioct.tmpfiles.conf (the real /run and
// /dev/shm paths the units use), and ioct-rt (simulator), ioct-gpu (CPU) and ioct-view run as
// ioct-rt, ioct-gpu and ioct-view with the arguments of their units' ExecStart lines and the
// units' umasks. Checks: groups flow end to end (ioct-gpu consumes them, ioct-view sends a frame
// to a viewer), the ring is 0640 ioct-rt:ioct-render, `nobody` cannot attach to the ring nor reach
// the control socket, an operator (a member of ioct-control) can, and no process runs as root or
// with a capability. Creating users and switching to them needs root: elsewhere the test fails,
// saying so (CI runs as root on a fresh machine).
#include <grp.h>
#include <pwd.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "ioct/test_support/child_process.hpp"
#include "ioct/view_test/http_client.hpp"
#include "ioct/view_test/logged_process.hpp"
#include "view_client.hpp"

namespace ioct {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

const fs::path kUnits = fs::path(IOCT_SYSTEMD_DIR);
// The installed paths (ioct.tmpfiles.conf, docs/operations.md).
constexpr char kRing[] = "/dev/shm/ioct/ring";
constexpr char kControlSocket[] = "/run/ioct/rt.sock";

std::string read(const fs::path& path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

struct Result {
  int status = -1;  // exit status; -1: killed or not run
  std::string output;
};

// Runs a command (arguments without shell metacharacters) and collects stdout and stderr.
Result run(const std::vector<std::string>& argv) {
  std::string command = "timeout 60";
  for (const std::string& a : argv) command += " '" + a + "'";
  Result r;
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return r;
  std::array<char, 4096> buffer{};
  while (std::fgets(buffer.data(), buffer.size(), pipe) != nullptr) r.output += buffer.data();
  const int status = ::pclose(pipe);
  r.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

struct Account {
  uid_t uid = 0;
  gid_t gid = 0;
};

Account user(const char* name) {
  const passwd* p = ::getpwnam(name);
  if (p == nullptr) throw std::runtime_error(std::string("no user ") + name);
  return {p->pw_uid, p->pw_gid};
}

gid_t group(const char* name) {
  const ::group* g = ::getgrnam(name);
  if (g == nullptr) throw std::runtime_error(std::string("no group ") + name);
  return g->gr_gid;
}

// The ExecStart line of a unit, split into words (continuation lines joined).
std::vector<std::string> exec_start(const char* unit) {
  const std::string text = std::regex_replace(read(kUnits / unit), std::regex("\\\\\n"), " ");
  std::smatch line;
  if (!std::regex_search(text, line, std::regex("\nExecStart=([^\n]*)"))) {
    throw std::runtime_error(std::string("no ExecStart in ") + unit);
  }
  std::istringstream words(line[1].str());
  std::vector<std::string> argv;
  for (std::string w; words >> w;) argv.push_back(w);
  return argv;
}

// The unit's UMask= ("0007").
std::string umask_of(const char* unit) {
  std::smatch m;
  const std::string text = read(kUnits / unit);
  if (!std::regex_search(text, m, std::regex("\nUMask=([0-7]+)"))) return "0022";
  return m[1].str();
}

// A scratch root holding what the package would install (/usr/bin, /etc/ioct) and the state
// directories systemd would make (/var/lib/...): readable by the service users, whose homes
// (and this checkout's folder) may not be.
class InstalledTree {
 public:
  InstalledTree()
      : root_(fs::temp_directory_path() / ("ioct-installed-" + std::to_string(::getpid()))) {
    fs::remove_all(root_);
    fs::create_directories(root_ / "usr/bin");
    fs::create_directories(root_ / "etc/ioct");
    fs::create_directories(root_ / "log");
    fs::permissions(root_, fs::perms(0755));
    for (const char* exe : {"ioct-rt", "ioct-gpu", "ioct-view", "ioct-rtctl"}) {
      fs::copy_file(test_support::sibling_executable(exe), root_ / "usr/bin" / exe);
    }
    // The pages, beside ioct-view as installed (followed if the build links them).
    const fs::path www =
        fs::path(test_support::sibling_executable("ioct-view")).parent_path() / "www";
    fs::copy(www, root_ / "usr/bin/www", fs::copy_options::recursive);
  }
  ~InstalledTree() {
    if (!keep_) fs::remove_all(root_);
  }
  // An installed path inside the tree: "/usr/bin/ioct-rt" -> "<root>/usr/bin/ioct-rt".
  fs::path operator()(const std::string& path) const { return root_ / path.substr(1); }
  // A state directory as systemd's StateDirectory= makes it: owned by the unit's user.
  void state_directory(const std::string& path, const char* owner, fs::perms mode) const {
    const fs::path p = (*this)(path);
    fs::create_directories(p);
    const Account a = user(owner);
    for (fs::path at = p; at != root_ / "var"; at = at.parent_path()) {
      ::chown(at.c_str(), a.uid, a.gid);
    }
    fs::permissions(p, mode);
  }
  const fs::path& root() const { return root_; }
  void keep() { keep_ = true; }

 private:
  fs::path root_;
  bool keep_ = false;
};

// The unit's command line with installed files moved into the tree; /run and /dev/shm stay.
std::vector<std::string> installed_command(const InstalledTree& tree, const char* unit) {
  std::vector<std::string> argv = exec_start(unit);
  for (std::string& a : argv) {
    for (const char* prefix : {"/usr/bin/", "/etc/", "/var/lib/"}) {
      if (a.rfind(prefix, 0) == 0) a = tree(a).string();
    }
  }
  return argv;
}

// "umask U; exec setpriv --reuid=USER --regid=USER --init-groups ... COMMAND": the unit's
// User=, Group=, SupplementaryGroups= (its user's groups from sysusers), UMask=,
// NoNewPrivileges= and empty CapabilityBoundingSet=.
std::unique_ptr<view_test::LoggedProcess> as_service(const InstalledTree& tree, const char* unit,
                                                     const char* user_name,
                                                     std::vector<std::string> command) {
  std::vector<std::string> args{"-c",
                                "umask " + umask_of(unit) + " && exec \"$@\"",
                                "sh",
                                "/usr/bin/setpriv",
                                std::string("--reuid=") + user_name,
                                std::string("--regid=") + user_name,
                                "--init-groups",
                                "--no-new-privs",
                                "--bounding-set=-all",
                                "--inh-caps=-all",
                                "--"};
  args.insert(args.end(), command.begin(), command.end());
  return std::make_unique<view_test::LoggedProcess>(
      "/bin/sh", std::move(args), tree.root() / "log" / (std::string(user_name) + ".log"));
}

// Whether something answers on the Unix socket (as root).
bool socket_answers(const char* path) {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  std::snprintf(address.sun_path, sizeof address.sun_path, "%s", path);
  const bool answered = ::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0;
  ::close(fd);
  return answered;
}

// The process's real, effective, saved and file-system uids and its effective capabilities.
struct Credentials {
  std::string uids;
  std::string cap_eff;
};

Credentials credentials(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  Credentials c;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("Uid:", 0) == 0)
      c.uids = std::regex_replace(line.substr(4), std::regex("\\s+"), " ");
    if (line.rfind("CapEff:", 0) == 0) c.cap_eff = line.substr(7);
  }
  return c;
}

TEST(InstalledUsers, TheApplianceRunsAsItsServiceUsersWithoutRoot) {
  ASSERT_EQ(::geteuid(), 0u)
      << "this test needs root: it creates the service users and groups (systemd-sysusers), the "
         "installed directories in /run and /dev/shm (systemd-tmpfiles) and runs each process as "
         "its user (setpriv). Run it as root (tools/ioct-test does, on a fresh machine).";
  for (const char* tool : {"/usr/bin/systemd-sysusers", "/usr/bin/systemd-tmpfiles",
                           "/usr/bin/setpriv", "/usr/bin/timeout"}) {
    ASSERT_EQ(::access(tool, X_OK), 0) << tool << " is missing (apt-get install systemd)";
  }
  ASSERT_FALSE(socket_answers(kControlSocket))
      << "an ioct-rt already answers on " << kControlSocket
      << ": this test runs the appliance at its installed paths; stop the service first";

  // The users, groups and directories, as the package's installation makes them (idempotent).
  const Result users = run({"/usr/bin/systemd-sysusers", (kUnits / "ioct.sysusers.conf").string()});
  ASSERT_EQ(users.status, 0) << users.output;
  const Result dirs =
      run({"/usr/bin/systemd-tmpfiles", "--create", (kUnits / "ioct.tmpfiles.conf").string()});
  ASSERT_EQ(dirs.status, 0) << dirs.output;
  const Account rt_user = user("ioct-rt");
  const Account nobody = user("nobody");
  const gid_t render_group = group("ioct-render");
  const gid_t control_group = group("ioct-control");

  InstalledTree tree;
  tree.state_directory("/var/lib/ioct/frames", "ioct-gpu", fs::perms(0755));
  tree.state_directory("/var/lib/ioct-view", "ioct-view", fs::perms(0700));
  // /etc/ioct/rt.toml: the simulator with the installed names, a small raster at a quarter of the
  // sweep rate (as the e2e tests, so 2 loaded cores keep up) and no SCHED_FIFO (CI shares them).
  {
    std::ofstream config(tree("/etc/ioct/rt.toml"));
    config << "[ring]\nname = \"" << kRing << "\"\ngroup = \"ioct-render\"\n\n"
           << "[digitizer]\nsamples_per_ascan = 512\nascans_per_bscan = 128\n"
              "bscans_per_group = 8\nascan_rate_hz = 25000.0\n\n"
           << "[scan]\nbscans_per_volume = 32\n\n[realtime]\npriority = 0\n\n"
           << "[safety]\nstall_timeout_ms = 10000\n\n"
           << "[control]\nsocket = \"" << kControlSocket
           << "\"\nsocket_group = \"ioct-control\"\nstart_scanning = true\n\n"
           << "[simulation]\nlaser_watchdog_timeout_ms = 10000\n";
  }
  fs::permissions(tree("/etc/ioct/rt.toml"), fs::perms(0644));

  std::vector<std::string> gpu_command = installed_command(tree, "ioct-gpu.service");
  for (const char* extra : {"--backend", "cpu", "--render-width", "320", "--render-height", "240",
                            "--status-interval", "1"}) {
    gpu_command.emplace_back(extra);
  }
  const unsigned short port = view_test::free_local_port();
  std::vector<std::string> view_command = installed_command(tree, "ioct-view.service");
  for (std::string& a : view_command) {
    if (a == "127.0.0.1:8080") a = "127.0.0.1:" + std::to_string(port);
  }

  auto rt =
      as_service(tree, "ioct-rt.service", "ioct-rt", installed_command(tree, "ioct-rt.service"));
  auto gpu = as_service(tree, "ioct-gpu.service", "ioct-gpu", gpu_command);
  auto view = as_service(tree, "ioct-view.service", "ioct-view", view_command);
  const auto logs = [&] {
    tree.keep();
    return "logs in " + (tree.root() / "log").string() + "\n--- ioct-rt:\n" + rt->log_tail(1500) +
           "\n--- ioct-gpu:\n" + gpu->log_tail(1500) + "\n--- ioct-view:\n" + view->log_tail(1500);
  };
  rt->start();
  gpu->start();
  view->start();

  // The ring appears; its mode and owners are checked below (0640, ioct-rt:ioct-render: the owner
  // writes, the group reads).
  struct stat ring {};
  for (const auto deadline = Clock::now() + 20s;
       ::stat(kRing, &ring) != 0 && Clock::now() < deadline && rt->running();) {
    std::this_thread::sleep_for(50ms);
  }
  ASSERT_EQ(::stat(kRing, &ring), 0) << kRing << " never appeared\n" << logs();

  // Groups flow end to end: ioct-view's state shows ioct-gpu consuming and ioct-rt's status (which
  // ioct-view, a member of ioct-control, asks for over the control socket).
  nlohmann::json state;
  for (const auto deadline = Clock::now() + 40s; Clock::now() < deadline;) {
    const view_test::HttpReply reply = view_test::http_request(port, "GET", "/api/state");
    if (reply.status == 200) {
      state = nlohmann::json::parse(reply.body, nullptr, false);
      if (state.is_object() && state["gpu"].is_object() &&
          state["gpu"].value("groups_consumed", 0) >= 3 && state["rt"].is_object() &&
          state["rt"].contains("readers") && !state["rt"]["readers"].empty() &&
          state["rt"]["readers"][0].value("consumed", 0) >= 3) {
        break;
      }
    }
    if (!rt->running() || !gpu->running() || !view->running()) break;
    std::this_thread::sleep_for(200ms);
  }
  ASSERT_TRUE(state.is_object()) << "ioct-view never answered GET /api/state\n" << logs();
  EXPECT_EQ(state.value("rt_error", "?"), "") << state.dump();
  ASSERT_TRUE(state["gpu"].is_object()) << "ioct-view cannot reach ioct-gpu\n" << logs();
  EXPECT_GE(state["gpu"].value("groups_consumed", 0), 3) << state.dump() << "\n" << logs();
  ASSERT_TRUE(state["rt"].is_object() && state["rt"].contains("readers") &&
              !state["rt"]["readers"].empty())
      << "ioct-view cannot reach ioct-rt, or ioct-rt lists no reader\n"
      << logs();
  // Looked at once ioct-gpu reads it, so the ring is made whole: the name appears (0600, the
  // creator's group) a moment before ioct-rt sets its mode and group.
  ASSERT_EQ(::stat(kRing, &ring), 0) << kRing << " vanished\n" << logs();
  EXPECT_TRUE(S_ISREG(ring.st_mode));
  EXPECT_EQ(ring.st_mode & 07777, 0640u) << std::oct << (ring.st_mode & 07777);
  EXPECT_EQ(ring.st_uid, rt_user.uid);
  EXPECT_EQ(ring.st_gid, render_group);
  EXPECT_EQ(state["rt"]["readers"][0].value("label", ""), "ioct-gpu") << state.dump();
  EXPECT_GE(state["rt"]["readers"][0].value("consumed", 0), 3) << state.dump();

  // ioct-view reads ioct-gpu's frame ring and sends a frame to a viewer.
  {
    view::testing::WsViewer viewer(port);
    const auto frame = viewer.next_frame(20s);
    ASSERT_TRUE(frame.has_value()) << "no frame reached a viewer\n" << logs();
    EXPECT_FALSE(frame->render.empty());
  }

  // No process runs as root or holds a capability.
  for (const auto& [process, name] :
       std::array<std::pair<view_test::LoggedProcess*, const char*>, 3>{
           {{rt.get(), "ioct-rt"}, {gpu.get(), "ioct-gpu"}, {view.get(), "ioct-view"}}}) {
    ASSERT_TRUE(process->running()) << name << " ended\n" << logs();
    const std::string uid = std::to_string(user(name).uid);
    const Credentials c = credentials(process->pid());
    EXPECT_EQ(c.uids, " " + uid + " " + uid + " " + uid + " " + uid) << name;
    EXPECT_EQ(c.cap_eff.find_first_not_of("0\t "), std::string::npos) << name << ": " << c.cap_eff;
  }

  const std::string bin = tree("/usr/bin/").string();
  const std::vector<std::string> as_nobody{"/usr/bin/setpriv", "--reuid=nobody",
                                           "--regid=" + std::to_string(nobody.gid)};
  const auto command = [](std::vector<std::string> first, const std::vector<std::string>& rest) {
    first.insert(first.end(), rest.begin(), rest.end());
    return first;
  };

  // A user outside ioct-render cannot attach to the ring, and says why.
  fs::create_directories(tree.root() / "nobody");
  ::chown((tree.root() / "nobody").c_str(), nobody.uid, nobody.gid);
  const Result attach = run(
      command(as_nobody, {"--clear-groups", "--", bin + "ioct-gpu", "--ring", kRing, "--backend",
                          "cpu", "--frames", "none", "--wait", "5", "--exit-when-producer-gone",
                          "--out", (tree.root() / "nobody").string()}));
  EXPECT_NE(attach.status, 0) << attach.output;
  EXPECT_NE(attach.output.find(std::string("'") + kRing + "': permission denied"),
            std::string::npos)
      << attach.output;

  // A user outside ioct-control cannot reach the control socket; an operator (in it) can.
  const Result outsider = run(command(as_nobody, {"--clear-groups", "--", bin + "ioct-rtctl",
                                                  "--socket", kControlSocket, "status"}));
  EXPECT_NE(outsider.status, 0) << outsider.output;
  EXPECT_NE(outsider.output.find("Permission denied"), std::string::npos) << outsider.output;
  const Result operator_status =
      run(command(as_nobody, {"--groups=" + std::to_string(control_group), "--", bin + "ioct-rtctl",
                              "--socket", kControlSocket, "status"}));
  EXPECT_EQ(operator_status.status, 0) << operator_status.output;
  EXPECT_NE(operator_status.output.find("\"ok\":true"), std::string::npos)
      << operator_status.output;

  // The socket itself: 0660 ioct-rt:ioct-control in /run/ioct (0750).
  struct stat control {};
  ASSERT_EQ(::stat(kControlSocket, &control), 0);
  EXPECT_EQ(control.st_mode & 0777, 0660u) << std::oct << (control.st_mode & 0777);
  EXPECT_EQ(control.st_gid, control_group);

  // Each ends cleanly on SIGTERM, as systemd stops it.
  for (const auto& [process, name] :
       std::array<std::pair<view_test::LoggedProcess*, const char*>, 3>{
           {{view.get(), "ioct-view"}, {gpu.get(), "ioct-gpu"}, {rt.get(), "ioct-rt"}}}) {
    const auto status = process->stop(10s);
    ASSERT_TRUE(status.has_value()) << name;
    EXPECT_TRUE(WIFEXITED(*status) && WEXITSTATUS(*status) == 0)
        << name << " " << test_support::describe_wait_status(*status) << "\n"
        << logs();
  }
  if (::testing::Test::HasFailure()) logs();
}

}  // namespace
}  // namespace ioct
