#pragma once
// Text-segmentation accuracy and speed, like Table III of Alonso et al. (ICRA 2019).
#include <functional>
#include <string>
#include <vector>

#include "keyfleet/vision/text_segmenter.hpp"

namespace keyfleet::eval {

struct SegmentationScores {
  std::size_t images = 0;
  double recall = 0, precision = 0, iou = 0;  // of the text class, pixels pooled over images
  // Whether the share of text found ranks the images as their true share of text does (what a
  // semantic keyframe score needs): Spearman's rho over the images, NaN below 3 images or when
  // either side is constant.
  double frame_rank_correlation = 0;
};

// Spearman's rank correlation of paired samples (tied values share their mean rank); NaN when
// there are fewer than 3 pairs or either side is constant.
double spearman_rho(const std::vector<double>& a, const std::vector<double>& b);

// images/NNNNNN.jpg + masks/NNNNNN.png pairs (keyfleet scenario training output).
SegmentationScores evaluate_on_pairs(vision::TextSegmenter& segmenter, const std::string& folder,
                                     std::size_t max_images);

// ICDAR 2015 photos with gt/gt_<name>.txt: word quadrilaterals filled as text ('###' too, as
// the boxes-as-masks protocol of COCO-Text does). `images` is the folder of .jpg files; `keep`
// (when given) picks photos by file stem ("img_10"), before max_images counts them.
using StemFilter = std::function<bool(const std::string& stem)>;
SegmentationScores evaluate_on_icdar(vision::TextSegmenter& segmenter, const std::string& images,
                                     const std::string& ground_truth, std::size_t max_images,
                                     const StemFilter& keep = {});

// The MiniNet recipe's validation split of ICDAR 2015 train: image ids divisible by 10.
bool icdar_validation_id(const std::string& stem);

// Median milliseconds of one forward pass on a frame at the segmenter's input size.
double median_forward_ms(vision::TextSegmenter& segmenter, int repetitions);

// The same for several segmenters taking turns, so that the noise of a shared machine hits them
// alike and their ratios hold.
std::vector<double> median_forward_ms(const std::vector<vision::TextSegmenter*>& segmenters,
                                      int repetitions);

}  // namespace keyfleet::eval
