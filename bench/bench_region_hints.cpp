// What the robot's text regions save and lose at the station: the demo's selection (the `full`
// strategy, density 4, MiniNet on the agent) on a generated scenario, each selected frame sent
// as JPEG 85 with its regions, then read by ppocr with region_hints off, only and first.
// Per mode: distinct signs read of those fully visible in the keyframes (ground truth), words
// reported, junk (words that are no word of the scene), and the text stage's ms per keyframe.
// Prints figures; never pass/fail.
//   build/bin/bench_region_hints SCENARIO_DIR [DETECTOR_SIZE=1280x736] [MODES=off,only,first]
#include <opencv2/core/utility.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <map>
#include <set>
#include <sstream>

#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/common/image_codec.hpp"
#include "keyfleet/common/process_tuning.hpp"
#include "keyfleet/common/scenario_truth.hpp"
#include "keyfleet/eval/metrics.hpp"
#include "keyfleet/eval/selection_eval.hpp"
#include "keyfleet/station/text/text_reader.hpp"
#include "keyfleet/station/text/text_reading_config.hpp"
#include "keyfleet/vision/model_files.hpp"

namespace {

using namespace keyfleet;

struct Sent {
  std::string drone;
  std::uint64_t frame = 0;
  cv::Mat image;  // as the station decodes it
  std::vector<cv::Rect> hints;
  const scenario::FrameTruth* truth = nullptr;
};

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + long(v.size() / 2), v.end());
  return v[v.size() / 2];
}

std::vector<std::string> split(const std::string& text, char by) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string part; std::getline(in, part, by);)
    if (!part.empty()) out.push_back(part);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  keyfleet::limit_openmp_to_one_thread(argv);
  if (argc < 2) {
    std::cerr << "usage: " << argv[0] << " SCENARIO_DIR [DETECTOR_SIZE] [MODES]\n";
    return 2;
  }
  const std::string dir = argv[1];
  const std::string detector = argc > 2 ? argv[2] : "1280x736";
  const auto modes = split(argc > 3 ? argv[3] : "off,only,first", ',');
  cv::setNumThreads(1);

  const scenario::Scenario scene = scenario::read_scenario(dir);
  SelectorConfig selector;  // the demo's: full strategy, orbslam trigger, density 4
  selector.density = 4;
  vision::DnnTextSegmenter segmenter(
      vision::locate_model(selector.semantic.model, "segmenter model"), 1);
  const JpegCodec codec(85);

  std::vector<eval::DroneFrames> drones;
  drones.reserve(scene.drones.size());  // `Sent::truth` points into them
  std::vector<Sent> sent;
  std::vector<double> region_counts;
  std::set<std::string> scene_words;
  for (const auto& info : scene.drones) {
    drones.push_back(eval::load_drone_frames(dir, info.robot_id));
    const auto& drone = drones.back();
    for (const auto& t : drone.truth)
      for (const auto& w : t.words)
        for (const auto& part : split(w.text, ' ')) scene_words.insert(eval::normalise_word(part));
    const auto all = eval::run_vslam_trigger(drone.frames, selector, info.fps);
    std::vector<std::uint64_t> kept;
    for (std::size_t i = 0; i < all.size(); i += 4) kept.push_back(all[i]);
    for (const auto& s : eval::select_on_keyframes(drone.frames, kept, selector, &segmenter)) {
      Sent k{info.robot_id,
             s.frame.index,
             codec.decode(codec.encode(s.frame.image)).image,
             {},
             &drone.truth.at(s.frame.index)};
      for (const auto& r : s.text_regions) k.hints.emplace_back(r.x, r.y, r.w, r.h);
      region_counts.push_back(double(s.text_regions.size()));
      sent.push_back(std::move(k));
    }
  }
  // Which fully visible words the hints cover (half the word's box inside a hinted region).
  std::set<int> visible_signs, covered_signs;
  std::size_t views = 0, covered_views = 0;
  for (const auto& k : sent) {
    const auto full = eval::fully_visible_signs(*k.truth);
    for (const auto& w : k.truth->words) {
      if (!full.count(w.sign_id)) continue;
      const cv::Rect box(cv::Point(int(w.box_x0), int(w.box_y0)),
                         cv::Point(int(w.box_x1), int(w.box_y1)));
      bool covered = false;
      for (const auto& h : k.hints) covered = covered || (box & h).area() * 2 >= box.area();
      ++views;
      covered_views += covered;
      visible_signs.insert(w.sign_id);
      if (covered) covered_signs.insert(w.sign_id);
    }
  }
  std::printf(
      "%zu keyframes from %zu drones; text regions a keyframe: median %.0f, max %.0f "
      "(%.0f bytes on the wire at the median); %zu distinct signs fully visible\n",
      sent.size(), drones.size(), median(region_counts),
      region_counts.empty() ? 0.0 : *std::max_element(region_counts.begin(), region_counts.end()),
      4 + 8 * median(region_counts), visible_signs.size());
  std::printf("hints cover %zu of %zu views of fully visible words, %zu of %zu distinct signs\n",
              covered_views, views, covered_signs.size(), visible_signs.size());

  std::printf(
      "\n| region_hints | signs read (of fully visible) | words | junk | ms/keyframe "
      "median | ms/keyframe mean |\n|---|---|---|---|---|---|\n");
  for (const auto& mode : modes) {
    TextReadingConfig config;
    config.engine = "ppocr";
    config.ppocr.detector_size = detector;
    config.ppocr.region_hints = mode;
    config.threads = 1;
    const auto reader = station::make_text_reader(config);
    std::set<int> read_signs;
    std::size_t words = 0, junk = 0;
    std::vector<double> ms;
    for (const auto& k : sent) {
      const auto start = std::chrono::steady_clock::now();
      const auto found = reader->read_with_hints(k.image, k.hints);
      ms.push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
              .count());
      std::vector<eval::WordRead> read;
      for (const auto& w : found) {
        read.push_back(
            {w.text, double(w.box.x), double(w.box.y), double(w.box.br().x), double(w.box.br().y)});
        ++words;
        junk += scene_words.count(eval::normalise_word(w.text)) == 0;
      }
      const auto full = eval::fully_visible_signs(*k.truth);
      for (int sign : eval::signs_read(read, *k.truth))
        if (full.count(sign)) read_signs.insert(sign);
    }
    double mean = 0;
    for (double m : ms) mean += m / double(std::max<std::size_t>(1, ms.size()));
    std::printf(
        "| %s | %zu of %zu (%.0f %%) | %zu | %zu (%.0f %%) | %.0f | %.0f |\n", mode.c_str(),
        read_signs.size(), visible_signs.size(),
        100.0 * double(read_signs.size()) / double(std::max<std::size_t>(1, visible_signs.size())),
        words, junk, 100.0 * double(junk) / double(std::max<std::size_t>(1, words)), median(ms),
        mean);
    std::string names;
    for (int sign : read_signs) names += " " + scene.signs.at(std::size_t(sign)).text;
    std::fprintf(stderr, "%s read:%s\n", mode.c_str(), names.c_str());
    std::fflush(stdout);
  }
  return 0;
}
