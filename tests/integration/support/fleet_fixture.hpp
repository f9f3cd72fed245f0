#pragma once
// Helpers for integration tests that run real agent and station processes over real
// Fast DDS on an isolated domain and partition, localhost only.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/common/transport.hpp"
#include "keyfleet/mission/child_process.hpp"
#include "keyfleet/station/station_config.hpp"

namespace keyfleet::testing {

// Polls `condition` until it holds or `timeout` passes (no fixed sleeps).
bool wait_until(const std::function<bool()>& condition, std::chrono::milliseconds timeout);

// The whole file as text; "" when it cannot be read (not there yet).
std::string read_file(const std::filesystem::path& path);

// A 64x48 JPEG keyframe of one colour (`shade`: its blue), for tests that publish by hand.
Keyframe small_keyframe(const std::string& robot_id, std::uint64_t sequence, int shade = 40);

// Publishes `k` on `link` until the station answers its number (a sample written while the link
// matches may be missed): the first answer taken, or none within `timeout`.
std::optional<KeyframeAck> first_answer(AgentLink& link, const Keyframe& k,
                                        std::chrono::milliseconds timeout);

struct StoredKeyframe {
  std::string robot_id;
  std::uint64_t sequence_number = 0;
  std::uint64_t frame_index = 0;
  std::vector<std::uint8_t> image;
};

// The station stored exactly `expected` for this robot: sequences 0..n-1, each image
// byte-identical, and (when frame_stride > 0) frame i * frame_stride for sequence i.
void expect_stored_exactly(const std::vector<StoredKeyframe>& stored, const std::string& robot,
                           const std::vector<std::vector<std::uint8_t>>& expected,
                           std::uint64_t frame_stride);

class FleetFixture : public ::testing::Test {
 protected:
  void SetUp() override;
  void TearDown() override;
  // For tests that SIGKILL a process: its Fast DDS shared-memory segments stay behind.
  static void remove_stale_shared_memory();

  // Settings shared by every process of this test: unique domain and partition,
  // fast discovery (lease 2 s, announcements 0.5 s) so that tests wait seconds, not tens;
  // DDS-Security off (tests that want it set dds.security).
  DdsSettings dds() const;
  AgentConfig agent_config(const std::string& robot_id) const;
  StationConfig station_config() const;

  // The station's output goes to <station_dir>/station.log unless `log_path` is given.
  std::unique_ptr<mission::ChildProcess> start_station(const StationConfig& config,
                                                       const std::filesystem::path& log_path = {});
  std::unique_ptr<mission::ChildProcess> start_agent(const AgentConfig& config);

  std::filesystem::path station_dir() const { return run_dir_ / "station"; }
  std::filesystem::path agent_dir(const std::string& robot_id) const { return run_dir_ / robot_id; }

  std::map<std::string, std::int64_t> stored_counts() const;
  // Every agent exits 0 within `timeout`; then the station stops cleanly on SIGTERM.
  void finish_mission(std::vector<std::unique_ptr<mission::ChildProcess>>& agents,
                      mission::ChildProcess& station, std::chrono::seconds timeout);
  std::vector<StoredKeyframe> stored_keyframes() const;
  std::int64_t outbox_pending(const std::string& robot_id) const;
  std::set<std::uint64_t> outbox_pending_sequences(const std::string& robot_id) const;
  // Keyframes the agent ever created (its outbox's next sequence number); 0 without an outbox.
  std::int64_t outbox_created(const std::string& robot_id) const;
  std::vector<std::string> rejection_reasons() const;

  std::filesystem::path run_dir_;
  int domain_id_ = 0;
  std::string partition_;
};

}  // namespace keyfleet::testing
