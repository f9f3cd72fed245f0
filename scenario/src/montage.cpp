#include "keyfleet/scenario/montage.hpp"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <filesystem>

#include "keyfleet/common/scenario_truth.hpp"

namespace keyfleet::scenario {
namespace {

cv::Scalar colour_of(WordVisibility visibility) {
  switch (visibility) {
    case WordVisibility::kFull: return {0, 220, 0};
    case WordVisibility::kCut: return {0, 220, 255};
    case WordVisibility::kOccluded: return {0, 0, 255};
  }
  return {255, 255, 255};
}

}  // namespace

cv::Mat scenario_montage(const std::string& scenario_dir, const MontageOptions& options) {
  namespace fs = std::filesystem;
  const Scenario scenario = read_scenario(scenario_dir);
  std::vector<cv::Mat> rows;
  for (const auto& drone : scenario.drones) {
    if (!options.drones.empty() && std::find(options.drones.begin(), options.drones.end(),
                                             drone.robot_id) == options.drones.end())
      continue;
    const fs::path folder = fs::path(scenario_dir) / drone.folder;
    const auto truth = read_frame_truth(folder.string());
    std::vector<std::uint64_t> frames = options.frames;
    if (frames.empty())
      for (int k = 0; k < 5; ++k) frames.push_back(k * (drone.frames - 1) / 4);
    std::vector<cv::Mat> tiles;
    for (const auto index : frames) {
      if (index >= truth.size()) continue;
      const FrameTruth& frame = truth[index];
      cv::Mat image = cv::imread((folder / frame.image).string(), cv::IMREAD_COLOR);
      if (image.empty()) throw std::runtime_error("cannot read " + (folder / frame.image).string());
      if (options.draw_words)
        for (const auto& word : frame.words) {
          std::vector<cv::Point> quad;
          for (const auto& p : word.quad) quad.emplace_back(cvRound(p.x), cvRound(p.y));
          cv::polylines(image, quad, true, colour_of(word.visibility), 2, cv::LINE_AA);
        }
      const double scale = double(options.tile_width) / image.cols;
      cv::resize(image, image, {}, scale, scale, cv::INTER_AREA);
      const std::string label =
          drone.robot_id + " day " + std::to_string(drone.day) + " frame " + std::to_string(index);
      cv::putText(image, label, {6, 18}, cv::FONT_HERSHEY_SIMPLEX, 0.5, {0, 0, 0}, 3, cv::LINE_AA);
      cv::putText(image, label, {6, 18}, cv::FONT_HERSHEY_SIMPLEX, 0.5, {255, 255, 255}, 1,
                  cv::LINE_AA);
      tiles.push_back(image);
    }
    if (tiles.empty()) continue;
    cv::Mat row;
    cv::hconcat(tiles, row);
    rows.push_back(row);
  }
  if (rows.empty()) throw std::runtime_error(scenario_dir + ": no frames matched the montage");
  const int width =
      std::max_element(rows.begin(), rows.end(), [](const cv::Mat& a, const cv::Mat& b) {
        return a.cols < b.cols;
      })->cols;
  for (auto& row : rows)
    if (row.cols < width)
      cv::copyMakeBorder(row, row, 0, 0, 0, width - row.cols, cv::BORDER_CONSTANT, {0, 0, 0});
  cv::Mat montage;
  cv::vconcat(rows, montage);
  return montage;
}

}  // namespace keyfleet::scenario
