#pragma once
// The semantic seam: a network that marks text pixels. The real implementation runs an ONNX
// model through OpenCV DNN, described by a JSON file beside it (model.onnx -> model.json): a
// segmenter with class logits (MiniNet: a pixel is text where a text class has the largest
// logit) or a DB text detector with one probability map (PP-OCR's: the mask is its text boxes,
// filled).
#include <opencv2/core.hpp>
#include <opencv2/dnn.hpp>

#include "keyfleet/vision/db_boxes.hpp"
#include "keyfleet/vision/dnn_layers.hpp"
#include "keyfleet/vision/semantic_config.hpp"

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace keyfleet::vision {

struct SegmenterInfo {
  enum class Output {
    kClassLogits,      // N x classes x H x W; "output": "class_logits" (the default)
    kTextProbability,  // N x 1 x H x W, DB's text probability; "output": "text_probability"
  };
  cv::Size input_size;       // frames are resized to this
  int size_multiple = 1;     // the network needs H and W multiples of this
  int max_batch = 0;         // frames a forward pass takes at most (0: any number)
  double scale = 1.0 / 255;  // blob = (pixel - mean) * scale / std, BGR order
  cv::Scalar mean_bgr{127.5, 127.5, 127.5};
  cv::Scalar std_bgr{1, 1, 1};
  Output output = Output::kClassLogits;
  DbParams boxes;  // kTextProbability: how the map becomes boxes ("db" in the description)
  std::vector<std::string> classes;
  std::vector<int> target_classes;  // indices into classes: what counts as "text"
  std::string description;
  double gflops_512x256 = 0;  // the network's cost at 512x256 (0 = not given)
};

class TextSegmenter {
 public:
  virtual ~TextSegmenter() = default;
  // One mask per frame (CV_8U, 255 = a target-class pixel) at the model's input size.
  virtual std::vector<cv::Mat> segment(const std::vector<cv::Mat>& bgr_frames) = 0;
  virtual const SegmenterInfo& info() const = 0;
};

// Reads the JSON description beside `model_path` (same name, .json). Throws StartupError.
SegmenterInfo read_segmenter_info(const std::string& model_path);

class DnnTextSegmenter final : public TextSegmenter {
 public:
  // Loads and checks the model with one forward pass at its input size: a missing or corrupt
  // file, or a network that does not take that input or gives the wrong output shape, is a
  // StartupError naming the file.
  // `input_size` overrides the description's (for evaluations at other resolutions).
  // `layers`: keyfleet's stand-ins for OpenCV's SELU, depthwise, 1x1 and transposed
  // convolutions (dnn_layers.hpp), in float the same outputs to float rounding; together MiniNet's
  // forward pass at 512x256 on one thread takes about 0.4x as long in float, 0.28x in bfloat16
  // (`keyfleet segmenter eval` compares them).
  DnnTextSegmenter(const std::string& model_path, int threads,
                   std::optional<cv::Size> input_size = std::nullopt, DnnLayers layers = {});
  std::vector<cv::Mat> segment(const std::vector<cv::Mat>& bgr_frames) override;
  const SegmenterInfo& info() const override { return info_; }
  // ms per layer type in the last forward pass (OpenCV's per-layer timers; keyfleet's stand-ins
  // are the "Keyfleet..." types, a SELU fused into the layer before it counts there).
  std::map<std::string, double> last_forward_ms_by_type() const;
  // The same per layer, in the network's order: its name, type and ms.
  struct LayerTime {
    std::string name, type;
    double ms = 0;
  };
  std::vector<LayerTime> last_forward_layers() const;

 private:
  SegmenterInfo info_;
  cv::dnn::Net net_;
};

// The segmenter a SemanticConfig describes (its model looked up as locate_model does).
std::unique_ptr<DnnTextSegmenter> make_text_segmenter(const SemanticConfig& config);

// The stand-in layers a semantic config asks for (all of them; bfloat16 and int8 as it says).
DnnLayers semantic_layers(const SemanticConfig& config);

}  // namespace keyfleet::vision
