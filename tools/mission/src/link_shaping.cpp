#include "keyfleet/mission/link_shaping.hpp"
#include "keyfleet/mission/experiment_config.hpp"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <sstream>

#include "keyfleet/common/error.hpp"

extern char** environ;

namespace keyfleet::mission {
namespace {

constexpr char kNamespacePrefix[] = "kfbw";
constexpr char kStationAddress[] = "10.77.255.1";
// Queueing the shaper allows before it drops: enough for a few DDS fragments in flight.
constexpr char kTbfLatency[] = "200ms";

std::string join(const std::vector<std::string>& words) {
  std::string out;
  for (const auto& w : words) out += (out.empty() ? "" : " ") + w;
  return out;
}

std::string format_number(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

std::string drone_address_of(std::size_t drone) {
  return "10.77." + std::to_string(drone / 250) + "." + std::to_string(drone % 250 + 2);
}

bool process_alive(long pid) {
  return pid > 0 && (::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM);
}

}  // namespace

CommandResult run_command(const std::vector<std::string>& argv) {
  CommandResult result;
  int pipe_fds[2];
  if (argv.empty() || ::pipe2(pipe_fds, O_CLOEXEC) != 0) return result;
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDERR_FILENO);
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = -1;
  const int rc = ::posix_spawnp(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  ::close(pipe_fds[1]);
  if (rc != 0) {
    ::close(pipe_fds[0]);
    result.output = "cannot run " + argv[0];
    return result;
  }
  char buffer[4096];
  for (ssize_t n; (n = ::read(pipe_fds[0], buffer, sizeof buffer)) > 0;)
    result.output.append(buffer, static_cast<std::size_t>(n));
  ::close(pipe_fds[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  while (!result.output.empty() && result.output.back() == '\n') result.output.pop_back();
  return result;
}

std::optional<std::string> netns_unavailable_reason() {
  if (::geteuid() != 0) return "not running as root (network namespaces need CAP_SYS_ADMIN)";
  const auto probe = run_command({"ip", "netns", "list"});
  if (probe.exit_code != 0) return "'ip netns list' failed (iproute2 missing?): " + probe.output;
  return std::nullopt;
}

void remove_stale_namespaces(Logger logger) {
  const auto list = run_command({"ip", "netns", "list"});
  std::istringstream lines(list.output);
  for (std::string line; std::getline(lines, line);) {
    const std::string name = line.substr(0, line.find(' '));
    if (name.rfind(kNamespacePrefix, 0) != 0) continue;
    // kfbw<pid>x<n>-...: the pid of the experiment that made it.
    const long pid = std::strtol(name.c_str() + sizeof kNamespacePrefix - 1, nullptr, 10);
    if (process_alive(pid)) continue;
    run_command({"ip", "netns", "delete", name});
    logger->warn("removed network namespace {} left by a stopped experiment (pid {})", name, pid);
  }
}

NetnsLinks::NetnsLinks(const std::vector<std::string>& robot_ids, const LinkProfileConfig& profile,
                       Logger logger)
    : profile_(profile), logger_(std::move(logger)), robot_ids_(robot_ids) {
  static std::atomic<int> counter{0};
  prefix_ =
      std::string(kNamespacePrefix) + std::to_string(::getpid()) + "x" + std::to_string(counter++);
  station_ns_ = prefix_ + "-st";
  try {
    run_or_throw({"ip", "netns", "add", station_ns_});
    created_ns_.push_back(station_ns_);
    run_or_throw({"ip", "-n", station_ns_, "link", "set", "lo", "up"});
    // The station has one address for every drone, on a link of its own: with an address per
    // veth it would announce them all, and each drone would send every sample to each one.
    run_or_throw({"ip", "link", "add", "kfst", "netns", station_ns_, "type", "veth", "peer", "name",
                  "kfstp", "netns", station_ns_});
    run_or_throw({"ip", "-n", station_ns_, "addr", "add", std::string(kStationAddress) + "/32",
                  "dev", "kfst"});
    run_or_throw({"ip", "-n", station_ns_, "link", "set", "kfst", "up"});
    run_or_throw({"ip", "-n", station_ns_, "link", "set", "kfstp", "up"});
    for (std::size_t i = 0; i < robot_ids.size(); ++i) {
      const std::string ns = prefix_ + "-d" + std::to_string(i);
      const std::string drone_if = "kfd" + std::to_string(i);
      const std::string station_if = "kfs" + std::to_string(i);
      run_or_throw({"ip", "netns", "add", ns});
      created_ns_.push_back(ns);
      drone_ns_.push_back(ns);
      drone_if_.push_back(drone_if);
      run_or_throw({"ip", "link", "add", drone_if, "netns", ns, "type", "veth", "peer", "name",
                    station_if, "netns", station_ns_});
      const std::string drone_address = drone_address_of(i);
      run_or_throw({"ip", "-n", ns, "addr", "add", drone_address + "/32", "dev", drone_if});
      run_or_throw({"ip", "-n", ns, "link", "set", "lo", "up"});
      run_or_throw({"ip", "-n", ns, "link", "set", drone_if, "up"});
      run_or_throw({"ip", "-n", station_ns_, "link", "set", station_if, "up"});
      // Point-to-point routes over the unnumbered veth; the default route also carries the
      // DDS multicast announcements.
      run_or_throw({"ip", "-n", ns, "route", "add", kStationAddress, "dev", drone_if});
      run_or_throw({"ip", "-n", ns, "route", "add", "default", "via", kStationAddress, "dev",
                    drone_if, "onlink"});
      run_or_throw({"ip", "-n", station_ns_, "route", "add", drone_address, "dev", station_if});
      shape(ns, drone_if);
      shape(station_ns_, station_if);
    }
    wait_until_up();
  } catch (...) {
    remove_all();
    throw;
  }
  if (profile_.rate_kbit_s > 0)
    notes_.push_back("tbf rate " + format_number(profile_.rate_kbit_s) +
                     " kbit/s applied on both ends of every drone's veth");
  else
    notes_.push_back("no rate limit (profile rate 0)");
}

NetnsLinks::~NetnsLinks() { remove_all(); }

void NetnsLinks::wait_until_up() {
  // A veth reports carrier a moment after both ends are up; Fast DDS ignores interfaces
  // that are not running yet, and a process started then never discovers its peers.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  for (const auto& ns : created_ns_) {
    for (;;) {
      const auto links = run_command({"ip", "-n", ns, "-o", "link", "show", "type", "veth"});
      bool all_up = links.exit_code == 0;
      std::istringstream lines(links.output);
      for (std::string line; std::getline(lines, line);)
        if (line.find("state UP") == std::string::npos) all_up = false;
      if (all_up) break;
      if (std::chrono::steady_clock::now() > deadline)
        throw StartupError("link set-up failed: veths in " + ns +
                           " not up after 10 s: " + links.output);
      ::usleep(20000);  // polling interval of the condition above
    }
  }
}

void NetnsLinks::run_or_throw(const std::vector<std::string>& argv) {
  const auto result = run_command(argv);
  if (result.exit_code != 0)
    throw StartupError("link set-up failed: '" + join(argv) + "': " + result.output);
}

void NetnsLinks::shape(const std::string& ns, const std::string& device) {
  const bool wants_netem = profile_.delay_ms > 0 || profile_.loss_percent > 0;
  std::vector<std::string> netem_parent = {"root"};
  if (profile_.rate_kbit_s > 0) {
    const double bytes_per_s = profile_.rate_kbit_s * 1000.0 / 8.0;
    // At least two full frames, else tbf cannot send a 1500-byte packet at all.
    const auto burst = static_cast<long>(std::max(3200.0, bytes_per_s / 50.0));
    run_or_throw({"ip", "netns", "exec", ns, "tc", "qdisc", "add", "dev", device, "root", "handle",
                  "1:", "tbf", "rate", format_number(profile_.rate_kbit_s) + "kbit", "burst",
                  std::to_string(burst), "latency", kTbfLatency});
    netem_parent = {"parent", "1:1"};
  }
  if (wants_netem && netem_available_ != false) {
    std::vector<std::string> argv = {"ip",    "netns", "exec", ns,    "tc",
                                     "qdisc", "add",   "dev",  device};
    argv.insert(argv.end(), netem_parent.begin(), netem_parent.end());
    argv.insert(argv.end(), {"handle", "10:", "netem"});
    if (profile_.delay_ms > 0)
      argv.insert(argv.end(), {"delay", format_number(profile_.delay_ms) + "ms"});
    if (profile_.loss_percent > 0)
      argv.insert(argv.end(), {"loss", format_number(profile_.loss_percent) + "%"});
    const auto result = run_command(argv);
    const bool first = !netem_available_.has_value();
    netem_available_ = result.exit_code == 0;
    if (first) {
      const std::string what = "delay " + format_number(profile_.delay_ms) + " ms, loss " +
                               format_number(profile_.loss_percent) + " %";
      if (*netem_available_) {
        notes_.push_back("netem " + what + " applied on both ends of every drone's veth");
      } else {
        notes_.push_back("netem NOT available on this kernel (tc: " + result.output + "): " + what +
                         " NOT applied by netem");
      }
    }
  }
  if (profile_.loss_percent > 0 && netem_available_ == false) drop_randomly(ns, device);
}

void NetnsLinks::drop_randomly(const std::string& ns, const std::string& device) {
  // Without netem, loss is an nftables rule on the receiving end: each packet arriving on the
  // device is dropped with the profile's probability, on both ends, so both directions lose as
  // much. Dropped after it crossed the link, a lost packet has used the sender's rate, as a lost
  // radio frame uses airtime, and a capture at the sender sees it sent.
  const long percent = std::lround(profile_.loss_percent);
  const std::vector<std::string> nft = {"ip", "netns", "exec", ns, "nft"};
  const auto with = [&](std::vector<std::string> args) {
    args.insert(args.begin(), nft.begin(), nft.end());
    return args;
  };
  run_or_throw(with({"add", "table", "inet", "keyfleet_loss"}));
  run_or_throw(with({"add", "chain", "inet", "keyfleet_loss", "in", "{", "type", "filter", "hook",
                     "prerouting", "priority", "0", ";", "policy", "accept", ";", "}"}));
  run_or_throw(with({"add", "rule", "inet", "keyfleet_loss", "in", "iifname", device, "numgen",
                     "random", "mod", "100", "<", std::to_string(percent), "drop"}));
  if (!loss_noted_) {
    notes_.push_back(
        "loss " + std::to_string(percent) +
        " % by an nftables rule (numgen random) on arrival at both ends of every drone's veth");
    loss_noted_ = true;
  }
}

void NetnsLinks::remove_all() noexcept {
  // Deleting a namespace deletes the veth ends inside it, and with them their peers.
  for (auto it = created_ns_.rbegin(); it != created_ns_.rend(); ++it) {
    const auto result = run_command({"ip", "netns", "delete", *it});
    if (result.exit_code != 0)
      logger_->error("cannot delete network namespace {}: {}", *it, result.output);
  }
  created_ns_.clear();
}

std::vector<std::string> NetnsLinks::command_prefix(const std::string& process) const {
  for (std::size_t i = 0; i < robot_ids_.size(); ++i)
    if (robot_ids_[i] == process) return {"ip", "netns", "exec", drone_ns_[i]};
  return {"ip", "netns", "exec", station_ns_};
}

std::string NetnsLinks::station_address(std::size_t) const { return kStationAddress; }

std::vector<std::string> NetnsLinks::drone_addresses() const {
  std::vector<std::string> out;
  for (std::size_t i = 0; i < robot_ids_.size(); ++i) out.push_back(drone_address_of(i));
  return out;
}

std::optional<WireBytes> NetnsLinks::counters(const std::string& robot_id) const {
  for (std::size_t i = 0; i < robot_ids_.size(); ++i) {
    if (robot_ids_[i] != robot_id) continue;
    const std::string stats = "/sys/class/net/" + drone_if_[i] + "/statistics/";
    // `ip netns exec` mounts the namespace's own sysfs, where the veth is visible.
    const auto result = run_command(
        {"ip", "netns", "exec", drone_ns_[i], "cat", stats + "tx_bytes", stats + "rx_bytes"});
    if (result.exit_code != 0) return std::nullopt;
    std::istringstream values(result.output);
    WireBytes wire;
    if (values >> wire.tx_bytes >> wire.rx_bytes) return wire;
  }
  return std::nullopt;
}

}  // namespace keyfleet::mission
