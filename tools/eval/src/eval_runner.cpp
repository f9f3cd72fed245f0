#include "keyfleet/eval/eval_runner.hpp"
#include "keyfleet/eval/eval_config.hpp"

#include <opencv2/core/utility.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <set>
#include <thread>

#include "keyfleet/agent/level_encoding.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/common/image_codec.hpp"
#include "keyfleet/eval/selection_eval.hpp"
#include "keyfleet/scenario/scenario_generator.hpp"
#include "keyfleet/station/analysis_setup.hpp"
#include "keyfleet/station/geometry/match_verifier.hpp"
#include "keyfleet/station/place_recognizer.hpp"
#include "keyfleet/station/places/orb_extractor.hpp"
#include "keyfleet/station/places/orb_vocabulary.hpp"
#include "keyfleet/station/text/text_reader.hpp"
#include "keyfleet/vision/model_files.hpp"
#include "keyfleet/vision/place_describer.hpp"

namespace keyfleet::eval {
namespace {

namespace fs = std::filesystem;
using SteadyClock = std::chrono::steady_clock;

double seconds_since(SteadyClock::time_point start) {
  return std::chrono::duration<double>(SteadyClock::now() - start).count();
}

// A selected frame as one encoding sends it: the frame, and the text regions it was selected
// with when the encoding depends on them (an index into DroneRun::regions; 0 otherwise).
using UnitKey = std::pair<std::uint64_t, std::size_t>;

// An encoding as the runner applies it.
struct EncodingPlan {
  std::string name;  // "" for the raw frames
  bool raw = true;   // read the camera frame itself; bytes at codec.jpeg_quality
  agent::SendLevel level;
  bool text_aware = false;
  // Only a text-aware, scaled encoding of a frame with text regions depends on the regions.
  UnitKey key(std::uint64_t frame, std::size_t regions) const {
    return {frame, !raw && text_aware && level.scale < 1.0 ? regions : 0};
  }
};

// What one drone leaves behind once its decoded frames are released.
struct DroneRun {
  scenario::DroneInfo info;
  std::vector<double> positions;  // street position of every frame
  // [strategy][density] -> the selected frames
  std::vector<std::vector<std::vector<std::uint64_t>>> selected;
  // [strategy][density][i] -> the text regions selected[s][k][i] came with, in `regions`
  std::vector<std::vector<std::vector<std::size_t>>> region_ids;
  std::vector<std::vector<TextRegion>> regions;       // [0]: none
  std::map<std::uint64_t, station::PlaceView> views;  // raw: queries and selected frames
  // [encoding] -> the database views of its decoded frames (empty for the raw frames: `views`)
  std::vector<std::map<UnitKey, station::PlaceView>> encoded_views;
  std::vector<std::uint64_t> queries;

  const station::PlaceView& database_view(const EncodingPlan& plan, std::size_t e,
                                          std::uint64_t frame, std::size_t region_id) const {
    return plan.raw ? views.at(frame) : encoded_views[e].at(plan.key(frame, region_id));
  }
};

// One image to read, with its frame's ground truth; the words' boxes are mapped back into the
// frame's pixels by (sx, sy) (a scaled frame is read at its own size).
struct ReadJob {
  const cv::Mat* image = nullptr;
  const scenario::FrameTruth* truth = nullptr;
  double sx = 1, sy = 1;
  bool hinted = false;  // read as the station reads a keyframe with text regions
  std::vector<cv::Rect> hints;
};

// Signs read in each image, with `threads` readers (one Tesseract each) working at once.
std::vector<std::set<int>> read_images(const std::vector<ReadJob>& jobs,
                                       const TextReadingConfig& text, int threads, EvalCost& cost,
                                       std::string& reader_name) {
  const std::size_t workers =
      std::max<std::size_t>(1, std::min<std::size_t>(std::size_t(threads), jobs.size()));
  std::vector<std::unique_ptr<station::TextReader>> readers;
  for (std::size_t i = 0; i < workers; ++i) readers.push_back(station::make_text_reader(text));
  reader_name = readers.front()->name();

  std::vector<std::set<int>> found(jobs.size());
  std::vector<std::vector<double>> ms(workers);
  std::atomic<std::size_t> next{0};
  const auto start = SteadyClock::now();
  auto work = [&](std::size_t w) {
    for (std::size_t i = next++; i < jobs.size(); i = next++) {
      const ReadJob& job = jobs[i];
      const auto t0 = SteadyClock::now();
      std::vector<WordRead> read;
      const auto words = job.hinted ? readers[w]->read_with_hints(*job.image, job.hints)
                                    : readers[w]->read(*job.image);
      for (const auto& word : words)
        read.push_back({word.text, job.sx * word.box.x, job.sy * word.box.y,
                        job.sx * (word.box.x + word.box.width),
                        job.sy * (word.box.y + word.box.height)});
      found[i] = signs_read(read, *job.truth);
      ms[w].push_back(seconds_since(t0) * 1e3);
    }
  };
  std::vector<std::thread> pool;
  for (std::size_t w = 1; w < workers; ++w) pool.emplace_back(work, w);
  work(0);
  for (auto& t : pool) t.join();
  cost.ocr_wall_s += seconds_since(start);
  cost.ocr_frames += jobs.size();
  std::vector<double> all;
  for (const auto& m : ms) all.insert(all.end(), m.begin(), m.end());
  if (!all.empty()) {
    std::nth_element(all.begin(), all.begin() + long(all.size() / 2), all.end());
    cost.ocr_median_ms = all[all.size() / 2];  // the last read's; all alike
  }
  return found;
}

// The raw frames' signs read, by frame.
std::map<std::uint64_t, std::set<int>> read_frames(const std::vector<std::uint64_t>& frames,
                                                   const DroneFrames& drone,
                                                   const TextReadingConfig& text, int threads,
                                                   EvalCost& cost, std::string& reader_name) {
  std::vector<ReadJob> jobs;
  for (auto f : frames) {
    ReadJob job;
    job.image = &drone.frames[f].image;
    job.truth = &drone.truth[f];
    jobs.push_back(std::move(job));
  }
  auto found = read_images(jobs, text, threads, cost, reader_name);
  std::map<std::uint64_t, std::set<int>> out;
  for (std::size_t i = 0; i < frames.size(); ++i) out[frames[i]] = std::move(found[i]);
  return out;
}

std::size_t region_id(std::vector<std::vector<TextRegion>>& known,
                      const std::vector<TextRegion>& regions) {
  if (regions.empty()) return 0;
  for (std::size_t i = 1; i < known.size(); ++i)
    if (known[i] == regions) return i;
  known.push_back(regions);
  return known.size() - 1;
}

std::set<int> words_in_sequence(const std::vector<scenario::FrameTruth>& truth) {
  std::set<int> signs;
  for (const auto& t : truth) {
    const auto full = fully_visible_signs(t);
    signs.insert(full.begin(), full.end());
  }
  return signs;
}

std::size_t count_in(const std::set<int>& found, const std::set<int>& relevant) {
  std::size_t n = 0;
  for (int f : found) n += relevant.count(f);
  return n;
}

}  // namespace

std::string prepare_scenario(const EvalConfig& config, const std::string& out_dir, Logger logger) {
  if (!config.scenario_dir.empty()) {
    if (!fs::is_regular_file(fs::path(config.scenario_dir) / "scenario.json"))
      throw StartupError("eval: scenario_dir " + config.scenario_dir +
                         " holds no scenario.json (generate one with keyfleet scenario generate)");
    return config.scenario_dir;
  }
  const fs::path dir = fs::path(out_dir) / "scenario";
  if (fs::is_regular_file(dir / "scenario.json")) {
    logger->info("reusing the scenario already in {}", dir.string());
    return dir.string();
  }
  logger->info("generating the scenario into {}", dir.string());
  scenario::generate_scenario(config.scenario, dir.string(), logger);
  return dir.string();
}

namespace {

// What every drone's evaluation shares.
struct Context {
  const EvalConfig& config;
  const std::string& scenario_dir;
  Logger logger;
  std::vector<SelectorConfig::Strategy> strategies;
  std::string model;  // empty when no strategy needs MiniNet
  std::shared_ptr<const station::OrbVocabulary> vocabulary;
  std::vector<PlaceRetrieval> retrievals;
  std::string descriptor_model;   // empty when no retrieval needs the descriptor
  int descriptor_dimensions = 0;  // its output length (0 without it)
  station::OrbParams orb;
  JpegCodec codec;
  std::size_t drones = 0;
  std::vector<EncodingPlan> encodings;  // one raw plan when the config lists none
};

// Every strategy at every density over one drone's frames: the selections, the bytes, the
// words read and the bag-of-words vectors the place pairs need afterwards.
DroneRun evaluate_drone(const Context& ctx, const std::string& drone, EvalResults& results) {
  const EvalConfig& config = ctx.config;
  ctx.logger->info("{}: decoding frames", drone);
  const DroneFrames d = load_drone_frames(ctx.scenario_dir, drone, config.selector.decode_reduce);
  DroneRun run;
  run.info = d.info;
  for (const auto& t : d.truth) run.positions.push_back(t.street_position_m);
  results.drones.push_back(drone + " (day " + std::to_string(d.info.day) + ", " +
                           std::to_string(d.frames.size()) + " frames)");
  EvalCost& cost = results.cost;
  cost.frames += d.frames.size();

  double trigger_ms = 0;
  const auto vslam = run_vslam_trigger(d.for_selection(), config.selector, d.info.fps, &trigger_ms);
  cost.trigger_ms_per_frame += trigger_ms / double(ctx.drones);
  ctx.logger->info("{}: {} V-SLAM keyframes ({:.1f} ms/frame)", drone, vslam.size(), trigger_ms);

  std::unique_ptr<CachingSegmenter> segmenter;
  if (!ctx.model.empty())
    segmenter = std::make_unique<CachingSegmenter>(
        std::make_unique<vision::DnnTextSegmenter>(ctx.model, config.selector.semantic.threads));
  std::set<std::uint64_t> distinct;
  run.selected.assign(ctx.strategies.size(), {});
  run.region_ids.assign(ctx.strategies.size(), {});
  run.regions.assign(1, {});
  for (std::size_t s = 0; s < ctx.strategies.size(); ++s)
    for (double density : config.densities) {
      std::vector<std::uint64_t> kept;
      for (auto i : spread_evenly(vslam.size(), density)) kept.push_back(vslam[i]);
      SelectorConfig selector = config.selector;
      selector.strategy = ctx.strategies[s];
      agent::StageClock clock;
      std::vector<std::uint64_t> frames;
      std::vector<std::size_t> regions;
      for (const auto& sel :
           select_on_keyframes(d.for_selection(), kept, selector, segmenter.get(), &clock)) {
        frames.push_back(sel.frame.index);
        regions.push_back(region_id(run.regions, sel.text_regions));
      }
      for (const auto& stage : clock.snapshot())
        if (stage.stage != "trigger" && stage.stage != "semantic")
          cost.selection_cpu_ms += stage.cpu_ms_total;
      ++cost.selection_runs;
      distinct.insert(frames.begin(), frames.end());
      run.selected[s].push_back(std::move(frames));
      run.region_ids[s].push_back(std::move(regions));
    }
  if (segmenter) {
    cost.segmenter_requests += segmenter->frames_requested();
    cost.segmenter_frames += segmenter->frames_segmented();
    cost.segmenter_cpu_ms += segmenter->cpu_ms();
  }

  for (std::uint64_t f = 0; f < d.frames.size(); f += std::uint64_t(config.query_every))
    run.queries.push_back(f);
  std::unique_ptr<vision::DnnPlaceDescriber> describer;
  if (!ctx.descriptor_model.empty())
    describer = std::make_unique<vision::DnnPlaceDescriber>(ctx.descriptor_model);
  auto describe = [&](const cv::Mat& image) {
    station::PlaceView view;
    view.features = station::extract_orb(image, ctx.orb);
    if (describer) view.descriptor = describer->describe(image);
    return view;
  };
  // The queries (and, for the raw frames, the database keyframes): the camera's frames.
  const bool any_raw = std::any_of(ctx.encodings.begin(), ctx.encodings.end(),
                                   [](const EncodingPlan& p) { return p.raw; });
  std::set<std::uint64_t> to_describe(run.queries.begin(), run.queries.end());
  if (any_raw) to_describe.insert(distinct.begin(), distinct.end());
  auto orb_start = SteadyClock::now();
  for (auto f : to_describe) run.views[f] = describe(d.frames[f].image);
  cost.orb_ms += seconds_since(orb_start) * 1e3;
  cost.orb_frames += to_describe.size();

  const std::set<int> sequence = words_in_sequence(d.truth);
  run.encoded_views.assign(ctx.encodings.size(), {});
  for (std::size_t e = 0; e < ctx.encodings.size(); ++e) {
    const EncodingPlan& plan = ctx.encodings[e];
    // Per unit (a frame as this encoding sends it): bytes and signs read.
    std::map<UnitKey, std::uint64_t> bytes;
    std::map<UnitKey, std::set<int>> read;
    if (plan.raw) {
      for (auto f : distinct) bytes[plan.key(f, 0)] = ctx.codec.encode(d.frames[f].image).size();
      const std::vector<std::uint64_t> to_read(distinct.begin(), distinct.end());
      ctx.logger->info("{}: reading the words in {} distinct selected frames", drone,
                       to_read.size());
      for (auto& [f, signs] :
           read_frames(to_read, d, config.text, config.ocr_threads, cost, results.text_reader))
        read[plan.key(f, 0)] = std::move(signs);
    } else {
      // Each unit with the text regions it was selected with (the first seen that has any): they
      // matter to the text-aware encodings and to the station's hints.
      std::map<UnitKey, std::size_t> units;
      for (std::size_t s = 0; s < run.selected.size(); ++s)
        for (std::size_t k = 0; k < run.selected[s].size(); ++k)
          for (std::size_t i = 0; i < run.selected[s][k].size(); ++i) {
            const std::size_t id = run.region_ids[s][k][i];
            std::size_t& regions = units[plan.key(run.selected[s][k][i], id)];
            if (regions == 0) regions = id;
          }
      const auto encode_start = SteadyClock::now();
      std::vector<cv::Mat> decoded;
      std::vector<ReadJob> jobs;
      for (const auto& [unit, regions] : units) {
        const cv::Mat& frame = d.frames[unit.first].image;
        const agent::EncodedFrame encoded =
            agent::encode_at_level(frame, run.regions[regions], plan.level, plan.text_aware,
                                   config.text_margin_px, ctx.codec);
        bytes[unit] = encoded.image.size();
        DecodeResult image = ctx.codec.decode(encoded.image);
        if (!image.ok())
          throw StartupError("eval: encoding " + plan.name + " of " + drone + " frame " +
                             std::to_string(unit.first) + " does not decode: " + image.error);
        decoded.push_back(std::move(image.image));
        ReadJob job;
        job.truth = &d.truth[unit.first];
        job.sx = double(frame.cols) / double(decoded.back().cols);
        job.sy = double(frame.rows) / double(decoded.back().rows);
        job.hinted = true;
        for (const auto& r : encoded.text_regions)
          job.hints.push_back(cv::Rect(r.x, r.y, r.w, r.h) &
                              cv::Rect(0, 0, decoded.back().cols, decoded.back().rows));
        jobs.push_back(std::move(job));
      }
      for (std::size_t i = 0; i < jobs.size(); ++i) jobs[i].image = &decoded[i];
      cost.encode_ms += seconds_since(encode_start) * 1e3;
      cost.encoded_frames += units.size();
      ctx.logger->info("{}: {}: reading the words in {} distinct selected frames", drone, plan.name,
                       jobs.size());
      auto found = read_images(jobs, config.text, config.ocr_threads, cost, results.text_reader);
      orb_start = SteadyClock::now();
      std::size_t i = 0;
      for (const auto& [unit, regions] : units) {
        read[unit] = std::move(found[i]);
        run.encoded_views[e][unit] = describe(decoded[i]);
        ++i;
      }
      cost.orb_ms += seconds_since(orb_start) * 1e3;
      cost.orb_frames += units.size();
    }

    for (std::size_t s = 0; s < ctx.strategies.size(); ++s)
      for (std::size_t k = 0; k < config.densities.size(); ++k) {
        const auto& frames = run.selected[s][k];
        std::set<int> full, words_read;
        WordScore w;
        for (std::size_t i = 0; i < frames.size(); ++i) {
          const auto visible = fully_visible_signs(d.truth[frames[i]]);
          full.insert(visible.begin(), visible.end());
          const UnitKey unit = plan.key(frames[i], run.region_ids[s][k][i]);
          const auto& r = read.at(unit);
          words_read.insert(r.begin(), r.end());
          w.bytes += bytes.at(unit);  // a frame selected twice is sent twice
        }
        w.drone = drone;
        w.strategy = config.strategies[s];
        w.encoding = plan.name;
        w.density = config.densities[k];
        w.vslam_keyframes = vslam.size();
        w.keyframes = frames.size();
        w.words_in_sequence = sequence.size();
        w.full_words = count_in(full, sequence);
        w.words_read = count_in(words_read, sequence);
        results.words.push_back(w);
      }
  }
  return run;
}

// Queries from `q` against the keyframes `db` selected at each strategy and density, with each
// retrieval mode: the candidates the station would verify, ranked as it ranks them.
void score_places(const Context& ctx, const DroneRun& q, const DroneRun& db,
                  std::vector<PlaceScore>& out) {
  const EvalConfig& config = ctx.config;
  for (std::size_t e = 0; e < ctx.encodings.size(); ++e)
    for (PlaceRetrieval retrieval : ctx.retrievals)
      for (std::size_t s = 0; s < db.selected.size(); ++s)
        for (std::size_t k = 0; k < config.densities.size(); ++k) {
          const auto& keyframes = db.selected[s][k];
          PlaceRecognitionConfig places;
          places.retrieval = retrieval;
          station::VerifiedPlaceRecognizer recognizer(ctx.vocabulary,
                                                      station::make_match_verifier(places.verifier),
                                                      places, ctx.descriptor_dimensions);
          for (std::size_t i = 0; i < keyframes.size(); ++i)
            recognizer.add(
                {db.info.robot_id, i}, 0,
                db.database_view(ctx.encodings[e], e, keyframes[i], db.region_ids[s][k][i]));
          PlaceScore p;
          p.query_drone = q.info.robot_id;
          p.database_drone = db.info.robot_id;
          p.strategy = config.strategies[s];
          p.encoding = ctx.encodings[e].name;
          p.retrieval = to_string(retrieval);
          p.density = config.densities[k];
          p.database_keyframes = keyframes.size();
          for (auto f : q.queries) {
            const double at = q.positions[f];
            if (!answerable(at, db.positions, config.place_tolerance_m)) {
              ++p.unanswerable;
              continue;
            }
            std::vector<double> retrieved;
            for (const station::KeyframeKey& key : recognizer.retrieve(q.views.at(f), 5, {}))
              retrieved.push_back(db.positions[keyframes[key.sequence]]);
            add_query(p.topk, at, retrieved, config.place_tolerance_m);
          }
          out.push_back(p);
        }
}

}  // namespace

EvalResults run_eval(const EvalConfig& config, const std::string& scenario_dir, Logger logger) {
  const auto start = SteadyClock::now();
  const scenario::Scenario scenario = scenario::read_scenario(scenario_dir);
  EvalResults results;
  results.scenario_dir = scenario_dir;
  results.scenario_name = scenario.name;
  results.scenario_seed = scenario.seed;
  results.strategies = config.strategies;
  results.densities = config.densities;
  results.place_tolerance_m = config.place_tolerance_m;
  results.query_every = config.query_every;
  results.jpeg_quality = config.codec.jpeg_quality;
  results.encodings = config.encodings;
  results.vocabulary = vision::locate_model(config.vocabulary, "place vocabulary");

  Context ctx{config,
              scenario_dir,
              logger,
              {},
              {},
              std::make_shared<const station::OrbVocabulary>(
                  station::OrbVocabulary::load(results.vocabulary)),
              {},
              {},
              0,
              {},
              JpegCodec(config.codec.jpeg_quality),
              0,
              {}};
  for (const auto& name : config.place_retrievals) {
    const auto retrieval = place_retrieval(name);
    if (!retrieval) throw StartupError("place_retrievals: unknown mode " + name);
    ctx.retrievals.push_back(*retrieval);
    if (station::retrieval_mode(*retrieval).ranks_by_descriptor() && ctx.descriptor_model.empty()) {
      ctx.descriptor_model = vision::locate_model(config.place_descriptor, "place descriptor");
      ctx.descriptor_dimensions =
          vision::read_place_describer_info(ctx.descriptor_model).dimensions;
    }
  }
  results.place_retrievals = config.place_retrievals;
  bool semantic = false;
  for (const auto& name : config.strategies) {
    ctx.strategies.push_back(strategy_from_string(name));
    semantic = semantic || name == "semantic" || name == "full";
  }
  if (semantic) ctx.model = vision::locate_model(config.selector.semantic.model, "segmenter model");
  ctx.orb.features = config.orb_features;
  std::vector<std::string> encoding_names;
  for (const auto& e : config.encodings) {
    EncodingPlan plan;
    plan.name = e.name;
    plan.raw = false;
    plan.level.jpeg_quality = e.jpeg_quality;
    plan.level.scale = e.scale;
    plan.text_aware = e.text_aware;
    ctx.encodings.push_back(plan);
    encoding_names.push_back(e.name);
  }
  if (ctx.encodings.empty()) {
    ctx.encodings.push_back(EncodingPlan{});
    encoding_names.push_back("");
    // The camera's frames carry no text regions: only the encodings read as the station does.
    if (config.text.ppocr.region_hints != "off")
      ctx.logger->warn(
          "text.region_hints is '{}' but the config lists no encodings: the camera's frames are "
          "read whole, without the robot's regions (list an encoding, e.g. "
          "{{name: q85, jpeg_quality: 85}}, to read keyframes as the station does)",
          config.text.ppocr.region_hints);
  }
  std::vector<std::string> drones = config.drones;
  if (drones.empty())
    for (const auto& d : scenario.drones) drones.push_back(d.robot_id);
  ctx.drones = drones.size();

  std::vector<DroneRun> runs;
  for (const auto& drone : drones) runs.push_back(evaluate_drone(ctx, drone, results));
  // Place recognition: every ordered pair of drones that flew on different days.
  for (const auto& q : runs)
    for (const auto& db : runs)
      if (q.info.day != db.info.day) score_places(ctx, q, db, results.places);
  for (const auto& retrieval : config.place_retrievals) {
    std::vector<PlaceScore> places;
    for (const auto& p : results.places)
      if (p.retrieval == retrieval) places.push_back(p);
    results.summary_by_retrieval[retrieval] =
        summarise(results.words, places, config.strategies, config.densities, encoding_names);
  }
  results.summary = results.summary_by_retrieval.at(config.place_retrievals.front());
  results.cost.wall_s = seconds_since(start);
  return results;
}

std::vector<PointSummary> summarise(const std::vector<WordScore>& words,
                                    const std::vector<PlaceScore>& places,
                                    const std::vector<std::string>& strategies,
                                    const std::vector<double>& densities,
                                    const std::vector<std::string>& encodings) {
  std::vector<PointSummary> out;
  for (const auto& encoding : encodings)
    for (const auto& strategy : strategies)
      for (double density : densities) {
        PointSummary p;
        p.strategy = strategy;
        p.encoding = encoding;
        p.density = density;
        std::size_t drones = 0;
        for (const auto& w : words) {
          if (w.strategy != strategy || w.density != density || w.encoding != encoding) continue;
          ++drones;
          p.keyframes += w.keyframes;
          p.vslam_keyframes += w.vslam_keyframes;
          p.words_in_sequence += w.words_in_sequence;
          p.full_words += w.full_words;
          p.words_read += w.words_read;
          p.bytes += w.bytes;
          if (w.words_in_sequence) {
            p.word_recall += double(w.words_read) / double(w.words_in_sequence);
            p.full_word_recall += double(w.full_words) / double(w.words_in_sequence);
          }
        }
        if (drones) {
          p.word_recall /= double(drones);
          p.full_word_recall /= double(drones);
        }
        for (const auto& pl : places) {
          if (pl.strategy != strategy || pl.density != density || pl.encoding != encoding) continue;
          p.topk.queries += pl.topk.queries;
          p.topk.top1 += pl.topk.top1;
          p.topk.top5 += pl.topk.top5;
        }
        out.push_back(p);
      }
  return out;
}

}  // namespace keyfleet::eval
