// A self-contained camera for demos and tests that need no scenario on disk: a drone panning
// along a procedurally drawn street front with shop signs, with bob, shake and sensor noise.
#include <opencv2/imgproc.hpp>

#include <array>
#include <cmath>

#include "keyfleet/agent/frame_source.hpp"

namespace keyfleet::agent {
namespace {

constexpr std::array<const char*, 16> kShopWords = {
    "HOTEL",   "PHARMACY", "BAKERY", "CAFE", "BOOKS",  "MARKET", "BANK", "PIZZA",
    "FLOWERS", "SHOES",    "MUSEUM", "TAXI", "GARAGE", "CINEMA", "TOYS", "DELI"};

cv::Scalar random_colour(cv::RNG& rng, int low, int high) {
  return cv::Scalar(rng.uniform(low, high), rng.uniform(low, high), rng.uniform(low, high));
}

// A street front several frames wide: sky, facades with windows and signs, pavement.
cv::Mat draw_street(int frame_width, int frame_height, cv::RNG& rng) {
  const int width = frame_width * 8;
  const int height = frame_height * 3 / 2;
  cv::Mat street(height, width, CV_8UC3, cv::Scalar(120, 130, 140));
  for (int y = 0; y < height / 4; ++y)
    street.row(y).setTo(cv::Scalar(235 - y / 3, 200 - y / 4, 150));
  street.rowRange(height * 7 / 8, height).setTo(cv::Scalar(90, 90, 95));
  for (int x = 0; x < width;) {
    const int facade_width = rng.uniform(frame_width / 3, frame_width);
    const int top = rng.uniform(height / 10, height / 4);
    const cv::Rect facade(x, top, std::min(facade_width, width - x), height * 7 / 8 - top);
    street(facade).setTo(random_colour(rng, 60, 220));
    for (int wy = facade.y + 20; wy + 40 < facade.y + facade.height * 2 / 3; wy += 60)
      for (int wx = facade.x + 15; wx + 30 < facade.x + facade.width - 10; wx += 50)
        cv::rectangle(street, cv::Rect(wx, wy, 30, 40), random_colour(rng, 20, 90), cv::FILLED);
    const char* word = kShopWords[static_cast<std::size_t>(rng.uniform(0, 16))];
    const double scale = rng.uniform(1.0, 2.2);
    int baseline = 0;
    const cv::Size text = cv::getTextSize(word, cv::FONT_HERSHEY_DUPLEX, scale, 3, &baseline);
    const cv::Point origin(facade.x + std::max(5, (facade.width - text.width) / 2),
                           facade.y + facade.height * 3 / 4);
    const cv::Rect board(origin.x - 10, origin.y - text.height - 12, text.width + 20,
                         text.height + baseline + 20);
    cv::rectangle(street, board & cv::Rect(0, 0, width, height), random_colour(rng, 200, 255),
                  cv::FILLED);
    cv::putText(street, word, origin, cv::FONT_HERSHEY_DUPLEX, scale, random_colour(rng, 0, 80), 3,
                cv::LINE_AA);
    x += facade_width + rng.uniform(0, 20);
  }
  return street;
}

class GeneratedSource final : public FrameSource {
 public:
  explicit GeneratedSource(const SourceConfig& config)
      : config_(config), rng_(config.seed * 7919 + 17) {
    street_ = draw_street(config.width, config.height, rng_);
    speed_px_ = rng_.uniform(3.0, 6.0);
  }

  std::optional<Frame> next() override {
    if (config_.max_frames && emitted_ >= config_.max_frames) return std::nullopt;
    const double t = static_cast<double>(emitted_);
    const double travel = street_.cols - config_.width * 1.3;
    const double phase = std::fmod(t * speed_px_, 2 * travel);
    const double x = phase < travel ? phase : 2 * travel - phase;  // fly back and forth
    const double bob = 0.08 * config_.height * std::sin(t / 25.0);
    const double shake = rng_.gaussian(1.5);
    const double zoom = 1.0 + 0.1 * std::sin(t / 60.0);
    cv::Mat warp = (cv::Mat_<double>(2, 3) << zoom, 0.002 * shake, -x, -0.002 * shake, zoom,
                    -(street_.rows - config_.height) / 2.0 - bob);
    Frame frame;
    frame.index = emitted_;
    frame.capture_time_ns = static_cast<std::int64_t>(t * 1e9 / config_.fps);
    cv::warpAffine(street_, frame.image, warp, cv::Size(config_.width, config_.height),
                   cv::INTER_LINEAR, cv::BORDER_REFLECT);
    cv::Mat noise(frame.image.size(), CV_16SC3);
    rng_.fill(noise, cv::RNG::NORMAL, 0, 4);
    frame.image.convertTo(frame.image, CV_16SC3);
    frame.image += noise;
    frame.image.convertTo(frame.image, CV_8UC3);
    ++emitted_;
    return frame;
  }

  double fps() const override { return config_.fps; }
  std::string describe() const override {
    return "generated street (seed " + std::to_string(config_.seed) + ", " +
           (config_.max_frames ? std::to_string(config_.max_frames) + " frames)"
                               : std::string("until stopped)"));
  }

 private:
  SourceConfig config_;
  cv::RNG rng_;
  cv::Mat street_;
  double speed_px_ = 4;
  std::uint64_t emitted_ = 0;
};

}  // namespace

std::unique_ptr<FrameSource> make_generated_source(const SourceConfig& config) {
  return std::make_unique<GeneratedSource>(config);
}

}  // namespace keyfleet::agent
