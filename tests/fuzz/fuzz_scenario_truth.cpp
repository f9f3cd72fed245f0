// The scenario ground-truth reader on hostile files: the first byte picks scenario.json (odd,
// e.g. 'S') or a drone's truth.jsonl (even, e.g. 'T'), the rest is the file. Reading either
// returns or throws std::runtime_error naming the file; nothing else.
#include <cstddef>
#include <cstdint>
#include <stdexcept>

#include "fuzz_file.hpp"
#include "keyfleet/common/scenario_truth.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  static const keyfleet::fuzz::FuzzFolder folder;
  const bool scenario = data[0] & 1;
  const std::string& dir =
      folder.write(scenario ? "scenario.json" : "truth.jsonl", data + 1, size - 1);
  try {
    if (scenario)
      keyfleet::scenario::read_scenario(dir);
    else
      keyfleet::scenario::read_frame_truth(dir);
  } catch (const std::runtime_error&) {
  }
  return 0;
}
