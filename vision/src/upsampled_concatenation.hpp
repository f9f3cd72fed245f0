#pragma once
// A float 3x3 convolution (stride 1, padding 1, one group) over a concatenation some of whose
// slices are upsamplings handed over unwritten (upsampling_hand_over.hpp): PP-OCR's DB head
// reads the FPN's four levels, three of them upsampled by 8, 4 and 2, concatenated (96 x 120 x 160
// at 640x480). The channels written in place, one run of them, go through Winograd's F(4x4, 3x3)
// with the bias; each handed-over slice's share is computed at its small size and added
// (upsampled_taps.hpp); then the activations, plane by plane. Internal to keyfleet_vision
// (convolution_layers.cpp's 3x3 stand-in holds one).
#include <opencv2/core.hpp>
#include <opencv2/dnn/all_layers.hpp>

#include <memory>
#include <vector>

#include "upsampled_taps.hpp"
#include "upsampling_hand_over.hpp"
#include "winograd_3x3.hpp"

namespace keyfleet::vision {

class UpsampledConcatenation {
 public:
  // weights: outputs x inputs x 3 x 3, float; bias: empty or one per output.
  UpsampledConcatenation(const cv::Mat& weights, const cv::Mat& bias);

  void add(std::shared_ptr<UpsamplingHandOver> hand_over) {
    hand_overs_.push_back(std::move(hand_over));
  }
  void clear() { hand_overs_.clear(); }
  bool waiting() const;

  // out (one image, outputs planes of in's size, contiguous) from in (one image, 4-D, continuous,
  // the waiting slices unwritten), `activation` (may be null) applied to each plane. False, with
  // nothing written, where the hand-overs are not slices of `in` this can take, the channels
  // written in place are not one run of 8 or more, or there are fewer than 8 outputs.
  bool run(const cv::Mat& in, float* out, const cv::dnn::ActivationLayer* activation);

  // Writes every waiting slice (as unfused), for a pass run() does not take.
  void write_waiting();

 private:
  struct Slice {
    UpsamplingHandOver* hand_over;
    int first, channels, ky, kx;
  };
  UpsampledTaps& taps_for(int first, int channels);
  Winograd3x3& winograd_for(int first, int channels);

  cv::Mat weights_, bias_;
  std::vector<std::shared_ptr<UpsamplingHandOver>> hand_overs_;
  std::vector<std::unique_ptr<UpsampledTaps>> taps_;  // by first channel and count
  std::unique_ptr<Winograd3x3> winograd_;             // the channels written in place
  int winograd_first_ = -1, winograd_channels_ = 0;
};

}  // namespace keyfleet::vision
