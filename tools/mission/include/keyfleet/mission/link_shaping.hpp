#pragma once
// Emulated radio links on one machine: the station in a network namespace of its own, each
// drone in another, joined by a veth pair shaped with tbf (rate) and netem (delay, loss)
// where the kernel has it; without netem, loss is an nftables rule. Needs root, iproute2 and
// (for loss without netem) nftables.
#include <optional>
#include <string>
#include <vector>

#include "keyfleet/common/logging.hpp"
#include "keyfleet/mission/bandwidth_metrics.hpp"
#include "keyfleet/mission/experiment_config.hpp"

namespace keyfleet::mission {

struct CommandResult {
  int exit_code = -1;  // -1: could not run
  std::string output;  // stdout and stderr
};

// Runs argv (looked up on PATH) and waits for it.
CommandResult run_command(const std::vector<std::string>& argv);

// Why namespaces cannot be used here, or nullopt when they can (root, ip works).
std::optional<std::string> netns_unavailable_reason();

// Deletes namespaces left by experiment processes that died without cleaning up.
void remove_stale_namespaces(Logger logger);

class NetnsLinks {
 public:
  // Builds the namespaces and links; on failure removes what it made and throws
  // StartupError with the command and its output.
  NetnsLinks(const std::vector<std::string>& robot_ids, const LinkProfileConfig& profile,
             Logger logger);
  ~NetnsLinks();  // deletes the namespaces, and with them the veth pairs
  NetnsLinks(const NetnsLinks&) = delete;
  NetnsLinks& operator=(const NetnsLinks&) = delete;

  // `ip netns exec NS` for "ground_station" or a robot id.
  std::vector<std::string> command_prefix(const std::string& process) const;
  std::string station_address(std::size_t drone) const;
  std::vector<std::string> drone_addresses() const;
  // Drone i's end of its link (inside its namespace, reached with command_prefix(robot id)).
  const std::string& drone_interface(std::size_t drone) const { return drone_if_.at(drone); }
  // The drone end's veth counters (tx = drone -> station); nullopt when unreadable.
  std::optional<WireBytes> counters(const std::string& robot_id) const;
  // One line per shaping step: what was applied and what was not (and why).
  const std::vector<std::string>& notes() const { return notes_; }

 private:
  void run_or_throw(const std::vector<std::string>& argv);
  void shape(const std::string& ns, const std::string& device);
  void drop_randomly(const std::string& ns, const std::string& device);
  void wait_until_up();
  void remove_all() noexcept;

  LinkProfileConfig profile_;
  Logger logger_;
  std::string prefix_;
  std::string station_ns_;
  std::vector<std::string> robot_ids_;
  std::vector<std::string> drone_ns_;
  std::vector<std::string> drone_if_;
  std::vector<std::string> created_ns_;
  std::vector<std::string> notes_;
  std::optional<bool> netem_available_;
  bool loss_noted_ = false;
};

}  // namespace keyfleet::mission
