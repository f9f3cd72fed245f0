#include "keyfleet/eval/photo_encoding.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>

#include "keyfleet/agent/level_encoding.hpp"
#include "keyfleet/agent/text_regions.hpp"
#include "keyfleet/common/config_error.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/common/image_codec.hpp"

namespace keyfleet::eval {

EvalEncoding parse_encoding_spec(const std::string& spec) {
  const auto fail = [&](const std::string& why) {
    return ConfigError("--encoding '" + spec + "': " + why +
                       " (NAME=QUALITY[@SCALE][+text], e.g. ta40=40@0.5+text)");
  };
  const auto equals = spec.find('=');
  if (equals == std::string::npos || equals == 0) throw fail("no NAME=");
  EvalEncoding e;
  e.name = spec.substr(0, equals);
  const bool name_ok =
      e.name.size() <= 32 && std::all_of(e.name.begin(), e.name.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' || c == '-';
      });
  if (!name_ok) throw fail("the name must be 1 to 32 of [A-Za-z0-9_.-]");
  std::string rest = spec.substr(equals + 1);
  const std::string suffix = "+text";
  if (rest.size() > suffix.size() &&
      rest.compare(rest.size() - suffix.size(), suffix.size(), suffix) == 0) {
    e.text_aware = true;
    rest.resize(rest.size() - suffix.size());
  }
  const auto at = rest.find('@');
  const std::string quality = rest.substr(0, at);
  char* end = nullptr;
  const long q = std::strtol(quality.c_str(), &end, 10);
  if (quality.empty() || *end != '\0' || q < 1 || q > 100)
    throw fail("the quality must be a whole number from 1 to 100");
  e.jpeg_quality = static_cast<int>(q);
  if (at != std::string::npos) {
    const std::string scale = rest.substr(at + 1);
    e.scale = std::strtod(scale.c_str(), &end);
    if (scale.empty() || *end != '\0' || !(e.scale > 0 && e.scale <= 1))
      throw fail("the scale must be in (0, 1]");
  }
  return e;
}

PhotoLink make_photo_link(const EvalEncoding& encoding, int text_margin_px,
                          std::shared_ptr<vision::TextSegmenter> segmenter,
                          const TextRegionsConfig& regions) {
  if (encoding.text_aware && !segmenter)
    throw StartupError("encoding " + encoding.name + ": text-aware needs the semantic model");
  auto codec = std::make_shared<JpegCodec>(encoding.jpeg_quality);
  return [encoding, text_margin_px, segmenter, regions, codec](const cv::Mat& photo) {
    std::vector<TextRegion> found;
    if (encoding.text_aware && encoding.scale < 1.0)
      found = agent::text_regions(segmenter->segment({photo}).at(0), photo.size(), regions);
    const agent::SendLevel level{encoding.jpeg_quality, encoding.scale, 1};
    const agent::EncodedFrame encoded =
        agent::encode_at_level(photo, found, level, encoding.text_aware, text_margin_px, *codec);
    DecodeResult decoded = codec->decode(encoded.image);
    if (!decoded.ok())
      throw StartupError("encoding " + encoding.name +
                         ": a photo does not decode: " + decoded.error);
    ReceivedPhoto out;
    out.sx = double(photo.cols) / double(decoded.image.cols);
    out.sy = double(photo.rows) / double(decoded.image.rows);
    out.bytes = encoded.image.size();
    out.image = std::move(decoded.image);
    return out;
  };
}

}  // namespace keyfleet::eval
