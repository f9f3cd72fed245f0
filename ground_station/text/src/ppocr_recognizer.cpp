#include "ppocr_recognizer.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>

#include "keyfleet/common/error.hpp"
#include "keyfleet/vision/dnn_layers.hpp"

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

std::vector<bool> latin_classes(const std::vector<std::string>& classes) {
  std::vector<bool> allowed(classes.size(), false);
  for (std::size_t c = 0; c < classes.size(); ++c) {
    const std::string& s = classes[c];
    const auto b0 = s.empty() ? 0u : static_cast<unsigned char>(s[0]);
    if (c == 0 || (s.size() == 1 && b0 >= 0x20 && b0 < 0x7F)) {
      allowed[c] = true;  // the blank and printable ASCII, the space included
    } else if (s.size() == 2 && b0 >= 0xC3 && b0 <= 0xC9) {
      allowed[c] = true;  // U+00C0..U+024F: accented Latin letters
    } else if (s == "\xC2\xA3" || s == "\xE2\x82\xAC" || s == "\xC2\xB0") {
      allowed[c] = true;  // pound, euro, degree
    }
  }
  return allowed;
}

namespace {

// One emitted character: its class and the time steps of its run.
struct CtcCharacter {
  int cls = 0;
  int first_step = 0, last_step = 0;
  float probability = 0;  // of its class, at the run's first step
};

std::vector<CtcCharacter> ctc_characters(const cv::Mat& probs, const std::vector<bool>& allowed) {
  std::vector<CtcCharacter> characters;
  int previous = 0;
  for (int t = 0; t < probs.rows; ++t) {
    const float* row = probs.ptr<float>(t);
    int c = 0;
    for (int k = 1; k < probs.cols; ++k)
      if ((allowed.empty() || allowed[std::size_t(k)]) && row[k] > row[c]) c = k;
    if (c != 0 && c == previous) {  // the same character still running
      characters.back().last_step = t;
      continue;
    }
    previous = c;
    if (c != 0) characters.push_back({c, t, t, row[c]});  // blanks separate repeats, emit nothing
  }
  return characters;
}

// The largest probability of a space class at steps first..last.
float space_probability(const cv::Mat& probs, const std::vector<int>& space_classes, int first,
                        int last) {
  float best = 0;
  for (int t = std::max(first, 0); t <= last && t < probs.rows; ++t)
    for (const int c : space_classes) best = std::max(best, probs.at<float>(t, c));
  return best;
}

}  // namespace

RecognizedLine ctc_decode(const cv::Mat& probs, const std::vector<std::string>& classes,
                          int input_width, int content_width, const TextQuad& quad, bool rotated,
                          const CtcOptions& options) {
  RecognizedLine line;
  if (probs.empty() || probs.type() != CV_32F || probs.cols != int(classes.size()) ||
      content_width <= 0 || (!options.allowed.empty() && options.allowed.size() != classes.size()))
    return line;
  // Fraction of the line's content covered by one time step.
  const float step_fraction = float(input_width) / float(probs.rows) / float(content_width);
  // Reading runs along the top edge, or, for a cut turned counter-clockwise, down the right side.
  const cv::Point2f& top_start = rotated ? quad[1] : quad[0];
  const cv::Point2f& top_end = rotated ? quad[2] : quad[1];
  const cv::Point2f& bottom_start = rotated ? quad[0] : quad[3];
  const cv::Point2f& bottom_end = rotated ? quad[3] : quad[2];

  const std::vector<CtcCharacter> characters = ctc_characters(probs, options.allowed);
  std::vector<int> space_classes;
  for (std::size_t c = 0; c < classes.size(); ++c)
    if (is_space(classes[c])) space_classes.push_back(int(c));
  RecognizedWord word;
  float confidence_sum = 0;
  int count = 0, first_step = 0, last_step = 0;
  const auto finish_word = [&] {
    if (count > 0) {
      word.confidence = confidence_sum / float(count);
      const float f0 = std::clamp(float(first_step) * step_fraction, 0.f, 1.f);
      const float f1 = std::clamp(float(last_step + 1) * step_fraction, 0.f, 1.f);
      word.quad = {lerp(top_start, top_end, f0), lerp(top_start, top_end, f1),
                   lerp(bottom_start, bottom_end, f1), lerp(bottom_start, bottom_end, f0)};
      line.words.push_back(word);
    }
    word = RecognizedWord{};
    confidence_sum = 0;
    count = 0;
  };
  for (const CtcCharacter& character : characters) {
    const std::string& text = classes[std::size_t(character.cls)];
    if (is_space(text)) {
      finish_word();
      continue;
    }
    if (count > 0 && options.space_probability > 0 &&
        space_probability(probs, space_classes, last_step + 1, character.first_step) >=
            options.space_probability)
      finish_word();
    if (count == 0) first_step = character.first_step;
    last_step = character.last_step;
    word.text += text;
    confidence_sum += character.probability;
    ++count;
  }
  finish_word();
  return line;
}

}  // namespace ppocr

PpocrRecognizer::PpocrRecognizer(const std::map<int, std::string>& models_by_width,
                                 const std::string& keys_path, RecognizerOptions options)
    : classes_(load_classes(keys_path)) {
  if (options.latin_only) options_.allowed = ppocr::latin_classes(classes_);
  options_.space_probability = options.space_probability;
  if (models_by_width.empty()) throw StartupError("ppocr recogniser: no model files");
  // keyfleet's stand-ins for OpenCV's 1x1, dense 3x3 and depthwise convolutions (in float: the
  // same probabilities to float rounding in about 0.7x the time); the scope covers the import and
  // the first pass of each network (OpenCV creates layers in both).
  vision::DnnLayersScope stand_ins(options.layers);
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
    stand_ins.watch(net);  // its first pass below fuses layers (DnnLayersScope::watch)
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
    return ppocr::ctc_decode(probs, classes_, width, content_width, quad, rotated, options_);
  } catch (const cv::Exception&) {
    return std::nullopt;
  }
}

}  // namespace keyfleet::station
