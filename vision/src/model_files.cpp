#include "keyfleet/vision/model_files.hpp"

#include <filesystem>

#include "keyfleet/common/error.hpp"
#include "keyfleet/vision/dnn_layers.hpp"

namespace keyfleet::vision {

std::string locate_model(const std::string& configured, const std::string& what) {
  namespace fs = std::filesystem;
  if (fs::is_regular_file(configured)) return configured;
  std::error_code error;
  const fs::path self = fs::read_symlink("/proc/self/exe", error);
  const fs::path shared = self.parent_path().parent_path() / "share" / "keyfleet" / "models";
  if (!error && fs::path(configured).is_relative()) {
    const fs::path installed = shared / configured;
    if (fs::is_regular_file(installed)) return installed.string();
  }
  throw StartupError(what + ": '" + configured + "' not found (as given, or in " + shared.string() +
                     ")");
}

cv::dnn::Net load_onnx_network(const std::string& path, const std::string& what) {
  if (!std::filesystem::is_regular_file(path))
    throw StartupError(what + ": model file " + path + " does not exist");
  cv::dnn::Net net;
  try {
    net = cv::dnn::readNetFromONNX(path);
  } catch (const cv::Exception& e) {
    throw StartupError(what + ": cannot load " + path + " (corrupt or not ONNX): " + e.what());
  }
  if (net.empty()) throw StartupError(what + ": " + path + " holds no network");
  net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
  if (DnnLayersScope* scope = DnnLayersScope::current()) scope->watch(net);
  return net;
}

}  // namespace keyfleet::vision
