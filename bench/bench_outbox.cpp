// What the agent's durability costs per keyframe: Outbox::add (its SQLite WAL committed with
// synchronous=FULL, so a power cut cannot roll a sequence number back) and acknowledge, beside
// the same insert committed with synchronous=NORMAL (what it was before). Images of 60 KB, the
// size of a 640x480 keyframe at quality 85. The disk decides: run it where the agent's outbox
// lives. Prints figures; never pass/fail.
//   build/bin/bench_outbox [--benchmark_repetitions=5 --benchmark_report_aggregates_only=true]
#include <benchmark/benchmark.h>

#include <filesystem>
#include <random>

#include "keyfleet/agent/outbox.hpp"
#include "keyfleet/common/sqlite.hpp"

namespace {

using namespace keyfleet;
namespace fs = std::filesystem;

std::vector<std::uint8_t> image_bytes() {
  std::mt19937 random(7);
  std::vector<std::uint8_t> bytes(60000);
  for (auto& b : bytes) b = static_cast<std::uint8_t>(random());
  return bytes;
}

fs::path fresh(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("keyfleet_bench_outbox_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir / "outbox.sqlite";
}

void BM_OutboxAddAndAcknowledge(benchmark::State& state) {
  agent::Outbox outbox(fresh("full").string(), "drone_0", OutboxConfig{});
  Keyframe k;
  k.robot_id = "drone_0";
  k.encoding = "jpeg";
  k.width = 640;
  k.height = 480;
  k.image = image_bytes();
  std::int64_t now = 0;
  for (auto _ : state) {
    k.sequence_number = outbox.next_sequence();
    outbox.add(k, ++now);
    outbox.acknowledge(k.sequence_number);
  }
}
BENCHMARK(BM_OutboxAddAndAcknowledge)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_SameInsertSynchronousNormal(benchmark::State& state) {
  SqliteDb db(fresh("normal").string());
  db.exec("PRAGMA synchronous=NORMAL");
  db.exec("CREATE TABLE pending (sequence_number INTEGER PRIMARY KEY, image BLOB NOT NULL)");
  const auto image = image_bytes();
  std::int64_t sequence = 0;
  for (auto _ : state) {
    db.prepare("INSERT INTO pending VALUES(?, ?)").bind(1, ++sequence).bind(2, image).step();
    db.prepare("DELETE FROM pending WHERE sequence_number = ?").bind(1, sequence).step();
  }
}
BENCHMARK(BM_SameInsertSynchronousNormal)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
