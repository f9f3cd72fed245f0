#pragma once
// Text boxes from a DB (differentiable binarisation) probability map, as PaddleOCR's
// DBPostProcess makes them: threshold -> contours -> minimum-area boxes -> mean probability inside
// the box -> unclip (polygon offset) -> quadrilaterals. The station's PP-OCR reader takes them as
// text lines; a segmenter with a probability output fills them as its text mask.
#include <opencv2/core.hpp>

#include <array>
#include <vector>

namespace keyfleet::vision {

// Four corners in reading order: top-left, top-right, bottom-right, bottom-left.
using TextQuad = std::array<cv::Point2f, 4>;

struct DetectedText {
  TextQuad quad;
  float score = 0;  // mean text probability inside the box before unclipping
};

struct DbParams {
  float binary_threshold = 0.3f;  // probability above which a map pixel is text
  float box_threshold = 0.6f;     // boxes with a lower mean probability are dropped
  float unclip_ratio = 1.5f;      // DB trains on shrunk text; boxes are grown back by this
  float min_size = 3;             // boxes with a shorter side (map pixels) are dropped
  int max_candidates = 1000;      // contours examined at most
};

// DB post-processing of a probability map (CV_32F). Only the top-left `valid` part of the map
// holds the image (the rest is letterbox padding); `scale` maps image to map pixels. Boxes come
// top-to-bottom, then left-to-right.
std::vector<DetectedText> db_postprocess(const cv::Mat& prob, cv::Size valid, float scale,
                                         cv::Size image_size, const DbParams& params);

// Corners of a rotated rectangle in TextQuad's order.
TextQuad ordered_corners(const cv::RotatedRect& rect);

// Minkowski sum of a convex polygon and a disc of radius `distance` (what Clipper's round-join
// offset computes, which PaddleOCR uses), arcs sampled with `arc_steps` segments.
std::vector<cv::Point2f> offset_convex_polygon(const std::vector<cv::Point2f>& polygon,
                                               float distance, int arc_steps = 8);

// PaddleOCR's unclip: the box offset by area * ratio / perimeter, as a minimum-area rectangle.
cv::RotatedRect unclip(const TextQuad& box, float ratio);

// `boxes` filled with 255 into a CV_8U mask of `size`.
cv::Mat fill_boxes(const std::vector<DetectedText>& boxes, cv::Size size);

}  // namespace keyfleet::vision
