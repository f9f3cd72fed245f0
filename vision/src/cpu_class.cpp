#include "keyfleet/vision/cpu_class.hpp"

#include <opencv2/core/utility.hpp>

#include <cstdlib>
#include <fstream>
#include <thread>
#include <utility>

#include "keyfleet/vision/dnn_layers.hpp"

#include "int8_product.hpp"

namespace keyfleet::vision {
namespace {

std::string cpu_model() {
  std::ifstream cpuinfo("/proc/cpuinfo");
  for (std::string line; std::getline(cpuinfo, line);) {
    if (line.rfind("model name", 0) != 0) continue;
    const auto colon = line.find(':');
    if (colon != std::string::npos) return line.substr(line.find_first_not_of(' ', colon + 1));
  }
  return "unknown CPU";
}

bool x86_has(const char* feature) {
#if defined(__x86_64__)
  __builtin_cpu_init();
  if (std::string(feature) == "avx2") return __builtin_cpu_supports("avx2");
  if (std::string(feature) == "fma") return __builtin_cpu_supports("fma");
  if (std::string(feature) == "avx512f") return __builtin_cpu_supports("avx512f");
#endif
  (void)feature;
  return false;
}

const char* yes_no(bool v) { return v ? "yes" : "no"; }

}  // namespace

std::string cpu_class_line() {
  std::string line = "CPU: " + cpu_model() + " (" +
                     std::to_string(std::thread::hardware_concurrency()) + " threads); AVX2+FMA " +
                     yes_no(x86_has("avx2") && x86_has("fma")) + ", AVX-512F " +
                     yes_no(x86_has("avx512f")) + ", AVX512-BF16 " +
                     yes_no(bfloat16_products_supported()) + "; OpenCV may use:";
  // What OpenCV's dispatch finds at run time, after OPENCV_CPU_DISABLE.
  const std::pair<int, const char*> features[] = {
      {CV_CPU_SSE4_2, "SSE4.2"},
      {CV_CPU_AVX, "AVX"},
      {CV_CPU_FMA3, "FMA3"},
      {CV_CPU_AVX2, "AVX2"},
      {CV_CPU_AVX_512F, "AVX512F"},
      {CV_CPU_AVX512_SKX, "AVX512_SKX"},
      {CV_CPU_AVX512_ICL, "AVX512_ICL"},
  };
  for (const auto& [id, name] : features)
    if (cv::checkHardwareSupport(id)) line += std::string(" ") + name;
  if (const char* disabled = std::getenv("OPENCV_CPU_DISABLE"))
    line += std::string(" [OPENCV_CPU_DISABLE=") + disabled + "]";
  return line;
}

std::string segmenter_kernels(bool bfloat16_wanted, bool int8_wanted) {
  if (!matrix_product_layers_supported()) return "OpenCV's layers";
  const std::string int8 =
      int8_wanted ? std::string(", wide 1x1 in int8 (") + int8_instructions() + ")" : "";
  if (bfloat16_wanted && bfloat16_products_supported())
    return "bfloat16 products (AVX512-BF16), depthwise in AVX2" + int8;
  return "float products, Winograd 3x3, depthwise in AVX2 (AVX2+FMA)" + int8;
}

}  // namespace keyfleet::vision
