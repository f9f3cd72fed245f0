#pragma once
#include <opencv2/dnn.hpp>

#include <string>

namespace keyfleet::vision {

// Where a configured model file (network, vocabulary) is: the path as given, else, for a
// relative path, beside the installed executables in <bin>/../share/keyfleet/models/.
// Throws StartupError naming `what` and both places when neither holds it.
std::string locate_model(const std::string& configured, const std::string& what);

// An ONNX network for OpenCV's own CPU backend, named to the calling thread's DnnLayersScope
// where one is alive (DnnLayersScope::watch). A missing, corrupt or empty file is a StartupError
// starting with `what` and naming the file.
cv::dnn::Net load_onnx_network(const std::string& path, const std::string& what);

}  // namespace keyfleet::vision
