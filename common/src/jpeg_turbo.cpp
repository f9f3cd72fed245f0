#include "keyfleet/common/jpeg_turbo.hpp"

#include <opencv2/imgcodecs.hpp>  // the flags only: the codecs are image_files()'s

#include <csetjmp>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>

// jpeglib.h needs FILE and size_t declared first.
#include <jpeglib.h>

#include "keyfleet/common/opencv_io.hpp"

namespace keyfleet {
namespace {

// libjpeg reports errors through a callback that must not return: it jumps back to the
// setjmp in the function that started the (de)compression, whose locals are all trivial.
struct ErrorManager {
  jpeg_error_mgr base;
  std::jmp_buf jump;
};

[[noreturn]] void on_error(j_common_ptr info) {
  std::longjmp(reinterpret_cast<ErrorManager*>(info->err)->jump, 1);
}
void on_message(j_common_ptr) {}  // warnings (a truncated scan) leave the decoded image as is

bool has_exif(const jpeg_decompress_struct& info) {
  for (jpeg_saved_marker_ptr m = info.marker_list; m; m = m->next)
    if (m->marker == JPEG_APP0 + 1 && m->data_length >= 6 && std::memcmp(m->data, "Exif\0", 6) == 0)
      return true;
  return false;
}

struct Destination {  // where jpeg_mem_dest puts the encoded bytes (malloc'd by libjpeg)
  unsigned char* data = nullptr;
  unsigned long size = 0;
};

}  // namespace

bool decode_jpeg_bgr(const std::uint8_t* data, std::size_t size, cv::Mat& out, int reduce,
                     cv::Size* full_size) {
  if (size < 4 || data[0] != 0xFF || data[1] != 0xD8) return false;
  if (reduce != 1 && reduce != 2 && reduce != 4 && reduce != 8) return false;
  jpeg_decompress_struct info;
  ErrorManager error;
  info.err = jpeg_std_error(&error.base);
  error.base.error_exit = on_error;
  error.base.output_message = on_message;
  jpeg_create_decompress(&info);
  if (setjmp(error.jump)) {
    jpeg_destroy_decompress(&info);
    return false;
  }
  jpeg_mem_src(&info, data, static_cast<unsigned long>(size));
  jpeg_save_markers(&info, JPEG_APP0 + 1, 0xFFFF);
  jpeg_read_header(&info, TRUE);
  const bool supported = info.jpeg_color_space == JCS_YCbCr ||
                         info.jpeg_color_space == JCS_GRAYSCALE || info.jpeg_color_space == JCS_RGB;
  if (!supported || has_exif(info)) {
    jpeg_destroy_decompress(&info);
    return false;
  }
  info.out_color_space = JCS_EXT_BGR;
  info.scale_num = 1;
  info.scale_denom = static_cast<unsigned int>(reduce);
  if (full_size) *full_size = cv::Size(int(info.image_width), int(info.image_height));
  jpeg_start_decompress(&info);
  out.create(int(info.output_height), int(info.output_width), CV_8UC3);
  while (info.output_scanline < info.output_height) {
    JSAMPROW row = out.ptr(int(info.output_scanline));
    jpeg_read_scanlines(&info, &row, 1);
  }
  jpeg_finish_decompress(&info);
  jpeg_destroy_decompress(&info);
  return true;
}

bool encode_jpeg_bgr(const cv::Mat& image, int quality, std::vector<std::uint8_t>& out) {
  if (image.type() != CV_8UC3 || image.empty()) return false;
  jpeg_compress_struct info;
  ErrorManager error;
  Destination destination;
  info.err = jpeg_std_error(&error.base);
  error.base.error_exit = on_error;
  error.base.output_message = on_message;
  jpeg_create_compress(&info);
  if (setjmp(error.jump)) {
    jpeg_destroy_compress(&info);
    std::free(destination.data);
    return false;
  }
  jpeg_mem_dest(&info, &destination.data, &destination.size);
  info.image_width = JDIMENSION(image.cols);
  info.image_height = JDIMENSION(image.rows);
  info.input_components = 3;
  info.in_color_space = JCS_EXT_BGR;
  jpeg_set_defaults(&info);
  jpeg_set_quality(&info, quality, TRUE);
  jpeg_start_compress(&info, TRUE);
  while (info.next_scanline < info.image_height) {
    JSAMPROW row = const_cast<JSAMPROW>(image.ptr(int(info.next_scanline)));
    jpeg_write_scanlines(&info, &row, 1);
  }
  jpeg_finish_compress(&info);
  jpeg_destroy_compress(&info);
  out.assign(destination.data, destination.data + destination.size);
  std::free(destination.data);
  return true;
}

cv::Mat read_image_bgr(const std::string& path, std::vector<std::uint8_t>& bytes, int reduce,
                       cv::Size* full_size) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) return {};
  const std::streamoff size = in.tellg();
  if (size <= 0) return {};
  bytes.resize(std::size_t(size));
  in.seekg(0);
  if (!in.read(reinterpret_cast<char*>(bytes.data()), size)) return {};
  cv::Mat image;
  if (decode_jpeg_bgr(bytes.data(), bytes.size(), image, reduce, full_size)) return image;
  try {
    image = image_files().decode(bytes, cv::IMREAD_COLOR);
  } catch (const cv::Exception&) {
    image.release();
  }
  if (full_size) *full_size = image.size();
  return image;
}

}  // namespace keyfleet
