#pragma once
// JPEG straight through libjpeg(-turbo) in OpenCV's BGR order. OpenCV 4.6's cv::imread and
// cv::imencode go through RGB and swap every row on the way: on a 640x480 frame the decode
// costs 2.5x what libjpeg-turbo's own BGR output does, for the same pixels.
#include <opencv2/core.hpp>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace keyfleet {

// Decodes a JPEG into 8-bit BGR, the pixels cv::imdecode(IMREAD_COLOR) gives; `out` keeps its
// buffer when the size matches and nobody else holds it. False (out unspecified) where the
// result could differ from OpenCV's or libjpeg fails: not a JPEG, CMYK, an Exif block (whose
// orientation cv::imread applies), corrupt data. Never throws.
bool decode_jpeg_bgr(const std::uint8_t* data, std::size_t size, cv::Mat& out);

// The bytes of cv::imencode(".jpg", image, {IMWRITE_JPEG_QUALITY, quality}) for an 8-bit BGR
// image (OpenCV's other settings at their defaults). False for any other image type.
bool encode_jpeg_bgr(const cv::Mat& image, int quality, std::vector<std::uint8_t>& out);

// cv::imread(path, IMREAD_COLOR), with JPEGs decoded by decode_jpeg_bgr; `bytes` holds the
// file and is reused from call to call. Empty when the file cannot be read or decoded.
cv::Mat read_image_bgr(const std::string& path, std::vector<std::uint8_t>& bytes);

}  // namespace keyfleet
