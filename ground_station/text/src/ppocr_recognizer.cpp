#include "ppocr_recognizer.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>

#include "keyfleet/common/error.hpp"

namespace keyfleet::station {
namespace {

float distance(const cv::Point2f& a, const cv::Point2f& b) {
  return std::hypot(a.x - b.x, a.y - b.y);
}

cv::Point2f lerp(const cv::Point2f& a, const cv::Point2f& b, float t) { return a + (b - a) * t; }

bool is_space(const std::string& c) { return c == " " || c == "\xE3\x80\x80"; /* U+3000 */ }

// Blank, the keys file in order, then the space the model was trained with (use_space_char).
std::vector<std::string> load_classes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw StartupError("ppocr recogniser: cannot read the character list '" + path + "'");
  std::vector<std::string> classes{""};
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    classes.push_back(line);
  }
  if (classes.size() < 2)
    throw StartupError("ppocr recogniser: the character list '" + path + "' is empty");
  classes.push_back(" ");
  return classes;
}

// Scaled to height 48, x/127.5 - 1, padded right with 0 after normalising (as PaddleOCR).
cv::Mat make_blob(const cv::Mat& crop, int width, int& content_width) {
  content_width = std::clamp(
      int(std::ceil(PpocrRecognizer::kHeight * double(crop.cols) / double(crop.rows))), 1, width);
  cv::Mat resized, normalised;
  cv::resize(crop, resized, cv::Size(content_width, PpocrRecognizer::kHeight), 0, 0,
             cv::INTER_LINEAR);
  resized.convertTo(normalised, CV_32FC3, 1.0 / 127.5, -1.0);
  cv::Mat padded(PpocrRecognizer::kHeight, width, CV_32FC3, cv::Scalar::all(0));
  normalised.copyTo(padded(cv::Rect(0, 0, content_width, PpocrRecognizer::kHeight)));
  return cv::dnn::blobFromImage(padded);
}

}  // namespace

namespace ppocr {

cv::Mat crop_quad(const cv::Mat& image, const TextQuad& q, bool* rotated) {
  if (rotated) *rotated = false;
  const cv::Mat bgr = to_bgr8(image);
  if (bgr.empty()) return {};
  for (const auto& p : q)
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) return {};
  const float w = std::round(std::max(distance(q[0], q[1]), distance(q[3], q[2])));
  const float h = std::round(std::max(distance(q[0], q[3]), distance(q[1], q[2])));
  // Degenerate, or far larger than a text line: a wild quad must not allocate gigabytes.
  constexpr float kMaxSide = 8192;
  if (w < 2 || h < 2 || w > kMaxSide || h > kMaxSide) return {};
  const cv::Point2f corners[4] = {{0, 0}, {w, 0}, {w, h}, {0, h}};
  cv::Mat crop;
  cv::warpPerspective(bgr, crop, cv::getPerspectiveTransform(q.data(), corners),
                      cv::Size(int(w), int(h)), cv::INTER_CUBIC, cv::BORDER_REPLICATE);
  if (h / w >= 1.5f) {
    cv::rotate(crop, crop, cv::ROTATE_90_COUNTERCLOCKWISE);
    if (rotated) *rotated = true;
  }
  return crop;
}

RecognizedLine ctc_decode(const cv::Mat& probs, const std::vector<std::string>& classes,
                          int input_width, int content_width, const TextQuad& quad, bool rotated) {
  RecognizedLine line;
  if (probs.empty() || probs.type() != CV_32F || probs.cols != int(classes.size()) ||
      content_width <= 0)
    return line;
  // Fraction of the line's content covered by one time step.
  const float step_fraction = float(input_width) / float(probs.rows) / float(content_width);
  // Reading runs along the top edge, or, for a cut turned counter-clockwise, down the right side.
  const cv::Point2f& top_start = rotated ? quad[1] : quad[0];
  const cv::Point2f& top_end = rotated ? quad[2] : quad[1];
  const cv::Point2f& bottom_start = rotated ? quad[0] : quad[3];
  const cv::Point2f& bottom_end = rotated ? quad[3] : quad[2];

  RecognizedWord word;
  float confidence_sum = 0;
  int characters = 0, first_step = 0, last_step = 0;
  const auto finish_word = [&] {
    if (characters > 0) {
      word.confidence = confidence_sum / float(characters);
      const float f0 = std::clamp(float(first_step) * step_fraction, 0.f, 1.f);
      const float f1 = std::clamp(float(last_step + 1) * step_fraction, 0.f, 1.f);
      word.quad = {lerp(top_start, top_end, f0), lerp(top_start, top_end, f1),
                   lerp(bottom_start, bottom_end, f1), lerp(bottom_start, bottom_end, f0)};
      line.words.push_back(word);
    }
    word = RecognizedWord{};
    confidence_sum = 0;
    characters = 0;
  };

  int previous = 0;
  for (int t = 0; t < probs.rows; ++t) {
    double best = 0;
    cv::Point best_at;
    cv::minMaxLoc(probs.row(t), nullptr, &best, nullptr, &best_at);
    const int c = best_at.x;
    if (c != 0 && c == previous) {  // the same character still running
      if (characters > 0 && !is_space(classes[std::size_t(c)])) last_step = t;
      continue;
    }
    previous = c;
    if (c == 0) continue;  // CTC blank: separates repeats, emits nothing
    const std::string& character = classes[std::size_t(c)];
    if (is_space(character)) {
      finish_word();
      continue;
    }
    if (characters == 0) first_step = t;
    last_step = t;
    word.text += character;
    // A character's confidence is its probability at the first step of its run.
    confidence_sum += float(best);
    ++characters;
  }
  finish_word();
  return line;
}

}  // namespace ppocr

PpocrRecognizer::PpocrRecognizer(const std::map<int, std::string>& models_by_width,
                                 const std::string& keys_path)
    : classes_(load_classes(keys_path)) {
  if (models_by_width.empty()) throw StartupError("ppocr recogniser: no model files");
  for (const auto& [width, path] : models_by_width) {
    if (width <= 0 || width % 8 != 0)
      throw StartupError("ppocr recogniser: width " + std::to_string(width) +
                         " is not a positive multiple of 8");
    cv::dnn::Net net;
    try {
      net = cv::dnn::readNetFromONNX(path);
    } catch (const cv::Exception& e) {
      throw StartupError("ppocr recogniser: cannot load '" + path + "': " + e.what());
    }
    if (net.empty()) throw StartupError("ppocr recogniser: '" + path + "' holds no network");
    net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
    net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
    nets_.emplace(width, std::move(net));
    // One pass on a blank line: a file of another width or another character list fails here.
    const int shape[] = {1, 3, kHeight, width};
    if (class_probabilities(cv::Mat(4, shape, CV_32F, cv::Scalar(0)), width).empty())
      throw StartupError("ppocr recogniser: '" + path + "' does not give " +
                         std::to_string(classes_.size()) + " classes per step for width " +
                         std::to_string(width) + " (does it match '" + keys_path + "'?)");
  }
}

int PpocrRecognizer::bucket_width(const cv::Mat& crop) const {
  const double wanted = std::ceil(kHeight * double(crop.cols) / double(crop.rows));
  for (const auto& entry : nets_)
    if (entry.first >= wanted) return entry.first;
  return nets_.rbegin()->first;  // a long line: squeezed into the widest
}

cv::Mat PpocrRecognizer::class_probabilities(const cv::Mat& blob, int width) {
  const auto it = nets_.find(width);
  if (it == nets_.end()) return {};
  try {
    it->second.setInput(blob);
    cv::Mat out = it->second.forward();  // 1 x T x classes, softmax
    if (out.dims != 3 || out.size[2] != int(classes_.size())) return {};
    return cv::Mat(out.size[1], out.size[2], CV_32F, out.ptr<float>()).clone();
  } catch (const cv::Exception&) {
    return {};
  }
}

std::optional<RecognizedLine> PpocrRecognizer::recognize(const cv::Mat& image,
                                                         const TextQuad& quad) {
  try {
    bool rotated = false;
    const cv::Mat crop = ppocr::crop_quad(image, quad, &rotated);
    if (crop.empty()) return std::nullopt;
    const int width = bucket_width(crop);
    int content_width = 0;
    const cv::Mat probs = class_probabilities(make_blob(crop, width, content_width), width);
    if (probs.empty()) return std::nullopt;
    return ppocr::ctc_decode(probs, classes_, width, content_width, quad, rotated);
  } catch (const cv::Exception&) {
    return std::nullopt;
  }
}

}  // namespace keyfleet::station
