#include "keyfleet/eval/place_eval.hpp"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <sstream>

#include "keyfleet/common/error.hpp"
#include "keyfleet/common/scenario_truth.hpp"
#include "keyfleet/station/analysis_setup.hpp"
#include "keyfleet/station/place_recognizer.hpp"
#include "keyfleet/station/places/orb_extractor.hpp"
#include "keyfleet/vision/model_files.hpp"
#include "keyfleet/vision/place_describer.hpp"

namespace keyfleet::eval {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

cv::Mat read_image(const fs::path& path) {
  cv::Mat image = cv::imread(path.string(), cv::IMREAD_COLOR);
  if (image.empty()) throw StartupError("places eval: cannot read " + path.string());
  return image;
}

// Describes views (ORB + descriptor) and keeps their costs.
class Describer {
 public:
  Describer(const PlaceEvalSettings& settings, PlaceEvalCost& cost, int orb_min_width)
      : cost_(cost) {
    orb_.features = settings.places.orb_features;
    orb_.min_width = orb_min_width;
    // Every view is described, whichever modes are compared.
    describer_ = std::make_unique<vision::DnnPlaceDescriber>(
        vision::locate_model(settings.places.descriptor, "place recognition: descriptor model"));
  }
  station::PlaceView view(const cv::Mat& bgr) {
    station::PlaceView v;
    auto start = Clock::now();
    v.features = station::extract_orb(bgr, orb_);
    cost_.orb_ms.push_back(ms_since(start));
    start = Clock::now();
    v.descriptor = describer_->describe(bgr);
    cost_.describe_ms.push_back(ms_since(start));
    return v;
  }

 private:
  PlaceEvalCost& cost_;
  station::OrbParams orb_;
  std::unique_ptr<vision::PlaceDescriber> describer_;
};

struct Condition {
  std::string name;
  std::function<cv::Mat(const cv::Mat&, std::mt19937&)> apply;
};

std::vector<Condition> conditions(const PlaceEvalSettings& s) {
  return {
      {"as captured", [](const cv::Mat& m, std::mt19937&) { return m; }},
      {"motion blur",
       [s](const cv::Mat& m, std::mt19937& rng) {
         const double length = s.blur_px * m.cols / 640.0;
         return motion_blurred(m, length, std::uniform_real_distribution<>(0, 180)(rng));
       }},
      {"dark", [s](const cv::Mat& m, std::mt19937&) { return exposure_scaled(m, s.dark_gain); }},
  };
}

// One recogniser per mode over the same stored views.
struct Recognisers {
  std::vector<std::string> names;
  std::vector<std::unique_ptr<station::PlaceRecognizer>> all;

  explicit Recognisers(const PlaceEvalSettings& settings) {
    for (PlaceRetrieval mode : settings.modes) {
      PlaceRecognitionConfig config = settings.places;
      config.enabled = true;
      config.retrieval = mode;
      names.push_back(to_string(mode));
      all.push_back(station::make_configured_place_recognizer(config));
    }
  }
  void add(const station::KeyframeKey& key, const station::PlaceView& view) {
    for (auto& r : all) r->add(key, 0, view);
  }
};

// Scores every query under every condition and mode; `right` says whether a stored key answers
// the query, `answerable` whether any does.
struct QueryScorer {
  std::vector<RetrievalScore> scores;  // [condition][mode]
  std::vector<std::vector<double>> ms;
  std::size_t modes = 0;

  QueryScorer(const std::string& dataset, const std::vector<Condition>& conds,
              const Recognisers& recognisers)
      : modes(recognisers.names.size()) {
    for (const auto& c : conds)
      for (const auto& name : recognisers.names) {
        RetrievalScore s;
        s.dataset = dataset;
        s.condition = c.name;
        s.mode = name;
        scores.push_back(s);
      }
    ms.resize(scores.size());
  }

  void score(std::size_t condition, const station::PlaceView& view, const Recognisers& r,
             const std::function<bool(const station::KeyframeKey&)>& right) {
    for (std::size_t m = 0; m < modes; ++m) {
      RetrievalScore& s = scores[condition * modes + m];
      ++s.queries;
      const auto keys = r.all[m]->retrieve(view, 5, {});
      for (std::size_t i = 0; i < keys.size(); ++i) {
        if (!right(keys[i])) continue;
        if (i == 0) ++s.top1;
        ++s.top5;
        break;
      }
      const auto start = Clock::now();
      const station::PlaceOutcome outcome = r.all[m]->recognise(view, {});
      ms[condition * modes + m].push_back(ms_since(start));
      if (outcome.best) {
        ++s.accepted;
        if (right(outcome.best->other)) ++s.accepted_right;
      }
    }
  }

  std::vector<RetrievalScore> finish() {
    for (std::size_t i = 0; i < scores.size(); ++i) scores[i].recognise_ms = median(ms[i]);
    return scores;
  }
};

}  // namespace

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(v.size() / 2), v.end());
  return v[v.size() / 2];
}

cv::Mat motion_blurred(const cv::Mat& bgr, double length_px, double angle_deg) {
  if (length_px < 1) return bgr.clone();
  const int size = static_cast<int>(std::ceil(length_px)) | 1;
  cv::Mat kernel = cv::Mat::zeros(size, size, CV_32F);
  const double c = size / 2, a = angle_deg * CV_PI / 180.0;
  const cv::Point2d d(std::cos(a) * length_px / 2, std::sin(a) * length_px / 2);
  cv::line(kernel, cv::Point(cvRound(c - d.x), cvRound(c - d.y)),
           cv::Point(cvRound(c + d.x), cvRound(c + d.y)), cv::Scalar(1), 1, cv::LINE_AA);
  kernel /= cv::sum(kernel)[0];
  cv::Mat out;
  cv::filter2D(bgr, out, -1, kernel, cv::Point(-1, -1), 0, cv::BORDER_REFLECT);
  return out;
}

cv::Mat exposure_scaled(const cv::Mat& bgr, double gain) {
  cv::Mat out;
  bgr.convertTo(out, -1, gain);  // saturating
  return out;
}

std::vector<RetrievalScore> evaluate_places_on_scenario(const std::string& scenario_dir,
                                                        const std::string& dataset,
                                                        const PlaceEvalSettings& settings,
                                                        PlaceEvalCost& cost, Logger logger) {
  const scenario::Scenario sc = scenario::read_scenario(scenario_dir);
  Recognisers recognisers(settings);
  Describer describer(settings, cost, 0);
  const auto conds = conditions(settings);
  std::map<station::KeyframeKey, double> stored_position;
  const int first_day = sc.drones.empty() ? 0 : sc.drones.front().day;
  for (const auto& drone : sc.drones) {
    if (drone.day != first_day) continue;
    const fs::path folder = fs::path(scenario_dir) / drone.folder;
    const auto truth = scenario::read_frame_truth(folder.string());
    for (std::size_t f = 0; f < truth.size(); f += std::size_t(settings.database_every)) {
      const station::KeyframeKey key{drone.robot_id, truth[f].index};
      recognisers.add(key, describer.view(read_image(folder / truth[f].image)));
      stored_position[key] = truth[f].street_position_m;
    }
  }
  logger->info("{}: {} stored keyframes of day {}", dataset, stored_position.size(), first_day);
  QueryScorer scorer(dataset, conds, recognisers);
  std::mt19937 rng(7);
  for (const auto& drone : sc.drones) {
    if (drone.day == first_day) continue;
    const fs::path folder = fs::path(scenario_dir) / drone.folder;
    const auto truth = scenario::read_frame_truth(folder.string());
    for (std::size_t f = 0; f < truth.size(); f += std::size_t(settings.query_every)) {
      const double at = truth[f].street_position_m;
      const auto right = [&](const station::KeyframeKey& k) {
        return std::abs(stored_position.at(k) - at) <= settings.tolerance_m;
      };
      if (std::none_of(stored_position.begin(), stored_position.end(),
                       [&](const auto& kv) { return right(kv.first); }))
        continue;
      const cv::Mat image = read_image(folder / truth[f].image);
      for (std::size_t c = 0; c < conds.size(); ++c)
        scorer.score(c, describer.view(conds[c].apply(image, rng)), recognisers, right);
    }
  }
  return scorer.finish();
}

std::vector<RetrievalScore> evaluate_places_on_corridor(const std::string& corridor_dir,
                                                        const PlaceEvalSettings& settings,
                                                        PlaceEvalCost& cost, Logger logger) {
  const fs::path root(corridor_dir);
  std::ifstream gt(root / "ground_truth.csv");
  if (!gt) throw StartupError("places eval: no " + (root / "ground_truth.csv").string());
  std::map<std::uint64_t, std::set<std::uint64_t>> matches;
  std::string line;
  std::getline(gt, line);  // header
  while (std::getline(gt, line)) {
    const auto comma = line.find(',');
    if (comma == std::string::npos) continue;
    std::istringstream refs(line.substr(comma + 1));
    std::uint64_t r;
    auto& set = matches[std::stoull(line.substr(0, comma))];
    while (refs >> r) set.insert(r);
  }
  const auto frame = [&](const char* part, std::uint64_t i) {
    char name[16];
    std::snprintf(name, sizeof name, "%07llu.jpg", static_cast<unsigned long long>(i));
    return root / part / name;
  };
  Recognisers recognisers(settings);
  Describer describer(settings, cost, 320);
  std::uint64_t refs = 0;
  for (; fs::exists(frame("ref", refs)); ++refs)
    recognisers.add({"ref", refs}, describer.view(read_image(frame("ref", refs))));
  logger->info("corridor: {} reference frames, {} queries with ground truth", refs, matches.size());
  const auto conds = conditions(settings);
  QueryScorer scorer("corridor", conds, recognisers);
  std::mt19937 rng(7);
  for (const auto& [query, answers] : matches) {
    if (answers.empty() || !fs::exists(frame("query", query))) continue;
    const cv::Mat image = read_image(frame("query", query));
    const auto right = [&answers = answers](const station::KeyframeKey& k) {
      return answers.count(k.sequence) > 0;
    };
    for (std::size_t c = 0; c < conds.size(); ++c)
      scorer.score(c, describer.view(conds[c].apply(image, rng)), recognisers, right);
  }
  return scorer.finish();
}

double descriptor_query_ms(std::size_t entries, int dimensions, int repeats) {
  station::DescriptorIndex index(dimensions);
  std::mt19937 rng(1);
  std::normal_distribution<float> normal;
  const auto random_unit = [&] {
    std::vector<float> v(static_cast<std::size_t>(dimensions));
    for (float& x : v) x = normal(rng);
    vision::l2_normalise(v);
    return v;
  };
  for (std::size_t i = 0; i < entries; ++i) index.add(random_unit());
  std::vector<double> ms;
  for (int r = 0; r < repeats; ++r) {
    const auto q = random_unit();
    const auto start = Clock::now();
    const auto found = index.query(q, 4);
    ms.push_back(ms_since(start));
    if (found.empty()) return 0;
  }
  return median(ms);
}

}  // namespace keyfleet::eval
