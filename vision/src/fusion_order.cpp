#include "fusion_order.hpp"

#include <algorithm>

#include "keyfleet/vision/dnn_layers.hpp"

namespace keyfleet::vision {
namespace {

// In `net` (which holds `self` at `first`): whether every layer after `self` up to `next` is
// named in `inside`.
bool only_inside_between(cv::dnn::Net& net, int first, const std::string& next,
                         const std::vector<std::string>& inside) {
  const int last = net.getLayerId(next);
  if (last <= first) return false;
  for (int id = first + 1; id < last; ++id) {
    const cv::Ptr<cv::dnn::Layer> layer = net.getLayer(id);
    if (!layer || std::find(inside.begin(), inside.end(), layer->name) == inside.end())
      return false;
  }
  return true;
}

}  // namespace

bool FusionOrder::runs_next(const cv::dnn::Layer& self, const cv::dnn::Layer& next) {
  if (const DnnLayersScope* scope = DnnLayersScope::current()) {
    for (cv::dnn::Net net : scope->watched()) {
      try {
        const int first = net.getLayerId(self.name);
        if (first < 0 || net.getLayer(first).get() != &self) continue;
        return decided_[next.name] = only_inside_between(net, first, next.name, inside_);
      } catch (const cv::Exception&) {
        return decided_[next.name] = false;
      }
    }
  }
  const auto known = decided_.find(next.name);
  return known != decided_.end() && known->second;
}

cv::Ptr<cv::dnn::Layer> FusionOrder::sole_reader(const cv::dnn::Layer& layer) {
  const std::vector<cv::Ptr<cv::dnn::Layer>> all = readers(layer);
  return all.size() == 1 ? all[0] : cv::Ptr<cv::dnn::Layer>();
}

std::vector<cv::Ptr<cv::dnn::Layer>> FusionOrder::readers(const cv::dnn::Layer& layer) {
  if (DnnLayersScope* scope = DnnLayersScope::current()) {
    std::vector<cv::Ptr<cv::dnn::Layer>> found;
    try {
      if (scope->readers(layer, found)) return readers_[layer.name] = found;
    } catch (const cv::Exception&) {
      return readers_[layer.name] = {};
    }
  }
  const auto known = readers_.find(layer.name);
  return known != readers_.end() ? known->second : std::vector<cv::Ptr<cv::dnn::Layer>>();
}

}  // namespace keyfleet::vision
