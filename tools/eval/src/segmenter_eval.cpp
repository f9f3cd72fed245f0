#include "keyfleet/eval/segmenter_eval.hpp"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <string_view>

#include "keyfleet/common/error.hpp"

namespace keyfleet::eval {
namespace {

namespace fs = std::filesystem;

struct Counts {
  double tp = 0, fp = 0, fn = 0;
  std::vector<double> found_share, true_share;  // of each image's pixels
  void add(const cv::Mat& predicted, const cv::Mat& truth) {
    tp += cv::countNonZero(predicted & truth);
    fp += cv::countNonZero(predicted & ~truth);
    fn += cv::countNonZero(~predicted & truth);
    const double area = double(truth.total());
    found_share.push_back(cv::countNonZero(predicted) / area);
    true_share.push_back(cv::countNonZero(truth) / area);
  }
  SegmentationScores scores() const {
    SegmentationScores s;
    s.images = found_share.size();
    s.recall = tp / std::max(1.0, tp + fn);
    s.precision = tp / std::max(1.0, tp + fp);
    s.iou = tp / std::max(1.0, tp + fp + fn);
    s.frame_rank_correlation = spearman_rho(found_share, true_share);
    return s;
  }
};

std::vector<double> mean_ranks(const std::vector<double>& values) {
  std::vector<std::size_t> order(values.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(),
            [&](std::size_t i, std::size_t j) { return values[i] < values[j]; });
  std::vector<double> ranks(values.size());
  for (std::size_t first = 0; first < order.size();) {
    std::size_t last = first;
    while (last + 1 < order.size() && values[order[last + 1]] == values[order[first]]) ++last;
    for (std::size_t k = first; k <= last; ++k) ranks[order[k]] = (first + last) / 2.0 + 1;
    first = last + 1;
  }
  return ranks;
}

std::vector<fs::path> images_in(const std::string& folder, std::size_t max_images,
                                const StemFilter& keep = {}) {
  if (!fs::is_directory(folder)) throw StartupError("no image folder " + folder);
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(folder))
    if (entry.path().extension() == ".jpg" && (!keep || keep(entry.path().stem().string())))
      files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  if (max_images && files.size() > max_images) files.resize(max_images);
  return files;
}

void score_one(vision::TextSegmenter& segmenter, const cv::Mat& image, const cv::Mat& truth_full,
               Counts& counts) {
  const cv::Mat predicted = segmenter.segment({image}).at(0);
  cv::Mat truth;
  cv::resize(truth_full, truth, predicted.size(), 0, 0, cv::INTER_NEAREST);
  counts.add(predicted > 0, truth > 0);
}

}  // namespace

double spearman_rho(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size()) throw std::invalid_argument("spearman_rho: samples of unequal size");
  const std::size_t n = a.size();
  if (n < 3) return std::numeric_limits<double>::quiet_NaN();
  const auto ra = mean_ranks(a), rb = mean_ranks(b);
  const double mean = (n + 1) / 2.0;  // of the ranks 1..n, ties or not
  double cov = 0, var_a = 0, var_b = 0;
  for (std::size_t i = 0; i < n; ++i) {
    cov += (ra[i] - mean) * (rb[i] - mean);
    var_a += (ra[i] - mean) * (ra[i] - mean);
    var_b += (rb[i] - mean) * (rb[i] - mean);
  }
  if (var_a == 0 || var_b == 0) return std::numeric_limits<double>::quiet_NaN();
  return cov / std::sqrt(var_a * var_b);
}

SegmentationScores evaluate_on_pairs(vision::TextSegmenter& segmenter, const std::string& folder,
                                     std::size_t max_images) {
  Counts counts;
  for (const auto& path : images_in((fs::path(folder) / "images").string(), max_images)) {
    const fs::path mask = fs::path(folder) / "masks" / (path.stem().string() + ".png");
    const cv::Mat image = cv::imread(path.string(), cv::IMREAD_COLOR);
    const cv::Mat truth = cv::imread(mask.string(), cv::IMREAD_GRAYSCALE);
    if (image.empty() || truth.empty()) throw StartupError("unreadable pair " + path.string());
    score_one(segmenter, image, truth, counts);
  }
  return counts.scores();
}

bool icdar_validation_id(const std::string& stem) {
  constexpr std::string_view prefix = "img_";
  if (stem.size() <= prefix.size() || stem.compare(0, prefix.size(), prefix) != 0) return false;
  const std::string digits = stem.substr(prefix.size());
  if (!std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return false;
  return digits.back() == '0';
}

SegmentationScores evaluate_on_icdar(vision::TextSegmenter& segmenter, const std::string& images,
                                     const std::string& ground_truth, std::size_t max_images,
                                     const StemFilter& keep) {
  Counts counts;
  for (const auto& path : images_in(images, max_images, keep)) {
    const cv::Mat image = cv::imread(path.string(), cv::IMREAD_COLOR);
    if (image.empty()) throw StartupError("unreadable image " + path.string());
    cv::Mat truth = cv::Mat::zeros(image.size(), CV_8UC1);
    std::ifstream gt(fs::path(ground_truth) / ("gt_" + path.stem().string() + ".txt"));
    std::string line;
    while (std::getline(gt, line)) {
      if (line.size() >= 3 && static_cast<unsigned char>(line[0]) == 0xEF) line = line.substr(3);
      std::replace(line.begin(), line.end(), ',', ' ');
      std::istringstream fields(line);
      std::vector<cv::Point> quad(4);
      bool ok = true;
      for (auto& p : quad) ok = ok && static_cast<bool>(fields >> p.x >> p.y);
      if (ok) cv::fillPoly(truth, std::vector<std::vector<cv::Point>>{quad}, 255);
    }
    score_one(segmenter, image, truth, counts);
  }
  return counts.scores();
}

double median_forward_ms(vision::TextSegmenter& segmenter, int repetitions) {
  return median_forward_ms(std::vector<vision::TextSegmenter*>{&segmenter}, repetitions).at(0);
}

std::vector<double> median_forward_ms(const std::vector<vision::TextSegmenter*>& segmenters,
                                      int repetitions) {
  std::vector<cv::Mat> frames;
  for (vision::TextSegmenter* s : segmenters) {
    frames.emplace_back(s->info().input_size, CV_8UC3, cv::Scalar(90, 120, 150));
    s->segment({frames.back()});  // warm-up
  }
  std::vector<std::vector<double>> ms(segmenters.size());
  for (int i = 0; i < repetitions; ++i)
    for (std::size_t k = 0; k < segmenters.size(); ++k) {
      const auto start = std::chrono::steady_clock::now();
      segmenters[k]->segment({frames[k]});
      ms[k].push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
              .count());
    }
  std::vector<double> medians;
  for (auto& m : ms) {
    std::nth_element(m.begin(), m.begin() + long(m.size() / 2), m.end());
    medians.push_back(m.empty() ? 0.0 : m[m.size() / 2]);
  }
  return medians;
}

}  // namespace keyfleet::eval
