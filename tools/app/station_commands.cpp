// `keyfleet query|locate|map`: questions to a station's database after (or during) a run.
#include <opencv2/imgcodecs.hpp>

#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>

#include "commands.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/station/analysis_setup.hpp"
#include "keyfleet/station/analysis_store.hpp"
#include "keyfleet/station/keyframe_store.hpp"
#include "keyfleet/station/map/topo_map.hpp"
#include "keyfleet/station/station_analysis.hpp"
#include "keyfleet/station/station_config.hpp"

namespace keyfleet::commands {
namespace {

namespace fs = std::filesystem;
using station::KeyframeKey;

struct RunOptions {
  std::string run;  // a station folder, or a mission run folder holding station/
};

fs::path station_dir(const std::string& run) {
  if (fs::is_regular_file(fs::path(run) / "station.sqlite")) return run;
  if (fs::is_regular_file(fs::path(run) / "station" / "station.sqlite"))
    return fs::path(run) / "station";
  throw StartupError("no station database in " + run + " (looked for station.sqlite and " +
                     "station/station.sqlite)");
}

// The station configuration the run used, when the run folder holds it; else the defaults.
StationConfig run_station_config(const fs::path& station) {
  for (const fs::path& candidate :
       {station / "config" / "station.yaml", station.parent_path() / "config" / "station.yaml"}) {
    if (fs::is_regular_file(candidate)) return load_station_config(candidate.string());
  }
  return StationConfig{};
}

std::string format_time(std::int64_t ns) {
  // Replayed scenarios count time from their first frame: show it as such, not as 1970.
  constexpr std::int64_t kYear2000Ns = 946'684'800LL * 1'000'000'000LL;
  if (ns < kYear2000Ns) {
    std::ostringstream out;
    out << "t+" << std::fixed << std::setprecision(3) << double(ns) * 1e-9 << " s";
    return out.str();
  }
  const std::time_t seconds = static_cast<std::time_t>(ns / 1000000000);
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  std::ostringstream out;
  out << std::put_time(&utc, "%Y-%m-%d %H:%M:%S") << '.' << std::setw(3) << std::setfill('0')
      << (ns / 1000000) % 1000 << 'Z';
  return out.str();
}

KeyframeKey parse_key(const std::string& text) {
  const auto hash = text.rfind('#');
  if (hash == std::string::npos || hash == 0 || hash + 1 == text.size())
    throw StartupError("keyframe '" + text + "': expected ROBOT#SEQUENCE, e.g. drone_0#12");
  try {
    return {text.substr(0, hash), std::stoull(text.substr(hash + 1))};
  } catch (const std::exception&) {
    throw StartupError("keyframe '" + text + "': the sequence number is not a number");
  }
}

// A finished run's database, opened read-only by every question: asking writes nothing.
std::string database(const fs::path& station_dir) {
  const fs::path path = station_dir / "station.sqlite";
  if (!fs::exists(path)) throw StartupError("no station database " + path.string());
  return path.string();
}

struct LoadedMap {
  station::KeyframeStore keyframes;
  station::AnalysisStore analysis;
  station::TopoMap map;
  explicit LoadedMap(const fs::path& dir)
      : keyframes(database(dir), SqliteDb::Mode::kReadOnly),
        analysis(database(dir), SqliteDb::Mode::kReadOnly) {
    station::rebuild_map(keyframes, analysis, map);
  }
  station::MapNodeId node(const std::string& text) const {
    const KeyframeKey key = parse_key(text);
    const auto id = map.find(key.robot_id, key.sequence);
    if (!id) throw StartupError("keyframe " + text + " is not in this run's map");
    return *id;
  }
};

std::string describe(const station::TopoMap& map, station::MapNodeId id) {
  const station::MapNode& n = map.node(id);
  std::ostringstream out;
  out << n.robot_id << '#' << n.sequence << "  " << format_time(n.capture_time_ns);
  if (n.pose) out << "  at (" << n.pose->tx << ", " << n.pose->ty << ", " << n.pose->tz << ")";
  if (!n.words.empty()) {
    out << "  words:";
    for (const auto& w : n.words) out << ' ' << w;
  }
  return out.str();
}

void query_words(const std::string& run, const std::string& text, std::size_t limit) {
  const fs::path dir = station_dir(run);
  const station::AnalysisStore store(database(dir), SqliteDb::Mode::kReadOnly);
  std::vector<station::StoredWord> words;
  try {
    words = store.search_words(text, limit);
  } catch (const std::exception& e) {
    throw StartupError("query '" + text + "' is not a valid search (FTS5 syntax): " + e.what());
  }
  if (words.empty()) {
    std::cout << "no word matches '" << text << "' in " << (dir / "station.sqlite").string()
              << "\n";
    return;
  }
  std::cout << std::left << std::setw(14) << "robot" << std::setw(10) << "keyframe" << std::setw(26)
            << "captured" << std::setw(16) << "word" << std::setw(7) << "conf"
            << "box (x,y,w,h)\n";
  for (const auto& w : words) {
    std::cout << std::left << std::setw(14) << w.keyframe.robot_id << std::setw(10)
              << w.keyframe.sequence << std::setw(26) << format_time(w.capture_time_ns)
              << std::setw(16) << w.text << std::setw(7) << std::setprecision(2) << w.confidence
              << w.box.x << ',' << w.box.y << ',' << w.box.width << ',' << w.box.height << "\n";
  }
}

struct LocateOptions {
  std::string image;
  std::string run;
  std::string vocabulary;
  std::string retrieval;
};

void locate(const LocateOptions& o) {
  const fs::path dir = station_dir(o.run);
  StationConfig config = run_station_config(dir);
  config.analysis.places.enabled = true;
  if (!o.vocabulary.empty()) config.analysis.places.vocabulary = o.vocabulary;
  if (!o.retrieval.empty()) {
    const auto retrieval = place_retrieval(o.retrieval);
    if (!retrieval)
      throw StartupError("--retrieval " + o.retrieval + ": must be one of " +
                         place_retrieval_choices());
    config.analysis.places.retrieval = *retrieval;
  }
  const cv::Mat image = cv::imread(o.image, cv::IMREAD_COLOR);
  if (image.empty()) throw StartupError("cannot read image " + o.image);
  PlaceRecognitionConfig& settings = config.analysis.places;
  LoadedMap loaded(dir);
  auto places = station::make_configured_place_recognizer(settings);
  station::PlaceIndexRebuild index = station::rebuild_place_index(loaded.analysis, *places);
  if (station::retrieval_mode(settings.retrieval).ranks_by_descriptor() && index.indexed > 0 &&
      index.without_descriptor == index.indexed) {
    std::cout << "no keyframe of this run has a stored place descriptor (analysed with bow "
                 "retrieval): retrieving by the bag of words\n";
    settings.retrieval = PlaceRetrieval::kBow;
    places = station::make_configured_place_recognizer(settings);
    index = station::rebuild_place_index(loaded.analysis, *places);
  }
  station::OrbParams orb;
  orb.features = settings.orb_features;
  station::PlaceView view{station::extract_orb(image, orb), {}};
  if (auto describer = station::make_configured_place_describer(settings))
    view.descriptor = describer->describe(image);
  const station::PlaceOutcome outcome = places->recognise(view, {});
  std::cout << "retrieval " << to_string(settings.retrieval) << ": checked "
            << outcome.checked.size() << " candidate(s) of " << index.indexed
            << " indexed keyframe(s)";
  if (station::retrieval_mode(settings.retrieval).ranks_by_descriptor() &&
      index.without_descriptor > 0)
    std::cout << " (" << index.without_descriptor << " without a stored descriptor)";
  std::cout << "\n";
  for (const auto& c : outcome.checked) {
    std::cout << "  " << station::to_string(c.other) << "  bow " << std::setprecision(3)
              << c.bow_score << "  cosine " << c.descriptor_similarity << "  inliers " << c.inliers
              << "/" << c.matches << "\n";
  }
  if (!outcome.best) {
    std::cout << "not located: no candidate passed verification (more than "
              << config.analysis.places.min_inliers << " inliers and a ratio above "
              << config.analysis.places.min_inlier_ratio << ")\n";
    throw CLI::RuntimeError(2);
  }
  const auto id = loaded.map.find(outcome.best->other.robot_id, outcome.best->other.sequence);
  std::cout << "located: "
            << (id ? describe(loaded.map, *id) : station::to_string(outcome.best->other)) << "  ("
            << outcome.best->inliers << " inliers)\n";
}

void add_map_commands(CLI::App& app) {
  auto* map = app.add_subcommand("map", "the shared topological map of a run");
  map->require_subcommand(1);
  auto run = std::make_shared<std::string>();
  const auto add_run = [run](CLI::App* command) {
    command->add_option("--run", *run, "station folder or mission run folder")->required();
  };

  auto key = std::make_shared<std::string>();
  auto* robots = map->add_subcommand("robots", "which robots saw the place of a keyframe");
  robots->add_option("keyframe", *key, "ROBOT#SEQUENCE")->required();
  add_run(robots);
  robots->callback([run, key] {
    run_reporting([&] {
      LoadedMap loaded(station_dir(*run));
      for (const auto& robot : loaded.map.robots_at_place(loaded.node(*key)))
        std::cout << robot << "\n";
    });
  });

  auto word = std::make_shared<std::string>();
  auto* where = map->add_subcommand("word", "where a word was seen (keyframes, robots, poses)");
  where->add_option("word", *word, "the word, case-insensitive")->required();
  add_run(where);
  where->callback([run, word] {
    run_reporting([&] {
      LoadedMap loaded(station_dir(*run));
      const auto nodes = loaded.map.nodes_with_word(*word);
      if (nodes.empty()) std::cout << "'" << *word << "' was not read in any keyframe\n";
      for (const auto id : nodes) std::cout << describe(loaded.map, id) << "\n";
    });
  });

  auto from = std::make_shared<std::string>(), to = std::make_shared<std::string>();
  auto* path = map->add_subcommand("path", "a path between two keyframes through the map");
  path->add_option("from", *from, "ROBOT#SEQUENCE")->required();
  path->add_option("to", *to, "ROBOT#SEQUENCE")->required();
  add_run(path);
  path->callback([run, from, to] {
    run_reporting([&] {
      LoadedMap loaded(station_dir(*run));
      const auto nodes = loaded.map.shortest_path(loaded.node(*from), loaded.node(*to));
      if (nodes.empty()) {
        std::cout << "no path: the two keyframes are not connected\n";
        throw CLI::RuntimeError(2);
      }
      for (const auto id : nodes) std::cout << describe(loaded.map, id) << "\n";
    });
  });

  auto out = std::make_shared<std::string>();
  auto* export_map = map->add_subcommand("export", "write the map as GraphML and JSON");
  add_run(export_map);
  export_map->add_option("--out", *out, "folder (default: the station folder)");
  export_map->callback([run, out] {
    run_reporting([&] {
      const fs::path dir = station_dir(*run);
      LoadedMap loaded(dir);
      const fs::path target = out->empty() ? dir : fs::path(*out);
      fs::create_directories(target);
      std::ofstream graphml(target / "map.graphml");
      loaded.map.write_graphml(graphml);
      std::ofstream(target / "map.json") << loaded.map.to_json().dump(1) << "\n";
      std::cout << "map: " << loaded.map.node_count() << " keyframes, "
                << loaded.map.place_matches().size() << " place matches -> "
                << (target / "map.graphml").string() << ", " << (target / "map.json").string()
                << "\n";
    });
  });
}

}  // namespace

void add_station_commands(CLI::App& app) {
  auto* query = app.add_subcommand("query", "search a station's database");
  query->require_subcommand(1);
  auto text = std::make_shared<std::string>();
  auto run = std::make_shared<std::string>();
  auto limit = std::make_shared<std::size_t>(50);
  auto* words = query->add_subcommand("words", "keyframes where a word was read (FTS5 search)");
  words->add_option("text", *text, "word or FTS5 query, e.g. HOTEL, hot*, \"main street\"")
      ->required();
  words->add_option("--run", *run, "station folder or mission run folder")->required();
  words->add_option("--limit", *limit, "at most this many rows");
  words->callback([text, run, limit] { run_reporting([&] { query_words(*run, *text, *limit); }); });

  auto options = std::make_shared<LocateOptions>();
  auto* locate_cmd =
      app.add_subcommand("locate", "relocalise an image: the best verified keyframe of a run");
  locate_cmd->add_option("image", options->image, "query image")
      ->required()
      ->check(CLI::ExistingFile);
  locate_cmd->add_option("--run", options->run, "station folder or mission run folder")->required();
  locate_cmd->add_option("--vocabulary", options->vocabulary,
                         "vocabulary file (default: the run's station configuration)");
  locate_cmd->add_option("--retrieval", options->retrieval,
                         "bow, cnn or fusion (default: the run's station configuration)");
  locate_cmd->callback([options] { run_reporting([&] { locate(*options); }); });

  add_map_commands(app);
}

}  // namespace keyfleet::commands
