#pragma once
#include <opencv2/core.hpp>
#include <opencv2/freetype.hpp>

#include <random>
#include <string>
#include <vector>

#include "keyfleet/scenario/scenario_config.hpp"

namespace keyfleet::scenario {

struct PhotoWord {
  std::vector<cv::Point2f> quad;  // 4 corners in photo pixels
  std::string text;
  bool legible = true;
};

struct Photo {
  std::string path;
  cv::Mat image;
  std::vector<PhotoWord> words;  // from ICDAR-style ground truth beside it, when present
  bool annotated = false;        // ground truth was found for it
};

// Loads real photos (with their text ground truth where it exists) and fonts.
class TextureLibrary {
 public:
  explicit TextureLibrary(const TextureConfig& config);

  const std::vector<Photo>& photos() const { return photos_; }
  std::size_t font_count() const { return fonts_.size(); }
  cv::freetype::FreeType2& font(std::size_t index) const { return *fonts_.at(index); }
  const std::vector<std::string>& words() const { return words_; }

 private:
  std::vector<Photo> photos_;
  std::vector<cv::Ptr<cv::freetype::FreeType2>> fonts_;
  std::vector<std::string> words_;
};

// ICDAR 2015 ground truth: `x1,y1,...,x4,y4,transcription` a line; '###' = illegible.
std::vector<PhotoWord> read_icdar_ground_truth(const std::string& path);

}  // namespace keyfleet::scenario
