#include "keyfleet/vision/db_boxes.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

namespace keyfleet::vision {
namespace {

// Mean of `prob` inside the polygon (PaddleOCR's "fast" box score).
float mean_inside(const cv::Mat& prob, const TextQuad& quad) {
  const std::vector<cv::Point2f> points(quad.begin(), quad.end());
  const cv::Rect bound = cv::boundingRect(points) & cv::Rect(0, 0, prob.cols, prob.rows);
  if (bound.empty()) return 0;
  cv::Mat mask = cv::Mat::zeros(bound.size(), CV_8U);
  std::vector<cv::Point> polygon;
  for (const auto& p : points) polygon.emplace_back(cvRound(p.x) - bound.x, cvRound(p.y) - bound.y);
  cv::fillPoly(mask, std::vector<std::vector<cv::Point>>{polygon}, cv::Scalar(1));
  return float(cv::mean(prob(bound), mask)[0]);
}

float shorter_side(const cv::RotatedRect& rect) {
  return std::min(rect.size.width, rect.size.height);
}

// Top-to-bottom; boxes whose tops differ by less than 10 px are one row, read left-to-right
// (PaddleOCR's sorted_boxes).
void sort_reading_order(std::vector<DetectedText>& boxes) {
  std::stable_sort(boxes.begin(), boxes.end(), [](const DetectedText& a, const DetectedText& b) {
    if (a.quad[0].y != b.quad[0].y) return a.quad[0].y < b.quad[0].y;
    return a.quad[0].x < b.quad[0].x;
  });
  for (std::size_t i = 1; i < boxes.size(); ++i)
    for (std::size_t j = i; j > 0; --j) {
      const auto& previous = boxes[j - 1].quad[0];
      const auto& current = boxes[j].quad[0];
      if (std::abs(current.y - previous.y) >= 10.f || current.x >= previous.x) break;
      std::swap(boxes[j - 1], boxes[j]);
    }
}

}  // namespace

TextQuad ordered_corners(const cv::RotatedRect& rect) {
  std::array<cv::Point2f, 4> p;
  rect.points(p.data());
  std::sort(p.begin(), p.end(),
            [](const cv::Point2f& a, const cv::Point2f& b) { return a.x < b.x; });
  // Of the two leftmost corners the upper one is top-left; the same on the right.
  const bool left_upper_first = p[0].y <= p[1].y;
  const bool right_upper_first = p[2].y <= p[3].y;
  const cv::Point2f top_left = left_upper_first ? p[0] : p[1];
  const cv::Point2f bottom_left = left_upper_first ? p[1] : p[0];
  const cv::Point2f top_right = right_upper_first ? p[2] : p[3];
  const cv::Point2f bottom_right = right_upper_first ? p[3] : p[2];
  return {top_left, top_right, bottom_right, bottom_left};
}

std::vector<cv::Point2f> offset_convex_polygon(const std::vector<cv::Point2f>& polygon,
                                               float distance, int arc_steps) {
  const std::size_t n = polygon.size();
  if (n < 3 || !(distance > 0) || arc_steps < 1) return polygon;
  // The orientation decides which side of an edge is outside.
  double twice_area = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const auto& a = polygon[i];
    const auto& b = polygon[(i + 1) % n];
    twice_area += double(a.x) * b.y - double(b.x) * a.y;
  }
  const float side = twice_area > 0 ? 1.f : -1.f;
  const auto outward_normal = [side](const cv::Point2f& a, const cv::Point2f& b) {
    const cv::Point2f d = b - a;
    const float length = std::hypot(d.x, d.y);
    if (length < 1e-6f) return cv::Point2f(0, 0);
    return cv::Point2f(d.y, -d.x) * (side / length);
  };
  const float pi = float(CV_PI);
  std::vector<cv::Point2f> out;
  out.reserve(n * std::size_t(arc_steps + 1));
  for (std::size_t i = 0; i < n; ++i) {
    // Around vertex i the offset boundary is an arc from the normal of the incoming edge to the
    // normal of the outgoing one; the edges between the arcs are the polygon's, moved outwards.
    const cv::Point2f& v = polygon[i];
    const cv::Point2f normal_in = outward_normal(polygon[(i + n - 1) % n], v);
    const cv::Point2f normal_out = outward_normal(v, polygon[(i + 1) % n]);
    const float start = std::atan2(normal_in.y, normal_in.x);
    float turn = std::atan2(normal_out.y, normal_out.x) - start;
    // The short way round: a convex polygon's exterior angles are below pi.
    while (turn > pi) turn -= 2 * pi;
    while (turn < -pi) turn += 2 * pi;
    for (int s = 0; s <= arc_steps; ++s) {
      const float angle = start + turn * float(s) / float(arc_steps);
      out.emplace_back(v.x + distance * std::cos(angle), v.y + distance * std::sin(angle));
    }
  }
  return out;
}

cv::RotatedRect unclip(const TextQuad& box, float ratio) {
  const std::vector<cv::Point2f> polygon(box.begin(), box.end());
  const double area = std::abs(cv::contourArea(polygon));
  const double perimeter = cv::arcLength(polygon, true);
  if (!(perimeter > 0)) return cv::minAreaRect(polygon);
  return cv::minAreaRect(offset_convex_polygon(polygon, float(area * ratio / perimeter)));
}

std::vector<DetectedText> db_postprocess(const cv::Mat& prob_map, cv::Size valid, float scale,
                                         cv::Size image_size, const DbParams& params) {
  std::vector<DetectedText> result;
  if (prob_map.empty() || prob_map.type() != CV_32F || !(scale > 0) || image_size.empty())
    return result;
  valid.width = std::min(valid.width, prob_map.cols);
  valid.height = std::min(valid.height, prob_map.rows);
  if (valid.width <= 0 || valid.height <= 0) return result;
  const cv::Mat prob = prob_map(cv::Rect(cv::Point(0, 0), valid));  // without the padding

  cv::Mat bitmap;
  cv::compare(prob, double(params.binary_threshold), bitmap, cv::CMP_GT);
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(bitmap, contours, cv::RETR_LIST, cv::CHAIN_APPROX_SIMPLE);

  const std::size_t candidates =
      std::min(contours.size(), std::size_t(std::max(0, params.max_candidates)));
  for (std::size_t i = 0; i < candidates; ++i) {
    if (contours[i].size() < 3) continue;
    const cv::RotatedRect rect = cv::minAreaRect(contours[i]);
    if (shorter_side(rect) < params.min_size) continue;
    const TextQuad box = ordered_corners(rect);
    const float score = mean_inside(prob, box);
    if (score < params.box_threshold) continue;
    const cv::RotatedRect grown = unclip(box, params.unclip_ratio);
    if (shorter_side(grown) < params.min_size + 2) continue;
    DetectedText text{ordered_corners(grown), score};
    for (auto& p : text.quad) {  // map pixels -> image pixels
      p.x = std::clamp(p.x / scale, 0.f, float(image_size.width - 1));
      p.y = std::clamp(p.y / scale, 0.f, float(image_size.height - 1));
    }
    result.push_back(text);
  }
  sort_reading_order(result);
  return result;
}

cv::Mat fill_boxes(const std::vector<DetectedText>& boxes, cv::Size size) {
  cv::Mat mask = cv::Mat::zeros(size, CV_8U);
  std::vector<std::vector<cv::Point>> polygons;
  for (const auto& box : boxes) {
    std::vector<cv::Point> corners;
    for (const auto& p : box.quad) corners.emplace_back(cvRound(p.x), cvRound(p.y));
    polygons.push_back(std::move(corners));
  }
  if (!polygons.empty()) cv::fillPoly(mask, polygons, cv::Scalar(255));
  return mask;
}

}  // namespace keyfleet::vision
