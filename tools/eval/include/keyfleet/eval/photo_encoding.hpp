#pragma once
// What the station would receive for a real photo sent at one of the robot's encodings (JPEG
// quality, scale, text-aware: agent::encode_at_level), for `keyfleet ocr eval --encoding`: the
// end-to-end F on the ICDAR 2015 photos against the bytes a photo took.
#include <opencv2/core.hpp>

#include <memory>
#include <string>

#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/eval/eval_config.hpp"
#include "keyfleet/eval/text_dataset_eval.hpp"
#include "keyfleet/vision/text_segmenter.hpp"

namespace keyfleet::eval {

// "NAME=QUALITY[@SCALE][+text]", e.g. "q55=55", "q40h=40@0.5", "ta40=40@0.5+text". Throws
// ConfigError naming the spec and what is wrong.
EvalEncoding parse_encoding_spec(const std::string& spec);

// A text-aware encoding's regions come from `segmenter` (the robot's semantic model, as the
// agent runs it) through agent::text_regions; a plain encoding ignores both. Throws StartupError
// when a photo does not encode or decode.
PhotoLink make_photo_link(const EvalEncoding& encoding, int text_margin_px,
                          std::shared_ptr<vision::TextSegmenter> segmenter,
                          const TextRegionsConfig& regions = {});

}  // namespace keyfleet::eval
