#pragma once
// The generated street as textured planes in the world (x along the street, y left, z up).
#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <random>
#include <string>
#include <vector>

#include "keyfleet/common/scenario_truth.hpp"
#include "keyfleet/scenario/scenario_config.hpp"

namespace keyfleet::scenario {

// A rectangle in the world carrying a texture. Texture pixel (s, t) (column, row) sits at
// origin + u * s * width_m / cols + v * (height_m - t * height_m / rows).
struct TexturedPlane {
  int id = 0;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // bottom-left corner
  Eigen::Vector3d u = Eigen::Vector3d::UnitX();      // along texture columns
  Eigen::Vector3d v = Eigen::Vector3d::UnitZ();      // texture up
  double width_m = 1;
  double height_m = 1;
  cv::Mat texture;         // BGR 8UC3
  cv::Mat alpha;           // 8UC1, empty = opaque; below 128 = see-through
  cv::Mat text_mask;       // 8UC1, empty = no text; 255 inside word boxes
  int lighting_group = 0;  // which per-day lighting factor applies

  Eigen::Vector3d at(double s, double t) const;    // world point of texture pixel (s, t)
  std::array<Eigen::Vector3d, 4> corners() const;  // tl, tr, br, bl
};

// A word placed in the world, on a sign or on a photo used as a facade.
struct PlacedWord {
  SignTruth truth;
  int plane_id = 0;  // the plane it is drawn on
};

struct StreetWorld {
  std::vector<TexturedPlane> planes;
  std::vector<PlacedWord> words;
  std::vector<int> group_side;  // per lighting group: +1 left facade, -1 right, 0 other
  double length_m = 0;
  double width_m = 0;
  double place_length_m = 0;

  int place_of(double x) const;
};

// Builds the street from its config and seed; logs nothing, throws StartupError when a
// configured font or photo folder yields nothing usable.
StreetWorld build_street(const ScenarioConfig& config, std::mt19937_64& rng);

// Colour factors of one 'day' (sun side, shadows, tint): per lighting group, and the sky's.
struct DayLighting {
  std::vector<cv::Scalar> groups;
  cv::Scalar sky{1, 1, 1};
};
DayLighting day_lighting(const StreetWorld& world, int day, std::uint64_t seed);

}  // namespace keyfleet::scenario
