#include "keyfleet/station/keyframe_analyzer.hpp"

#include <opencv2/imgproc.hpp>

#include <chrono>

#include "keyfleet/common/clock.hpp"

namespace keyfleet::station {
namespace {

double elapsed_ms(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

std::vector<cv::Rect> hint_rects(const std::vector<TextRegion>& regions) {
  std::vector<cv::Rect> out;
  out.reserve(regions.size());
  for (const TextRegion& r : regions) out.emplace_back(r.x, r.y, r.w, r.h);
  return out;
}

}  // namespace

KeyframeAnalyzer::KeyframeAnalyzer(std::unique_ptr<TextReader> reader, PlaceRecognizer* places,
                                   std::unique_ptr<vision::PlaceDescriber> describer,
                                   const AnalysisConfig& config, Logger logger)
    : reader_(std::move(reader)),
      places_(places),
      describer_(std::move(describer)),
      config_(config),
      logger_(std::move(logger)) {
  orb_.features = config.places.orb_features;
}

AnalysisResult KeyframeAnalyzer::analyse(const AnalysisJob& job) {
  AnalysisResult result;
  result.key = job.key;
  result.capture_time_ns = job.capture_time_ns;
  // The pixels the station's check decoded, else (a keyframe restored or deferred) the JPEG's.
  DecodeResult decoded;
  if (job.image.empty()) {
    decoded = codec_.decode(job.jpeg);
    if (!decoded.ok()) {
      result.status = AnalysisStatus::kFailed;
      result.detail = "cannot decode the stored image: " + decoded.error;
      return result;
    }
  }
  const cv::Mat& image = job.image.empty() ? decoded.image : job.image;
  if (places_) {
    const auto start = std::chrono::steady_clock::now();
    cv::Mat grey;
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
    PlaceView view{extract_orb(grey, orb_), {}};
    if (describer_) view.descriptor = describer_->describe(image);
    const PlaceOutcome outcome =
        places_->recognise_then_add(job.key, job.capture_time_ns, view,
                                    not_a_recent_neighbour(job.key, job.capture_time_ns,
                                                           config_.places.same_robot_exclusion_s));
    result.place = outcome.best;
    result.candidates_checked = outcome.checked.size();
    result.features = std::move(view.features);
    result.descriptor = std::move(view.descriptor);
    result.places_ms = elapsed_ms(start);
  }
  if (reader_) {
    const auto start = std::chrono::steady_clock::now();
    const double cpu_start = thread_cpu_ms();
    result.words = reader_->read_with_hints(image, hint_rects(job.text_regions));
    result.text_ms = elapsed_ms(start);
    result.text_cpu_ms = thread_cpu_ms() - cpu_start;
  }
  return result;
}

}  // namespace keyfleet::station
