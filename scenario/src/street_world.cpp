#include "keyfleet/scenario/street_world.hpp"
#include "keyfleet/scenario/scenario_config.hpp"

#include <opencv2/imgproc.hpp>

#include <cmath>

#include "keyfleet/scenario/texture_library.hpp"

namespace keyfleet::scenario {
namespace {

constexpr double kFacadePxPerM = 64;
constexpr double kSignOffsetM = 0.08;  // signs stand this far in front of their facade

double uniform(std::mt19937_64& rng, double low, double high) {
  return std::uniform_real_distribution<double>(low, high)(rng);
}
int uniform_int(std::mt19937_64& rng, int low, int high) {
  return std::uniform_int_distribution<int>(low, high)(rng);
}
bool chance(std::mt19937_64& rng, double p) { return uniform(rng, 0, 1) < p; }
cv::Scalar colour(std::mt19937_64& rng, int low, int high) {
  return cv::Scalar(uniform_int(rng, low, high), uniform_int(rng, low, high),
                    uniform_int(rng, low, high));
}

// Adds fine grain so that walls are not flat (feature trackers need texture).
void add_grain(cv::Mat& image, std::mt19937_64& rng, double sigma) {
  cv::Mat noise(image.size(), CV_16SC3);
  cv::RNG cv_rng(rng());
  cv_rng.fill(noise, cv::RNG::NORMAL, 0, sigma);
  cv::Mat wide;
  image.convertTo(wide, CV_16SC3);
  wide += noise;
  wide.convertTo(image, CV_8UC3);
}

cv::Mat procedural_facade(int cols, int rows, std::mt19937_64& rng) {
  cv::Mat tex(rows, cols, CV_8UC3, colour(rng, 70, 210));
  add_grain(tex, rng, 6);
  const double px = kFacadePxPerM;
  // Upper floors: a grid of windows with frames and sills.
  const double floor_h = uniform(rng, 2.8, 3.4) * px;
  const double window_w = uniform(rng, 0.8, 1.4) * px;
  const double window_h = uniform(rng, 1.2, 1.7) * px;
  const double spacing = window_w + uniform(rng, 0.6, 1.4) * px;
  const cv::Scalar glass = colour(rng, 20, 90);
  const cv::Scalar frame = colour(rng, 150, 250);
  for (double top = rows - 2 * floor_h; top > 0.3 * px; top -= floor_h) {
    for (double x = 0.5 * px; x + window_w < cols - 0.3 * px; x += spacing) {
      const cv::Rect window(int(x), int(top + 0.4 * px), int(window_w), int(window_h));
      cv::rectangle(tex, window, glass, cv::FILLED);
      cv::rectangle(tex, window, frame, std::max(2, int(0.06 * px)));
      cv::line(tex, {window.x + window.width / 2, window.y},
               {window.x + window.width / 2, window.y + window.height}, frame, 2);
    }
  }
  // Ground floor: shop window and a door.
  const int ground_top = rows - int(floor_h);
  const cv::Rect shop(int(0.4 * px), ground_top + int(0.5 * px), int(cols * 0.55),
                      int(floor_h - 0.6 * px));
  cv::rectangle(tex, shop, colour(rng, 30, 110), cv::FILLED);
  cv::rectangle(tex, shop, colour(rng, 20, 60), std::max(3, int(0.08 * px)));
  const cv::Rect door(int(cols * 0.72), ground_top + int(0.6 * px), int(1.0 * px),
                      int(floor_h - 0.6 * px));
  cv::rectangle(tex, door & cv::Rect(0, 0, cols, rows), colour(rng, 30, 120), cv::FILLED);
  // Cornice line between floors.
  cv::line(tex, {0, ground_top}, {cols, ground_top}, colour(rng, 40, 200), int(0.15 * px));
  return tex;
}

// Crops a photo to the building's aspect ratio and scales it; carries its words through.
cv::Mat photo_facade(const Photo& photo, int cols, int rows, std::vector<PhotoWord>& words) {
  const double aspect = double(cols) / rows;
  cv::Rect crop(0, 0, photo.image.cols, photo.image.rows);
  if (double(photo.image.cols) / photo.image.rows > aspect) {
    crop.width = int(photo.image.rows * aspect);
    crop.x = (photo.image.cols - crop.width) / 2;
  } else {
    crop.height = int(photo.image.cols / aspect);
    crop.y = (photo.image.rows - crop.height) / 2;
  }
  cv::Mat tex;
  cv::resize(photo.image(crop), tex, cv::Size(cols, rows), 0, 0, cv::INTER_AREA);
  const double sx = double(cols) / crop.width, sy = double(rows) / crop.height;
  for (const auto& word : photo.words) {
    PhotoWord moved = word;
    bool inside = true;
    for (auto& p : moved.quad) {
      p = {float((p.x - crop.x) * sx), float((p.y - crop.y) * sy)};
      inside = inside && p.x >= 0 && p.y >= 0 && p.x < cols && p.y < rows;
    }
    if (inside) words.push_back(moved);
  }
  return tex;
}

struct SignImage {
  cv::Mat texture, mask;
  cv::Rect word_box;  // in texture pixels
};

SignImage paint_sign(const std::string& word, const TextureLibrary& library, std::mt19937_64& rng) {
  auto& font = library.font(std::size_t(uniform_int(rng, 0, int(library.font_count()) - 1)));
  const int text_height = uniform_int(rng, 56, 96);
  int baseline = 0;
  const cv::Size text = font.getTextSize(word, text_height, -1, &baseline);
  // Some installed fonts lack glyphs (or metrics) for a word: no sign rather than a crash.
  if (text.width <= 0 || text.height <= 0 || baseline < 0) return {};
  const int pad_x = uniform_int(rng, text_height / 4, text_height), pad_y = text_height / 3;
  const cv::Size size(text.width + 2 * pad_x, text.height + baseline + 2 * pad_y);
  // Contrast varies from strong to weak: real signs are not all legible.
  const cv::Scalar board = colour(rng, 0, 255);
  const double contrast = uniform(rng, 0.25, 1.0);
  cv::Scalar ink;
  for (int c = 0; c < 3; ++c) {
    const double opposite = board[c] > 127 ? 0 : 255;
    ink[c] = board[c] + contrast * (opposite - board[c]);
  }
  SignImage sign{cv::Mat(size, CV_8UC3, board), {}, {}};
  const cv::Point origin(pad_x, pad_y + text.height);
  font.putText(sign.texture, word, origin, text_height, ink, -1, cv::LINE_AA, true);
  cv::rectangle(sign.texture, cv::Rect({0, 0}, size), ink * 0.5 + board * 0.5, 3);
  sign.word_box = cv::Rect(pad_x, pad_y, text.width, text.height + baseline);
  // The word's box, not its glyphs: text regions, as ICDAR and COCO-Text annotate them.
  sign.mask = cv::Mat::zeros(size, CV_8UC1);
  sign.mask(sign.word_box).setTo(255);
  return sign;
}

cv::Mat ground_texture(double length_m, double width_m, std::mt19937_64& rng, int& cols) {
  const double px = 24;  // seen at a glancing angle: coarser is enough
  cols = int(length_m * px);
  const int rows = int(width_m * px);
  cv::Mat tex(rows, cols, CV_8UC3, cv::Scalar(80, 82, 86));
  add_grain(tex, rng, 12);
  const int kerb = int(2.5 * px);
  tex.rowRange(0, kerb).setTo(cv::Scalar(150, 150, 155));  // pavements
  tex.rowRange(rows - kerb, rows).setTo(cv::Scalar(150, 150, 155));
  for (int x = 0; x < cols; x += int(1.2 * px))  // paving slabs
    for (int r : {0, rows - kerb}) cv::line(tex, {x, r}, {x, r + kerb}, {110, 110, 115}, 2);
  for (int x = 0; x < cols; x += int(6 * px))  // centre line dashes
    cv::rectangle(tex, cv::Rect(x, rows / 2 - 3, int(3 * px), 6), {220, 220, 220}, cv::FILLED);
  add_grain(tex, rng, 5);
  return tex;
}

void add_tree(StreetWorld& world, double x, double y, const Eigen::Vector3d& u, int group,
              std::mt19937_64& rng) {
  const double w = uniform(rng, 2.5, 4.0), h = uniform(rng, 5.0, 7.5);
  const int cols = int(w * 48), rows = int(h * 48);
  cv::Mat tex(rows, cols, CV_8UC3, cv::Scalar(40, 90, 50));
  add_grain(tex, rng, 25);
  cv::Mat alpha = cv::Mat::zeros(rows, cols, CV_8UC1);
  const int trunk_w = std::max(4, cols / 12);
  cv::rectangle(alpha, cv::Rect(cols / 2 - trunk_w / 2, rows / 2, trunk_w, rows / 2), 255,
                cv::FILLED);
  tex(cv::Rect(cols / 2 - trunk_w / 2, rows / 2, trunk_w, rows / 2)).setTo(cv::Scalar(40, 60, 80));
  for (int blob = 0; blob < 40; ++blob) {  // leafy crown: overlapping discs
    const cv::Point centre(uniform_int(rng, cols / 6, cols * 5 / 6),
                           uniform_int(rng, rows / 12, rows * 11 / 20));
    cv::circle(alpha, centre, uniform_int(rng, cols / 10, cols / 5), 255, cv::FILLED);
  }
  TexturedPlane tree;
  tree.u = u;
  tree.v = Eigen::Vector3d::UnitZ();
  tree.origin = Eigen::Vector3d(x, y, 0) - u * (w / 2);
  tree.width_m = w, tree.height_m = h;
  tree.texture = tex, tree.alpha = alpha;
  tree.lighting_group = group;
  world.planes.push_back(tree);
}

void add_pole(StreetWorld& world, double x, double y, const Eigen::Vector3d& u, int group) {
  TexturedPlane pole;
  pole.u = u;
  pole.v = Eigen::Vector3d::UnitZ();
  pole.origin = Eigen::Vector3d(x, y, 0);
  pole.width_m = 0.22, pole.height_m = 6.0;
  pole.texture = cv::Mat(240, 9, CV_8UC3, cv::Scalar(50, 55, 60));
  pole.texture.rowRange(0, 12).setTo(cv::Scalar(200, 220, 230));  // the lamp
  pole.lighting_group = group;
  world.planes.push_back(pole);
}

}  // namespace

Eigen::Vector3d TexturedPlane::at(double s, double t) const {
  return origin + u * (s * width_m / texture.cols) + v * (height_m - t * height_m / texture.rows);
}

std::array<Eigen::Vector3d, 4> TexturedPlane::corners() const {
  return {origin + v * height_m, origin + u * width_m + v * height_m, origin + u * width_m, origin};
}

int StreetWorld::place_of(double x) const { return int(std::floor(x / place_length_m)); }

StreetWorld build_street(const ScenarioConfig& config, std::mt19937_64& rng) {
  const TextureLibrary library(config.textures);
  const StreetConfig& street = config.street;
  StreetWorld world;
  world.length_m = street.length_m;
  world.width_m = street.width_m;
  world.place_length_m = street.place_length_m;
  const double half = street.width_m / 2;

  auto new_group = [&](int side) {
    world.group_side.push_back(side);
    return int(world.group_side.size()) - 1;
  };

  for (const int side : {+1, -1}) {
    // Seen from the street, +x runs to the right on the left facade and to the left on the
    // right one, so textures are laid out along u = side * x.
    const Eigen::Vector3d u = Eigen::Vector3d::UnitX() * side;
    for (double x = 0; x < street.length_m;) {
      const double w =
          std::min(uniform(rng, street.building_min_width_m, street.building_max_width_m),
                   street.length_m - x);
      const double h = street.facade_height_m * uniform(rng, 0.75, 1.15);
      const int group = new_group(side);
      TexturedPlane facade;
      facade.u = u;
      facade.v = Eigen::Vector3d::UnitZ();
      facade.origin = Eigen::Vector3d(side > 0 ? x : x + w, side * half, 0);
      facade.width_m = w, facade.height_m = h;
      facade.lighting_group = group;
      const int cols = int(w * kFacadePxPerM), rows = int(h * kFacadePxPerM);
      std::vector<PhotoWord> photo_words;
      const auto& photos = library.photos();
      if (!photos.empty() && chance(rng, config.textures.photo_probability)) {
        const Photo& photo = photos[std::size_t(uniform_int(rng, 0, int(photos.size()) - 1))];
        facade.texture = photo_facade(photo, cols, rows, photo_words);
      } else {
        facade.texture = procedural_facade(cols, rows, rng);
      }
      facade.id = int(world.planes.size());
      if (!photo_words.empty()) {
        facade.text_mask = cv::Mat::zeros(rows, cols, CV_8UC1);
        for (const auto& pw : photo_words) {
          std::vector<cv::Point> poly;
          for (const auto& p : pw.quad) poly.emplace_back(cvRound(p.x), cvRound(p.y));
          cv::fillConvexPoly(facade.text_mask, poly, 255);
          PlacedWord placed;
          placed.plane_id = facade.id;
          placed.truth.text = pw.text;
          placed.truth.legible = pw.legible;
          placed.truth.side = side > 0 ? "left" : "right";
          double cx = 0;
          for (std::size_t i = 0; i < 4; ++i) {
            const Eigen::Vector3d p = facade.at(pw.quad[i].x, pw.quad[i].y);
            placed.truth.word_corners[i] = {p.x(), p.y(), p.z()};
            cx += p.x() / 4;
          }
          placed.truth.place_id = world.place_of(cx);
          world.words.push_back(placed);
        }
      }
      world.planes.push_back(facade);

      // Shop signs above the ground floor, standing slightly proud of the facade.
      const int signs = chance(rng, street.sign_probability)
                            ? 1 + int(chance(rng, street.extra_sign_probability))
                            : 0;
      for (int k = 0; k < signs; ++k) {
        const std::string& word =
            library.words()[std::size_t(uniform_int(rng, 0, int(library.words().size()) - 1))];
        SignImage sign = paint_sign(word, library, rng);
        if (sign.texture.empty()) continue;
        const double sign_h = (k == 0 ? uniform(rng, 0.6, 1.2) : uniform(rng, 0.35, 0.6));
        const double sign_w = sign_h * sign.texture.cols / sign.texture.rows;
        if (sign_w > w * 0.95) continue;
        TexturedPlane plane;
        plane.u = u;
        plane.v = Eigen::Vector3d::UnitZ();
        const double along = uniform(rng, 0.05 * w, w - sign_w - 0.05 * w);
        const double z = k == 0 ? uniform(rng, 3.0, 4.2) : uniform(rng, 1.2, 2.4);
        plane.origin = facade.origin + u * along + Eigen::Vector3d(0, -side * kSignOffsetM, z);
        plane.width_m = sign_w, plane.height_m = sign_h;
        plane.texture = sign.texture, plane.text_mask = sign.mask;
        plane.lighting_group = group;
        plane.id = int(world.planes.size());
        PlacedWord placed;
        placed.plane_id = plane.id;
        placed.truth.text = word;
        placed.truth.side = side > 0 ? "left" : "right";
        const cv::Rect& b = sign.word_box;
        const cv::Point2d box[4] = {{double(b.x), double(b.y)},
                                    {double(b.x + b.width), double(b.y)},
                                    {double(b.x + b.width), double(b.y + b.height)},
                                    {double(b.x), double(b.y + b.height)}};
        for (std::size_t i = 0; i < 4; ++i) {
          const Eigen::Vector3d p = plane.at(box[i].x, box[i].y);
          placed.truth.word_corners[i] = {p.x(), p.y(), p.z()};
        }
        placed.truth.place_id =
            world.place_of((placed.truth.word_corners[0].x + placed.truth.word_corners[1].x) / 2);
        world.planes.push_back(plane);
        world.words.push_back(placed);
      }
      x += w;
    }
  }

  // Street furniture along both kerbs, between the drones and the facades.
  const int furniture_group = new_group(0);
  for (const int side : {+1, -1}) {
    const Eigen::Vector3d u = Eigen::Vector3d::UnitX() * side;
    if (street.pole_spacing_m > 0)
      for (double x = uniform(rng, 2, street.pole_spacing_m); x < street.length_m;
           x += street.pole_spacing_m * uniform(rng, 0.8, 1.2))
        add_pole(world, x, side * (half - 2.0), u, furniture_group);
    if (street.tree_spacing_m > 0)
      for (double x = uniform(rng, 4, street.tree_spacing_m); x < street.length_m;
           x += street.tree_spacing_m * uniform(rng, 0.7, 1.3))
        add_tree(world, x, side * (half - 2.6), u, furniture_group, rng);
  }

  TexturedPlane ground;
  int ground_cols = 0;
  ground.texture = ground_texture(street.length_m, street.width_m, rng, ground_cols);
  ground.origin = Eigen::Vector3d(0, -half, 0);
  ground.u = Eigen::Vector3d::UnitX();
  ground.v = Eigen::Vector3d::UnitY();
  ground.width_m = street.length_m, ground.height_m = street.width_m;
  ground.lighting_group = new_group(0);
  world.planes.push_back(ground);

  for (std::size_t i = 0; i < world.planes.size(); ++i) world.planes[i].id = int(i);
  for (std::size_t i = 0; i < world.words.size(); ++i) world.words[i].truth.id = int(i);
  return world;
}

DayLighting day_lighting(const StreetWorld& world, int day, std::uint64_t seed) {
  std::mt19937_64 rng(seed * 1000003ULL + std::uint64_t(day) * 7919ULL + 11);
  const double brightness = day == 0 ? 1.0 : uniform(rng, 0.6, 1.35);
  const cv::Scalar tint(uniform(rng, 0.85, 1.15), uniform(rng, 0.92, 1.08),
                        uniform(rng, 0.85, 1.15));
  const int sunny_side = chance(rng, 0.5) ? +1 : -1;
  DayLighting lighting;
  lighting.sky = tint * brightness;
  for (const int side : world.group_side) {
    double f = brightness;
    if (side != 0) f *= (side == sunny_side ? uniform(rng, 1.0, 1.25) : uniform(rng, 0.6, 0.9));
    lighting.groups.push_back(tint * f);
  }
  return lighting;
}

}  // namespace keyfleet::scenario
