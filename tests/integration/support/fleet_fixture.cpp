#include "fleet_fixture.hpp"

#include <unistd.h>

#include <csignal>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <random>
#include <sstream>

#include "keyfleet/common/image_codec.hpp"
#include "keyfleet/common/sqlite.hpp"

namespace keyfleet::testing {
namespace fs = std::filesystem;

bool wait_until(const std::function<bool()>& condition, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (condition()) return true;
    ::usleep(20000);  // polling interval of the condition, not a wait for an outcome
  }
  return condition();
}

void expect_stored_exactly(const std::vector<StoredKeyframe>& stored, const std::string& robot,
                           const std::vector<std::vector<std::uint8_t>>& expected,
                           std::uint64_t frame_stride) {
  std::vector<const StoredKeyframe*> mine;
  for (const auto& k : stored)
    if (k.robot_id == robot) mine.push_back(&k);
  ASSERT_EQ(mine.size(), expected.size()) << robot << " lost or duplicated keyframes";
  for (std::size_t seq = 0; seq < expected.size(); ++seq) {
    EXPECT_EQ(mine[seq]->sequence_number, seq);
    if (frame_stride) {
      EXPECT_EQ(mine[seq]->frame_index, seq * frame_stride);
    }
    EXPECT_TRUE(mine[seq]->image == expected[seq])
        << robot << " keyframe " << seq << " differs from what the agent encoded";
  }
}

std::string read_file(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

Keyframe small_keyframe(const std::string& robot_id, std::uint64_t sequence, int shade) {
  Keyframe k;
  k.robot_id = robot_id;
  k.sequence_number = sequence;
  k.encoding = "jpeg";
  k.width = 64;
  k.height = 48;
  k.image = JpegCodec(80).encode(cv::Mat(48, 64, CV_8UC3, cv::Scalar(shade, 120, 200)));
  return k;
}

std::optional<KeyframeAck> first_answer(AgentLink& link, const Keyframe& k,
                                        std::chrono::milliseconds timeout) {
  std::optional<KeyframeAck> first;
  wait_until(
      [&] {
        link.publish(k);
        for (const auto& ack : link.take_acks(k.robot_id, std::chrono::milliseconds(300)))
          if (!first && ack.sequence_number == k.sequence_number) first = ack;
        return first.has_value();
      },
      timeout);
  return first;
}

void FleetFixture::finish_mission(std::vector<std::unique_ptr<mission::ChildProcess>>& agents,
                                  mission::ChildProcess& station, std::chrono::seconds timeout) {
  for (auto& agent : agents) {
    const auto status = agent->wait_for(timeout);
    ASSERT_TRUE(status.has_value()) << agent->name() << " did not finish";
    EXPECT_TRUE(status->ok()) << agent->name() << " " << status->describe() << "\n"
                              << mission::tail_of_file(agent->log_path(), 20);
  }
  station.signal(SIGTERM);
  const auto station_status = station.wait_for(std::chrono::seconds(30));
  ASSERT_TRUE(station_status && station_status->ok())
      << mission::tail_of_file(station.log_path(), 20);
}

void FleetFixture::SetUp() {
  std::random_device entropy;
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  run_dir_ = fs::temp_directory_path() /
             ("keyfleet-it-" + std::string(info->name()) + "-" + std::to_string(::getpid()) + "-" +
              std::to_string(entropy() % 100000));
  fs::create_directories(run_dir_);
  domain_id_ = static_cast<int>(100 + (static_cast<unsigned>(::getpid()) + entropy()) % 130);
  partition_ = "it-" + std::string(info->name()) + "-" + std::to_string(entropy());
}

void FleetFixture::TearDown() {
  if (!HasFailure())
    fs::remove_all(run_dir_);
  else
    std::cerr << "run folder kept for inspection: " << run_dir_ << "\n";
}

void FleetFixture::remove_stale_shared_memory() {
  if (std::system("fastdds shm clean > /dev/null 2>&1") != 0)
    std::cerr << "note: 'fastdds shm clean' failed; stale /dev/shm/fastrtps_* may remain\n";
}

DdsSettings FleetFixture::dds() const {
  DdsSettings s;
  s.domain_id = domain_id_;
  s.partition = partition_;
  s.lease_duration_s = 2.0;
  s.announcement_period_s = 0.5;
  s.security.enabled = false;  // plain DDS unless a test secures it (test_dds_security)
  return s;
}

AgentConfig FleetFixture::agent_config(const std::string& robot_id) const {
  AgentConfig c;
  c.robot_id = robot_id;
  c.dds = dds();
  c.source.kind = SourceConfig::Kind::kGenerated;
  c.source.realtime = false;
  c.source.max_frames = 60;
  c.source.width = 320;
  c.source.height = 240;
  c.selector.strategy = SelectorConfig::Strategy::kVslam;
  c.selector.trigger.kind = TriggerConfig::Kind::kStride;
  c.selector.trigger.stride = 5;
  c.stats_period_s = 0.5;
  c.wait_for_station_s = 20;
  c.drain_timeout_s = 60;
  c.outbox.resend_after_s = 1.0;
  return c;
}

StationConfig FleetFixture::station_config() const {
  StationConfig c;
  c.dds = dds();
  c.report_period_s = 1.0;
  // The analysis runs, but these tests are about delivery: a stop does not wait for it
  // (what is left is analysed when a station next starts on the database).
  c.analysis.drain_timeout_s = 2;
  return c;
}

namespace {
void write(const fs::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}
}  // namespace

std::unique_ptr<mission::ChildProcess> FleetFixture::start_station(const StationConfig& config,
                                                                   const fs::path& log_path) {
  fs::create_directories(station_dir());
  const fs::path yaml = run_dir_ / "station.yaml";
  write(yaml, to_yaml(config));
  return std::make_unique<mission::ChildProcess>(
      "ground_station",
      std::vector<std::string>{KEYFLEET_STATION_BIN, "--config", yaml.string(), "--run-dir",
                               station_dir().string()},
      (log_path.empty() ? station_dir() / "station.log" : log_path).string());
}

std::unique_ptr<mission::ChildProcess> FleetFixture::start_agent(const AgentConfig& config) {
  const fs::path dir = agent_dir(config.robot_id);
  fs::create_directories(dir);
  const fs::path yaml = run_dir_ / (config.robot_id + ".yaml");
  write(yaml, to_yaml(config));
  return std::make_unique<mission::ChildProcess>(
      config.robot_id,
      std::vector<std::string>{KEYFLEET_AGENT_BIN, "--config", yaml.string(), "--run-dir",
                               dir.string()},
      (dir / "agent.log").string());
}

std::map<std::string, std::int64_t> FleetFixture::stored_counts() const {
  std::map<std::string, std::int64_t> counts;
  const fs::path db_path = station_dir() / "station.sqlite";
  if (!fs::exists(db_path)) return counts;
  try {
    SqliteDb db(db_path.string(), SqliteDb::Mode::kReadOnly);
    auto q = db.prepare("SELECT robot_id, COUNT(*) FROM keyframes GROUP BY robot_id");
    while (q.step()) counts[q.text(0)] = q.int64(1);
  } catch (const SqliteError&) {
  }
  return counts;
}

std::vector<StoredKeyframe> FleetFixture::stored_keyframes() const {
  SqliteDb db((station_dir() / "station.sqlite").string(), SqliteDb::Mode::kReadOnly);
  auto q = db.prepare(
      "SELECT robot_id, sequence_number, frame_index, image FROM keyframes "
      "ORDER BY robot_id, sequence_number");
  std::vector<StoredKeyframe> out;
  while (q.step())
    out.push_back({q.text(0), static_cast<std::uint64_t>(q.int64(1)),
                   static_cast<std::uint64_t>(q.int64(2)), q.blob(3)});
  return out;
}

std::int64_t FleetFixture::outbox_pending(const std::string& robot_id) const {
  try {
    return static_cast<std::int64_t>(outbox_pending_sequences(robot_id).size());
  } catch (const SqliteError&) {
    return 0;
  }
}

std::set<std::uint64_t> FleetFixture::outbox_pending_sequences(const std::string& robot_id) const {
  std::set<std::uint64_t> sequences;
  const fs::path path = agent_dir(robot_id) / "outbox.sqlite";
  if (!fs::exists(path)) return sequences;
  SqliteDb db(path.string(), SqliteDb::Mode::kReadOnly);
  auto q = db.prepare("SELECT sequence_number FROM pending");
  while (q.step()) sequences.insert(static_cast<std::uint64_t>(q.int64(0)));
  return sequences;
}

std::int64_t FleetFixture::outbox_created(const std::string& robot_id) const {
  const fs::path path = agent_dir(robot_id) / "outbox.sqlite";
  if (!fs::exists(path)) return 0;
  try {
    SqliteDb db(path.string(), SqliteDb::Mode::kReadOnly);
    auto q = db.prepare("SELECT value FROM meta WHERE key='next_sequence'");
    return q.step() ? std::stoll(q.text(0)) : 0;
  } catch (const SqliteError&) {
    return 0;
  }
}

std::vector<std::string> FleetFixture::rejection_reasons() const {
  std::vector<std::string> out;
  SqliteDb db((station_dir() / "station.sqlite").string(), SqliteDb::Mode::kReadOnly);
  auto q = db.prepare("SELECT reason FROM rejected ORDER BY received_ns");
  while (q.step()) out.push_back(q.text(0));
  return out;
}

}  // namespace keyfleet::testing
