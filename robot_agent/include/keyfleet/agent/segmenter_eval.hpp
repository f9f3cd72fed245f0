#pragma once
// Text-segmentation accuracy and speed, like the first seed's Table III.
#include <string>
#include <vector>

#include "keyfleet/agent/text_segmenter.hpp"

namespace keyfleet::agent {

struct SegmentationScores {
  std::size_t images = 0;
  double recall = 0, precision = 0, iou = 0;  // of the text class, pixels pooled over images
};

// images/NNNNNN.jpg + masks/NNNNNN.png pairs (keyfleet scenario training output).
SegmentationScores evaluate_on_pairs(TextSegmenter& segmenter, const std::string& folder,
                                     std::size_t max_images);

// ICDAR 2015 photos with gt/gt_<name>.txt: word quadrilaterals filled as text ('###' too, as
// the boxes-as-masks protocol of COCO-Text does). `images` is the folder of .jpg files.
SegmentationScores evaluate_on_icdar(TextSegmenter& segmenter, const std::string& images,
                                     const std::string& ground_truth, std::size_t max_images);

// Median milliseconds of one forward pass on a frame at the segmenter's input size.
double median_forward_ms(TextSegmenter& segmenter, int repetitions);

// The same for several segmenters taking turns, so that the noise of a shared machine hits them
// alike and their ratios hold.
std::vector<double> median_forward_ms(const std::vector<TextSegmenter*>& segmenters,
                                      int repetitions);

}  // namespace keyfleet::agent
