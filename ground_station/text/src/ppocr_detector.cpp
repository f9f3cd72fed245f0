#include "ppocr_detector.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

#include "keyfleet/common/error.hpp"
#include "keyfleet/vision/dnn_layers.hpp"

namespace keyfleet::station {
namespace {

// PaddleOCR normalises with the ImageNet numbers (published in RGB order) applied to the
// channels in the order OpenCV decoded them, so 0.485 goes to blue. The model was trained so.
constexpr float kMean[3] = {0.485f, 0.456f, 0.406f};
constexpr float kStd[3] = {0.229f, 0.224f, 0.225f};

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

namespace ppocr {

cv::Mat to_bgr8(const cv::Mat& image) {
  if (image.empty() || image.depth() != CV_8U) return {};
  cv::Mat bgr;
  switch (image.channels()) {
    case 3: return image;
    case 1: cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR); return bgr;
    case 4: cv::cvtColor(image, bgr, cv::COLOR_BGRA2BGR); return bgr;
    default: return {};
  }
}

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

}  // namespace ppocr

PpocrDetector::PpocrDetector(const std::string& model_path, cv::Size input_size,
                             const DbParams& params)
    : input_size_(input_size), params_(params) {
  if (input_size.width <= 0 || input_size.height <= 0 || input_size.width % 32 != 0 ||
      input_size.height % 32 != 0)
    throw StartupError("ppocr detector: input size " + std::to_string(input_size.width) + "x" +
                       std::to_string(input_size.height) + " is not a multiple of 32");
  // keyfleet's float stand-ins for OpenCV's 1x1, dense 3x3 and depthwise convolutions: the same
  // map to float rounding in about 0.7x the time. OpenCV creates the layers on import and on the
  // first pass (the probe below), so the scope covers both.
  const vision::DnnLayersScope stand_ins(vision::DnnLayers::in_float());
  try {
    net_ = cv::dnn::readNetFromONNX(model_path);
  } catch (const cv::Exception& e) {
    throw StartupError("ppocr detector: cannot load '" + model_path + "': " + e.what());
  }
  if (net_.empty()) throw StartupError("ppocr detector: '" + model_path + "' holds no network");
  net_.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  net_.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
  // One pass on a blank input: a file converted for another size fails here, not per image.
  const int shape[] = {1, 3, input_size.height, input_size.width};
  if (probability_map(cv::Mat(4, shape, CV_32F, cv::Scalar(0))).empty())
    throw StartupError("ppocr detector: '" + model_path + "' does not give a " +
                       std::to_string(input_size.width) + "x" + std::to_string(input_size.height) +
                       " probability map");
}

cv::Mat PpocrDetector::probability_map(const cv::Mat& blob) {
  try {
    net_.setInput(blob);
    cv::Mat out = net_.forward();
    if (out.dims != 4 || out.size[2] != input_size_.height || out.size[3] != input_size_.width)
      return {};
    return cv::Mat(input_size_, CV_32F, out.ptr<float>()).clone();
  } catch (const cv::Exception&) {
    return {};
  }
}

std::vector<DetectedText> PpocrDetector::detect(const cv::Mat& image) {
  const cv::Mat bgr = ppocr::to_bgr8(image);
  if (bgr.empty()) return {};
  const float scale = std::min(float(input_size_.width) / float(bgr.cols),
                               float(input_size_.height) / float(bgr.rows));
  const cv::Size fitted(std::clamp(cvRound(float(bgr.cols) * scale), 1, input_size_.width),
                        std::clamp(cvRound(float(bgr.rows) * scale), 1, input_size_.height));
  try {
    cv::Mat resized, normalised;
    cv::resize(bgr, resized, fitted, 0, 0, cv::INTER_LINEAR);
    resized.convertTo(normalised, CV_32FC3, 1.0 / 255.0);
    normalised -= cv::Scalar(kMean[0], kMean[1], kMean[2]);
    cv::divide(normalised, cv::Scalar(kStd[0], kStd[1], kStd[2]), normalised);
    // Padded with 0 after normalising (the data set's mean), which the network sees as nothing.
    cv::Mat padded(input_size_, CV_32FC3, cv::Scalar::all(0));
    normalised.copyTo(padded(cv::Rect(cv::Point(0, 0), fitted)));
    const cv::Mat prob = probability_map(cv::dnn::blobFromImage(padded));
    if (prob.empty()) return {};
    return ppocr::db_postprocess(prob, fitted, scale, bgr.size(), params_);
  } catch (const cv::Exception&) {
    return {};
  }
}

}  // namespace keyfleet::station
