#include "keyfleet/eval/text_eval.hpp"

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <tuple>

#include "keyfleet/common/error.hpp"

namespace keyfleet::eval {
namespace {

std::string lower_ascii(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// The official script's special characters; "·" is two bytes in UTF-8.
const std::vector<std::string>& edge_punctuation() {
  static const std::vector<std::string> marks = {"!", "?", ".",        ":", ",", "*", "\"",
                                                 "(", ")", "\xC2\xB7", "[", "]", "/", "'"};
  return marks;
}

std::size_t leading_mark(const std::string& s) {
  for (const auto& m : edge_punctuation())
    if (s.size() > m.size() && s.compare(0, m.size(), m) == 0) return m.size();
  return 0;
}

std::size_t trailing_mark(const std::string& s) {
  for (const auto& m : edge_punctuation())
    if (s.size() > m.size() && s.compare(s.size() - m.size(), m.size(), m) == 0) return m.size();
  return 0;
}

using Quad = std::array<cv::Point2f, 4>;

std::vector<cv::Point2f> hull_of(const Quad& quad) {
  std::vector<cv::Point2f> hull;
  cv::convexHull(std::vector<cv::Point2f>(quad.begin(), quad.end()), hull);
  return hull;
}

struct Overlap {
  double intersection = 0;
  double area_a = 0, area_b = 0;
};

// Ground-truth quads are convex in practice; their convex hull is what is compared.
Overlap overlap_of(const Quad& a, const Quad& b) {
  Overlap o;
  const auto hull_a = hull_of(a), hull_b = hull_of(b);
  o.area_a = cv::contourArea(hull_a);
  o.area_b = cv::contourArea(hull_b);
  if (o.area_a <= 0 || o.area_b <= 0) return o;
  std::vector<cv::Point2f> common;
  o.intersection = std::max(0.0, double(cv::intersectConvexConvex(hull_a, hull_b, common, true)));
  return o;
}

// The next non-empty line of an ICDAR ground-truth file, without its byte-order mark (first
// line) and line ending; `line_number` counts every line read.
bool next_gt_line(std::istream& in, std::string& line, int& line_number) {
  while (std::getline(in, line)) {
    ++line_number;
    if (line_number == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);
    while (!line.empty() && (line.back() == '\r' || line.back() == '\n')) line.pop_back();
    if (!line.empty()) return true;
  }
  return false;
}

}  // namespace

EndToEndCounts& EndToEndCounts::operator+=(const EndToEndCounts& other) {
  matched += other.matched;
  gt_words += other.gt_words;
  detections += other.detections;
  return *this;
}

double EndToEndCounts::recall() const {
  return gt_words ? double(matched) / double(gt_words) : 0.0;
}

double EndToEndCounts::precision() const {
  return detections ? double(matched) / double(detections) : 0.0;
}

double EndToEndCounts::f_score() const {
  const double r = recall(), p = precision();
  return r + p > 0 ? 2 * r * p / (r + p) : 0.0;
}

double quad_iou(const std::array<cv::Point2f, 4>& a, const std::array<cv::Point2f, 4>& b) {
  const Overlap o = overlap_of(a, b);
  const double uni = o.area_a + o.area_b - o.intersection;
  return uni > 0 && o.area_a > 0 && o.area_b > 0 ? o.intersection / uni : 0.0;
}

double quad_rect_iou(const std::array<cv::Point2f, 4>& quad, const cv::Rect& rect) {
  return rect.width > 0 && rect.height > 0 ? quad_iou(quad, station::corners_of(rect)) : 0.0;
}

bool transcriptions_match(const std::string& gt_text, const std::string& detected,
                          bool allow_gt_edge_punctuation) {
  const std::string gt = lower_ascii(gt_text), det = lower_ascii(detected);
  if (gt == det) return true;
  if (!allow_gt_edge_punctuation) return false;
  const std::size_t lead = leading_mark(gt), trail = trailing_mark(gt);
  if (lead && gt.substr(lead) == det) return true;
  if (trail && gt.substr(0, gt.size() - trail) == det) return true;
  return lead && trail && gt.size() > lead + trail &&
         gt.substr(lead, gt.size() - lead - trail) == det;
}

EndToEndCounts match_end_to_end(const std::vector<GtWord>& truth,
                                const std::vector<station::ReadWord>& detections,
                                const EndToEndParams& params) {
  // Candidate pairs (IoU, gt, det) with matching text, best overlap first.
  std::vector<std::tuple<double, std::size_t, std::size_t>> pairs;
  for (std::size_t g = 0; g < truth.size(); ++g) {
    if (truth[g].dont_care) continue;
    for (std::size_t d = 0; d < detections.size(); ++d) {
      const double iou = quad_iou(truth[g].quad, station::outline_of(detections[d]));
      if (iou >= params.min_iou &&
          transcriptions_match(truth[g].text, detections[d].text, params.allow_gt_edge_punctuation))
        pairs.emplace_back(iou, g, d);
    }
  }
  std::sort(pairs.begin(), pairs.end(),
            [](const auto& a, const auto& b) { return std::get<0>(a) > std::get<0>(b); });
  std::vector<bool> gt_used(truth.size(), false), det_used(detections.size(), false);
  EndToEndCounts counts;
  for (const auto& [iou, g, d] : pairs) {
    if (gt_used[g] || det_used[d]) continue;
    gt_used[g] = det_used[d] = true;
    ++counts.matched;
  }
  for (const auto& word : truth) counts.gt_words += word.dont_care ? 0 : 1;
  for (std::size_t d = 0; d < detections.size(); ++d) {
    bool ignored = false;
    const Quad outline = station::outline_of(detections[d]);
    for (std::size_t g = 0; !det_used[d] && !ignored && g < truth.size(); ++g) {
      if (!truth[g].dont_care) continue;
      const Overlap o = overlap_of(outline, truth[g].quad);
      ignored = o.area_a > 0 && o.intersection / o.area_a > params.dont_care_overlap;
    }
    counts.detections += ignored ? 0 : 1;
  }
  return counts;
}

std::vector<GtWord> read_icdar_gt(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw StartupError("cannot read ICDAR ground truth " + path);
  std::vector<GtWord> words;
  std::string line;
  int line_number = 0;
  while (next_gt_line(in, line, line_number)) {
    GtWord word;
    std::size_t pos = 0;
    for (int i = 0; i < 8; ++i) {
      const std::size_t comma = line.find(',', pos);
      if (comma == std::string::npos)
        throw StartupError(path + ":" + std::to_string(line_number) +
                           ": expected 8 coordinates and a transcription");
      try {
        const float v = std::stof(line.substr(pos, comma - pos));
        (i % 2 ? word.quad[i / 2].y : word.quad[i / 2].x) = v;
      } catch (const std::exception&) {
        throw StartupError(path + ":" + std::to_string(line_number) + ": bad coordinate '" +
                           line.substr(pos, comma - pos) + "'");
      }
      pos = comma + 1;
    }
    word.text = line.substr(pos);  // may hold commas
    word.dont_care = word.text == "###";
    words.push_back(std::move(word));
  }
  return words;
}

std::vector<CroppedWord> read_mmocr_labels(const std::string& labels_json) {
  namespace fs = std::filesystem;
  std::ifstream in(labels_json);
  if (!in) throw StartupError("cannot read word labels " + labels_json);
  std::vector<CroppedWord> words;
  try {
    const auto json = nlohmann::json::parse(in);
    const fs::path images = fs::path(labels_json).parent_path() / "imgs";
    for (const auto& item : json.at("data_list")) {
      CroppedWord word;
      word.image_path = (images / item.at("img_path").get<std::string>()).string();
      word.text = item.at("instances").at(0).at("text").get<std::string>();
      words.push_back(std::move(word));
    }
  } catch (const nlohmann::json::exception& e) {
    throw StartupError("malformed word labels " + labels_json + ": " + e.what());
  }
  return words;
}

std::vector<CroppedWord> read_icdar_word_gt(const std::string& gt_txt) {
  namespace fs = std::filesystem;
  std::ifstream in(gt_txt, std::ios::binary);
  if (!in) throw StartupError("cannot read word ground truth " + gt_txt);
  const fs::path folder = fs::path(gt_txt).parent_path();
  std::vector<CroppedWord> words;
  std::string line;
  int line_number = 0;
  while (next_gt_line(in, line, line_number)) {
    const std::size_t comma = line.find(", \"");
    if (comma == std::string::npos || line.size() < comma + 4 || line.back() != '"')
      throw StartupError(gt_txt + ":" + std::to_string(line_number) +
                         ": expected 'word_N.png, \"TEXT\"'");
    CroppedWord word;
    word.image_path = (folder / line.substr(0, comma)).string();
    const std::string quoted = line.substr(comma + 3, line.size() - comma - 4);
    for (std::size_t i = 0; i < quoted.size(); ++i) {
      if (quoted[i] == '\\' && i + 1 < quoted.size()) ++i;
      word.text += quoted[i];
    }
    words.push_back(std::move(word));
  }
  return words;
}

std::vector<CroppedWord> read_word_set(const std::string& folder) {
  namespace fs = std::filesystem;
  const fs::path labels = fs::path(folder) / "labels.json";
  if (fs::exists(labels)) return read_mmocr_labels(labels.string());
  const fs::path gt = fs::path(folder) / "gt.txt";
  if (fs::exists(gt)) return read_icdar_word_gt(gt.string());
  throw StartupError("no word set in " + folder + " (neither labels.json nor gt.txt)");
}

std::string cropped_word_reading(const std::vector<station::ReadWord>& words) {
  std::vector<const station::ReadWord*> ordered;
  for (const auto& w : words) ordered.push_back(&w);
  std::sort(
      ordered.begin(), ordered.end(),
      [](const station::ReadWord* a, const station::ReadWord* b) { return a->box.x < b->box.x; });
  std::string text;
  for (const auto* w : ordered) text += w->text;
  return text;
}

}  // namespace keyfleet::eval
