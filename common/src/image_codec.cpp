#include "keyfleet/common/image_codec.hpp"

#include <opencv2/imgcodecs.hpp>  // the flags only: the codecs are image_files()'s

#include "keyfleet/common/error.hpp"
#include "keyfleet/common/jpeg_turbo.hpp"
#include "keyfleet/common/opencv_io.hpp"

namespace keyfleet {

JpegCodec::JpegCodec(int quality) : quality_(quality) {
  if (quality < 1 || quality > 100)
    throw StartupError("JPEG quality must be between 1 and 100, got " + std::to_string(quality));
}

std::vector<std::uint8_t> JpegCodec::encode(const cv::Mat& image) const {
  return encode_at_quality(image, quality_);
}

std::vector<std::uint8_t> JpegCodec::encode_at_quality(const cv::Mat& image, int quality) const {
  std::vector<std::uint8_t> bytes;
  if (encode_jpeg_bgr(image, quality, bytes)) return bytes;  // BGR: no RGB copy on the way
  if (!image_files().encode(".jpg", image, {cv::IMWRITE_JPEG_QUALITY, quality}, bytes))
    bytes.clear();
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
  // libjpeg-turbo straight into BGR (2.5x faster than cv::imdecode, the same pixels); OpenCV
  // for what it refuses (an Exif block, CMYK, corrupt data), with the orientation ignored as the
  // claimed size is the stored one.
  if (decode_jpeg_bgr(bytes.data(), bytes.size(), result.image)) return result;
  try {
    result.image = image_files().decode(bytes, cv::IMREAD_COLOR | cv::IMREAD_IGNORE_ORIENTATION);
  } catch (const cv::Exception& e) {
    result.error = std::string("JPEG decoder failed: ") + e.what();
    return result;
  } catch (const StartupError& e) {
    result.error = std::string("no decoder for this JPEG: ") + e.what();
    return result;
  }
  if (result.image.empty()) result.error = "corrupt JPEG (decoder returned no image)";
  return result;
}

}  // namespace keyfleet
