#include "keyfleet/common/image_codec.hpp"

#include <opencv2/imgcodecs.hpp>

#include "keyfleet/common/error.hpp"
#include "keyfleet/common/jpeg_turbo.hpp"

namespace keyfleet {

JpegCodec::JpegCodec(int quality) : quality_(quality) {
  if (quality < 1 || quality > 100)
    throw StartupError("JPEG quality must be between 1 and 100, got " + std::to_string(quality));
}

std::vector<std::uint8_t> JpegCodec::encode(const cv::Mat& image) const {
  std::vector<std::uint8_t> bytes;
  if (encode_jpeg_bgr(image, quality_, bytes)) return bytes;  // BGR: no RGB copy on the way
  cv::imencode(".jpg", image, bytes, {cv::IMWRITE_JPEG_QUALITY, quality_});
  return bytes;
}

DecodeResult JpegCodec::decode(const std::vector<std::uint8_t>& bytes) const {
  DecodeResult result;
  if (bytes.empty()) {
    result.error = "empty image";
    return result;
  }
  if (!jpeg_dimensions(bytes)) {
    result.error = "not a JPEG (no start-of-frame header)";
    return result;
  }
  try {
    result.image = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    result.error = std::string("JPEG decoder failed: ") + e.what();
    return result;
  }
  if (result.image.empty()) result.error = "corrupt JPEG (decoder returned no image)";
  return result;
}

std::optional<ImageSize> jpeg_dimensions(const std::vector<std::uint8_t>& bytes) {
  const std::size_t n = bytes.size();
  if (n < 4 || bytes[0] != 0xFF || bytes[1] != 0xD8) return std::nullopt;
  std::size_t pos = 2;
  while (pos + 4 <= n) {
    if (bytes[pos] != 0xFF) return std::nullopt;
    const std::uint8_t marker = bytes[pos + 1];
    if (marker == 0xFF) {  // fill byte
      ++pos;
      continue;
    }
    if (marker == 0xD8 || marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) {
      pos += 2;  // markers without a length
      continue;
    }
    const std::size_t length = (std::size_t{bytes[pos + 2]} << 8) | bytes[pos + 3];
    if (length < 2 || pos + 2 + length > n) return std::nullopt;
    const bool start_of_frame =
        marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
    if (start_of_frame) {
      if (length < 7) return std::nullopt;
      ImageSize size;
      size.height = (std::uint32_t{bytes[pos + 5]} << 8) | bytes[pos + 6];
      size.width = (std::uint32_t{bytes[pos + 7]} << 8) | bytes[pos + 8];
      if (size.width == 0 || size.height == 0) return std::nullopt;
      return size;
    }
    if (marker == 0xDA || marker == 0xD9) return std::nullopt;  // scan before any SOF
    pos += 2 + length;
  }
  return std::nullopt;
}

}  // namespace keyfleet
