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
// `reduce` 2, 4 or 8 decodes at 1/reduce of the size (each side rounded up) by libjpeg's DCT
// scaling: the smaller image comes straight from the coefficients (the entropy decoding stays the
// same work, the rest shrinks), close to an area resize of the full decode but not equal to it.
// `full_size`, when given, gets the image's own size. Other values of `reduce` are refused (false).
bool decode_jpeg_bgr(const std::uint8_t* data, std::size_t size, cv::Mat& out, int reduce = 1,
                     cv::Size* full_size = nullptr);

// The bytes of cv::imencode(".jpg", image, {IMWRITE_JPEG_QUALITY, quality}) for an 8-bit BGR
// image (OpenCV's other settings at their defaults). False for any other image type.
bool encode_jpeg_bgr(const cv::Mat& image, int quality, std::vector<std::uint8_t>& out);

// cv::imread(path, IMREAD_COLOR), with JPEGs decoded by decode_jpeg_bgr; `bytes` holds the
// file and is reused from call to call. Empty when the file cannot be read or decoded. With
// `reduce` > 1 a JPEG is decoded at 1/reduce of its size and `full_size` (when given) gets its
// own; other formats, and JPEGs libjpeg cannot take, come whole (full_size = their size), through
// OpenCV's codecs (opencv_io.hpp): StartupError where their plugin cannot be loaded.
cv::Mat read_image_bgr(const std::string& path, std::vector<std::uint8_t>& bytes, int reduce = 1,
                       cv::Size* full_size = nullptr);

}  // namespace keyfleet
