#pragma once
#include <opencv2/core.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "keyfleet/common/jpeg_header.hpp"

namespace keyfleet {

struct DecodeResult {
  cv::Mat image;      // empty on failure
  std::string error;  // what went wrong, when image is empty
  bool ok() const { return !image.empty(); }
};

// Seam for how keyframe images travel: the agent encodes, the station decodes.
class ImageCodec {
 public:
  virtual ~ImageCodec() = default;
  virtual std::string encoding() const = 0;
  virtual std::vector<std::uint8_t> encode(const cv::Mat& image) const = 0;
  // At another quality (1..100) than the codec's own, for a sender that fits its link; a codec
  // without a quality ignores it.
  virtual std::vector<std::uint8_t> encode_at_quality(const cv::Mat& image, int quality) const {
    (void)quality;
    return encode(image);
  }
  // Never throws: bad bytes give an error, not an exception.
  virtual DecodeResult decode(const std::vector<std::uint8_t>& bytes) const = 0;
};

class JpegCodec final : public ImageCodec {
 public:
  explicit JpegCodec(int quality);
  std::string encoding() const override { return "jpeg"; }
  std::vector<std::uint8_t> encode(const cv::Mat& image) const override;
  std::vector<std::uint8_t> encode_at_quality(const cv::Mat& image, int quality) const override;
  // 8-bit BGR whatever the file's components (a grey JPEG comes as three equal channels), the
  // pixels of cv::imdecode(IMREAD_COLOR), the file's Exif orientation not applied.
  DecodeResult decode(const std::vector<std::uint8_t>& bytes) const override;

 private:
  int quality_;
};

}  // namespace keyfleet
