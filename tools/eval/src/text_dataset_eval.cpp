#include "keyfleet/eval/text_dataset_eval.hpp"

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>

#include "keyfleet/common/error.hpp"

namespace keyfleet::eval {
namespace {

namespace fs = std::filesystem;

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const auto mid = values.begin() + long(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

// Reads and times one image.
std::vector<station::ReadWord> timed_read(station::TextReader& reader, const cv::Mat& image,
                                          std::vector<double>& ms) {
  const auto start = std::chrono::steady_clock::now();
  auto words = reader.read(image);
  ms.push_back(
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
  return words;
}

// img_N.jpg sorted by N, so "--max-images 10" means the same ten images everywhere.
std::vector<fs::path> icdar_images(const fs::path& folder) {
  if (!fs::is_directory(folder)) throw StartupError("no ICDAR image folder " + folder.string());
  std::vector<std::pair<long, fs::path>> numbered;
  for (const auto& entry : fs::directory_iterator(folder)) {
    const std::string stem = entry.path().stem().string();
    if (entry.path().extension() != ".jpg" || stem.rfind("img_", 0) != 0) continue;
    try {
      numbered.emplace_back(std::stol(stem.substr(4)), entry.path());
    } catch (const std::exception&) {
      numbered.emplace_back(-1, entry.path());
    }
  }
  std::sort(numbered.begin(), numbered.end());
  std::vector<fs::path> files;
  for (auto& [n, path] : numbered) files.push_back(std::move(path));
  return files;
}

// Words read in a received image, in the photo's pixels.
void to_photo_pixels(std::vector<station::ReadWord>& words, double sx, double sy) {
  if (sx == 1 && sy == 1) return;
  for (auto& w : words) {
    const int x0 = int(std::floor(w.box.x * sx)), y0 = int(std::floor(w.box.y * sy));
    const int x1 = int(std::ceil(w.box.br().x * sx)), y1 = int(std::ceil(w.box.br().y * sy));
    w.box = cv::Rect(x0, y0, x1 - x0, y1 - y0);
    for (auto& corner : w.quad) corner = {float(corner.x * sx), float(corner.y * sy)};
  }
}

}  // namespace

EndToEndResult evaluate_end_to_end(station::TextReader& reader, const std::string& set_dir,
                                   std::size_t max_images, const EndToEndParams& params,
                                   const PhotoLink& link) {
  EndToEndResult result;
  std::vector<double> ms;
  for (const auto& path : icdar_images(fs::path(set_dir) / "images")) {
    if (max_images && result.images >= max_images) break;
    const cv::Mat image = cv::imread(path.string(), cv::IMREAD_COLOR);
    if (image.empty()) throw StartupError("unreadable image " + path.string());
    const auto truth = read_icdar_gt(
        (fs::path(set_dir) / "gt" / ("gt_" + path.stem().string() + ".txt")).string());
    if (link) {
      ReceivedPhoto received = link(image);
      result.bytes += received.bytes;
      auto words = timed_read(reader, received.image, ms);
      to_photo_pixels(words, received.sx, received.sy);
      result.counts += match_end_to_end(truth, words, params);
    } else {
      result.counts += match_end_to_end(truth, timed_read(reader, image, ms), params);
    }
    ++result.images;
  }
  result.median_ms = median(ms);
  return result;
}

WordAccuracyResult evaluate_cropped_words(station::TextReader& reader, const std::string& words_dir,
                                          std::size_t max_words) {
  WordAccuracyResult result;
  std::vector<double> ms;
  for (const auto& word : read_word_set(words_dir)) {
    if (max_words && result.words >= max_words) break;
    const cv::Mat image = cv::imread(word.image_path, cv::IMREAD_COLOR);
    if (image.empty()) throw StartupError("unreadable word image " + word.image_path);
    const std::string reading = cropped_word_reading(timed_read(reader, image, ms));
    result.correct += transcriptions_match(word.text, reading, false) ? 1 : 0;
    ++result.words;
  }
  result.median_ms = median(ms);
  return result;
}

double median_read_ms(station::TextReader& reader, const cv::Mat& image, int repetitions) {
  std::vector<double> ms;
  reader.read(image);
  for (int i = 0; i < std::max(1, repetitions); ++i) timed_read(reader, image, ms);
  return median(ms);
}

}  // namespace keyfleet::eval
