#pragma once
#include <cstdint>
#include <vector>

#include "keyfleet/agent/frame_source.hpp"
#include "keyfleet/agent/keyframe_selector.hpp"
#include "keyfleet/common/image_codec.hpp"

namespace keyfleet::testing {

// Replays an agent's deterministic source and selection, independently of the agent
// process, to get the exact JPEG bytes it must have published, by sequence number.
inline std::vector<std::vector<std::uint8_t>> expected_images(const AgentConfig& config) {
  auto source = agent::make_generated_source(config.source);
  auto selector = agent::make_selector(config.selector, config.source.fps);
  JpegCodec codec(config.codec.jpeg_quality);
  std::vector<std::vector<std::uint8_t>> images;
  while (auto frame = source->next())
    for (const auto& selection : selector->push(*frame).selected)
      images.push_back(codec.encode(selection.frame.image));
  for (const auto& selection : selector->finish())
    images.push_back(codec.encode(selection.frame.image));
  return images;
}

}  // namespace keyfleet::testing
