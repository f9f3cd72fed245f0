#pragma once
// Whether a stand-in may take over the layer that reads its output: OpenCV runs a network's layers
// in the order of their ids and lays the blobs out for that order before it fuses. A fused pair
// writes the second layer's output when the first layer runs; were a layer of another branch to
// run between the two, OpenCV may have laid that output over one of that layer's blobs (dead
// again by the second layer's turn) and the branch would overwrite it. So a stand-in takes over a
// layer only where every layer between the two is one it already runs (its activations). The
// order comes from the network the calling thread's DnnLayersScope watches (its first set-up);
// what was decided is kept for later set-ups (another input size), which may run outside any
// scope. Internal to keyfleet_vision (convolution_layers.cpp).
#include <opencv2/dnn.hpp>

#include <map>
#include <string>
#include <vector>

namespace keyfleet::vision {

class FusionOrder {
 public:
  // The layer named so now runs inside the fusing one (an activation, a layer taken over).
  void joined(const std::string& name) { inside_.push_back(name); }
  // OpenCV undid the fusions (before it fuses again).
  void clear() { inside_.clear(); }
  // Whether `next` runs right after `self` and the layers it runs; false where no watched network
  // holds `self` and nothing was decided for `next` before.
  bool runs_next(const cv::dnn::Layer& self, const cv::dnn::Layer& next);
  // The one layer that reads `layer`'s outputs in the network the scope watches, else null (none
  // or several, or no watched network holds it); what was found is kept for later set-ups.
  cv::Ptr<cv::dnn::Layer> sole_reader(const cv::dnn::Layer& layer);
  // Every layer that reads `layer`'s outputs there (empty: none, or no watched network holds it);
  // kept as sole_reader's.
  std::vector<cv::Ptr<cv::dnn::Layer>> readers(const cv::dnn::Layer& layer);

 private:
  std::vector<std::string> inside_;
  std::map<std::string, bool> decided_;                                  // by the next layer's name
  std::map<std::string, std::vector<cv::Ptr<cv::dnn::Layer>>> readers_;  // by the layer's name
};

}  // namespace keyfleet::vision
