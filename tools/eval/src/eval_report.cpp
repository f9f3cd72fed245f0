// The evaluation's files: results.json (everything), results.csv (one row per drone and
// point, plus the summed rows) and report.md (tables, plots, the paper's claims checked).
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "keyfleet/common/error.hpp"
#include "keyfleet/common/file_output.hpp"
#include "keyfleet/eval/eval_runner.hpp"

namespace keyfleet::eval {
namespace {

namespace fs = std::filesystem;

std::string format(const char* fmt, ...) {
  char buffer[512];
  va_list args;
  va_start(args, fmt);
  std::vsnprintf(buffer, sizeof buffer, fmt, args);
  va_end(args);
  return buffer;
}

nlohmann::json to_json(const PointSummary& p) {
  return {{"strategy", p.strategy},
          {"encoding", p.encoding},
          {"density", p.density},
          {"keyframes", p.keyframes},
          {"vslam_keyframes", p.vslam_keyframes},
          {"words_in_sequence", p.words_in_sequence},
          {"full_words", p.full_words},
          {"words_read", p.words_read},
          {"word_recall", p.word_recall},
          {"full_word_recall", p.full_word_recall},
          {"bytes", p.bytes},
          {"place_queries", p.topk.queries},
          {"top1", p.topk.top1_rate()},
          {"top5", p.topk.top5_rate()}};
}

PointSummary summary_from_json(const nlohmann::json& j) {
  PointSummary p;
  p.strategy = j.at("strategy");
  p.encoding = j.value("encoding", std::string());  // absent before encodings
  p.density = j.at("density");
  p.keyframes = j.at("keyframes");
  p.vslam_keyframes = j.at("vslam_keyframes");
  p.words_in_sequence = j.at("words_in_sequence");
  p.full_words = j.at("full_words");
  p.words_read = j.at("words_read");
  p.word_recall = j.at("word_recall");
  p.full_word_recall = j.at("full_word_recall");
  p.bytes = j.at("bytes");
  p.topk.queries = j.at("place_queries");
  p.topk.top1 = std::size_t(std::llround(j.at("top1").get<double>() * double(p.topk.queries)));
  p.topk.top5 = std::size_t(std::llround(j.at("top5").get<double>() * double(p.topk.queries)));
  return p;
}

std::string csv(const EvalResults& r) {
  std::ostringstream out;
  out << "scope,encoding,strategy,density,keyframes,vslam_keyframes,words_in_sequence,full_words,"
         "words_read,word_recall,bytes,place_queries,top1,top5\n";
  for (const auto& w : r.words)
    out << w.drone << "," << w.encoding << "," << w.strategy << "," << w.density << ","
        << w.keyframes << "," << w.vslam_keyframes << "," << w.words_in_sequence << ","
        << w.full_words << "," << w.words_read << ","
        << (w.words_in_sequence ? double(w.words_read) / double(w.words_in_sequence) : 0.0) << ","
        << w.bytes << ",,,\n";
  for (const auto& p : r.summary)
    out << "all," << p.encoding << "," << p.strategy << "," << p.density << "," << p.keyframes
        << "," << p.vslam_keyframes << "," << p.words_in_sequence << "," << p.full_words << ","
        << p.words_read << "," << p.word_recall << "," << p.bytes << "," << p.topk.queries << ","
        << p.topk.top1_rate() << "," << p.topk.top5_rate() << "\n";
  return out.str();
}

// One table: a row per density, a column per strategy, `cell` formats a point.
template <typename Cell>
std::string table(const EvalResults& r, const std::string& first, Cell cell) {
  std::string out = "| " + first + " | keyframes |";
  std::string rule = "|---|---|";
  for (const auto& s : r.strategies) out += " " + s + " |", rule += "---|";
  out += "\n" + rule + "\n";
  for (double d : r.densities) {
    const auto* any = find_point(r.summary, r.strategies.front(), d);
    out += format("| %.0f %% | %zu |", 100 * d, any ? any->keyframes : 0);
    for (const auto& s : r.strategies) {
      const auto* p = find_point(r.summary, s, d);
      out += " " + (p ? cell(*p) : std::string("-")) + " |";
    }
    out += "\n";
  }
  return out;
}

// Where one strategy has more (or at least as much) than another, density by density.
template <typename Value>
std::string compare(const EvalResults& r, const std::string& a, const std::string& b, Value value,
                    const char* unit, bool at_least) {
  std::string out;
  int holds = 0, points = 0;
  for (double d : r.densities) {
    const auto* pa = find_point(r.summary, a, d);
    const auto* pb = find_point(r.summary, b, d);
    if (!pa || !pb) continue;
    ++points;
    const double va = value(*pa), vb = value(*pb);
    const bool ok = at_least ? va >= vb : va > vb;
    holds += ok;
    out += format("%s%.0f %%: %.3g vs %.3g%s", out.empty() ? "" : "; ", 100 * d, va, vb, unit);
  }
  if (!points) return "(" + a + " or " + b + " not evaluated)";
  return format("holds at %d of %d densities (%s vs %s: ", holds, points, a.c_str(), b.c_str()) +
         out + ")";
}

// The results of one encoding only (its summaries), for the per-encoding tables.
EvalResults only_encoding(const EvalResults& r, const std::string& encoding) {
  EvalResults one = r;
  auto keep = [&](std::vector<PointSummary> points) {
    points.erase(std::remove_if(points.begin(), points.end(),
                                [&](const PointSummary& p) { return p.encoding != encoding; }),
                 points.end());
    return points;
  };
  one.summary = keep(r.summary);
  for (auto& [mode, points] : one.summary_by_retrieval) points = keep(points);
  return one;
}

std::string encodings_section(const EvalResults& r) {
  const auto points = compare_encodings(r);
  if (points.empty()) return {};
  std::ostringstream md;
  md << "## Encodings (information per byte)\n\nEach selected keyframe encoded as the agent's "
        "send ladder would (JPEG quality, scale, text-aware: the frame's size kept, its text "
        "regions at full detail, the background coarsened), decoded, and read and described "
        "from the decoded image; queries stay the query drone's camera frames. Relative to `"
     << r.encodings.front().name << "` at the same strategy and density.\n\n";
  md << "| encoding | quality | scale | text-aware | strategy | kept | keyframes | kB / keyframe "
        "| words read | % of "
     << r.encodings.front().name << " | recall |";
  std::string rule = "|---|---|---|---|---|---|---|---|---|---|---|";
  for (const auto& mode : r.place_retrievals) md << " top-1 " << mode << " |", rule += "---|";
  md << "\n" << rule << "\n";
  for (const auto& p : points) {
    const EvalEncoding* e = nullptr;
    for (const auto& candidate : r.encodings)
      if (candidate.name == p.encoding) e = &candidate;
    md << format("| %s | %d | %.2f | %s | %s | %.0f %% | %zu | %.1f | %zu | %.1f %% | %.3f |",
                 p.encoding.c_str(), e ? e->jpeg_quality : 0, e ? e->scale : 0.0,
                 e && e->text_aware ? "yes" : "no", p.strategy.c_str(), 100 * p.density,
                 p.keyframes, p.kb_per_keyframe, p.words_read, 100 * p.words_vs_reference,
                 p.word_recall);
    for (const auto& mode : r.place_retrievals) {
      const auto it = p.top1.find(mode);
      const auto d = p.top1_vs_reference.find(mode);
      md << format(" %.3f (%+.1f) |", it == p.top1.end() ? 0.0 : it->second,
                   d == p.top1_vs_reference.end() ? 0.0 : 100 * d->second);
    }
    md << "\n";
  }
  md << "\nTop-1 in brackets: points against the reference. Words read and top-1 for every "
        "encoding, strategy and density follow in the tables below, one set per encoding.\n\n"
        "![words read and top-1 against kB per keyframe](fig_encodings.png)\n\n";
  return md.str();
}

std::string report_tables(const EvalResults& r);
std::string cost_section(const EvalResults& r);

std::string report(const EvalResults& r) {
  if (r.encodings.empty()) return report_tables(r) + cost_section(r);
  std::ostringstream md;
  md << "# keyfleet eval: information per byte, " << r.encodings.size()
     << " encodings on a generated scenario\n\n";
  md << encodings_section(r);
  for (const auto& e : r.encodings) {
    std::string part = report_tables(only_encoding(r, e.name));
    // One encoding's Fig. 6 under its own heading, its sections a level down.
    std::string shifted;
    std::istringstream lines(part);
    for (std::string line; std::getline(lines, line);) {
      if (line.rfind("# ", 0) == 0)
        line = "# Encoding `" + e.name + "` (JPEG " + std::to_string(e.jpeg_quality) +
               format(", scale %.2f", e.scale) + (e.text_aware ? ", text-aware" : "") + ")";
      if (!line.empty() && line[0] == '#') line = "#" + line;
      shifted += line + "\n";
    }
    md << shifted << "\n";
  }
  md << cost_section(r);
  return md.str();
}

std::string report_tables(const EvalResults& r) {
  std::ostringstream md;
  md << "# keyfleet eval: Fig. 6 of Alonso et al. (ICRA 2019) on a generated scenario\n\n";
  md << "Scenario `" << r.scenario_name << "` (seed " << r.scenario_seed << ", " << r.scenario_dir
     << "): ";
  for (std::size_t i = 0; i < r.drones.size(); ++i) md << (i ? ", " : "") << r.drones[i];
  md << ". Text reader: `" << r.text_reader
     << "`. Place recognition (the table and plot; other "
        "modes below): `"
     << (r.place_retrievals.empty() ? std::string("bow") : r.place_retrievals.front())
     << "` retrieval, ORB with `" << fs::path(r.vocabulary).filename().string()
     << "`, queries every " << r.query_every
     << "th frame of one drone against the selected keyframes of each drone of the other day, "
     << "right when the retrieved keyframe looks at a street point within " << r.place_tolerance_m
     << " m of the query's. JPEG quality " << r.jpeg_quality
     << ". Densities are fractions of each drone's V-SLAM keyframes, kept evenly spread and "
        "the same for every strategy, so every strategy sends the same number of keyframes.\n\n";

  md << "## (a) Words read (Fig. 6a)\n\nDistinct ground-truth words read by the text reader in "
        "the selected keyframes, summed over drones (recall = mean over drones of words read / "
        "legible words fully visible somewhere in the drone's sequence):\n\n";
  md << table(r, "kept", [](const PointSummary& p) {
    return format("%zu (%.2f)", p.words_read, p.word_recall);
  });
  md << "\nOf the same words, those fully visible in a selected keyframe (ground truth, no "
        "reading):\n\n";
  md << table(r, "kept", [](const PointSummary& p) {
    return format("%zu / %zu", p.full_words, p.words_in_sequence);
  });
  md << "\n![Fig. 6a](fig6a_words.png)\n\n";

  md << "## (b) Place recognition (Fig. 6b)\n\nTop-1 / top-5 accuracy over the answerable "
        "queries (some frame of the database drone looks within the tolerance):\n\n";
  md << table(r, "kept", [](const PointSummary& p) {
    return format("%.3f / %.3f (%zu q)", p.topk.top1_rate(), p.topk.top5_rate(), p.topk.queries);
  });
  md << "\n![Fig. 6b](fig6b_places.png)\n\n";
  for (std::size_t m = 1; m < r.place_retrievals.size(); ++m) {
    const std::string& mode = r.place_retrievals[m];
    EvalResults other = r;
    other.summary = r.summary_by_retrieval.at(mode);
    md << "With `" << mode << "` retrieval (top-1 / top-5, the same queries):\n\n";
    md << table(other, "kept", [](const PointSummary& p) {
      return format("%.3f / %.3f", p.topk.top1_rate(), p.topk.top5_rate());
    });
    md << "\n";
  }

  md << "## (c) Bytes sent\n\n";
  md << table(r, "kept", [](const PointSummary& p) { return format("%.2f MB", p.bytes / 1e6); });

  md << "\n## The paper's claims, here\n\n";
  auto read = [](const PointSummary& p) { return double(p.words_read); };
  auto full = [](const PointSummary& p) { return double(p.full_words); };
  auto top1 = [](const PointSummary& p) { return p.topk.top1_rate(); };
  auto top5 = [](const PointSummary& p) { return p.topk.top5_rate(); };
  md << "- More words at every density (words read): "
     << compare(r, "full", "vslam", read, "", false) << ".\n";
  md << "- The same on ground truth (words fully visible in the keyframes): "
     << compare(r, "full", "vslam", full, "", false) << ".\n";
  md << "- No loss in place recognition (top-1): " << compare(r, "full", "vslam", top1, "", true)
     << ".\n";
  md << "- No loss in place recognition (top-5): " << compare(r, "full", "vslam", top5, "", true)
     << ".\n";
  const auto* one = find_point(r.summary, r.strategies.front(), r.densities.front());
  if (one && one->topk.queries)
    md << format("\nOne query is %.1f points of accuracy at a density; one word is one count.\n",
                 100.0 / double(one->topk.queries));

  return md.str();
}

// What the whole evaluation cost (every encoding's together).
std::string cost_section(const EvalResults& r) {
  std::ostringstream md;
  const auto& c = r.cost;
  md << "\n## Cost\n\n";
  md << format(
      "%zu frames decoded; V-SLAM trigger %.1f ms/frame CPU, run once per drone; %zu "
      "selection runs (strategy x density x drone) recomputing quality and sharpness, %.1f s "
      "CPU; MiniNet asked about %zu frames, ran on %zu (cached per frame), %.1f s CPU; text "
      "reader on %zu distinct selected frames, %.1f s wall (median %.0f ms a frame, one "
      "reader); ORB + bag of words on %zu frames, %.1f s; whole evaluation %.1f s wall.\n",
      c.frames, c.trigger_ms_per_frame, c.selection_runs, c.selection_cpu_ms / 1e3,
      c.segmenter_requests, c.segmenter_frames, c.segmenter_cpu_ms / 1e3, c.ocr_frames,
      c.ocr_wall_s, c.ocr_median_ms, c.orb_frames, c.orb_ms / 1e3, c.wall_s);
  if (c.encoded_frames)
    md << format(
        "\nEncodings: %zu frames encoded and decoded (each distinct selected frame once per "
        "encoding: the text reader and ORB counts above are these, plus the queries' ORB), "
        "%.1f s.\n",
        c.encoded_frames, c.encode_ms / 1e3);
  return md.str();
}

}  // namespace

const PointSummary* find_point(const std::vector<PointSummary>& summary,
                               const std::string& strategy, double density) {
  for (const auto& p : summary)
    if (p.strategy == strategy && p.density == density) return &p;
  return nullptr;
}

const PointSummary* find_point(const std::vector<PointSummary>& summary,
                               const std::string& strategy, double density,
                               const std::string& encoding) {
  for (const auto& p : summary)
    if (p.strategy == strategy && p.density == density && p.encoding == encoding) return &p;
  return nullptr;
}

std::vector<EncodingPoint> compare_encodings(const EvalResults& r) {
  std::vector<EncodingPoint> out;
  if (r.encodings.empty()) return out;
  const std::string& reference = r.encodings.front().name;
  for (const auto& p : r.summary) {
    EncodingPoint e;
    e.encoding = p.encoding;
    e.strategy = p.strategy;
    e.density = p.density;
    e.keyframes = p.keyframes;
    e.kb_per_keyframe = p.keyframes ? double(p.bytes) / double(p.keyframes) / 1e3 : 0.0;
    e.words_read = p.words_read;
    e.words_in_sequence = p.words_in_sequence;
    e.word_recall = p.word_recall;
    const PointSummary* ref = find_point(r.summary, p.strategy, p.density, reference);
    if (ref && ref->words_read)
      e.words_vs_reference = double(p.words_read) / double(ref->words_read);
    for (const auto& [mode, summary] : r.summary_by_retrieval) {
      const PointSummary* mine = find_point(summary, p.strategy, p.density, p.encoding);
      const PointSummary* theirs = find_point(summary, p.strategy, p.density, reference);
      if (!mine) continue;
      e.top1[mode] = mine->topk.top1_rate();
      if (theirs) e.top1_vs_reference[mode] = mine->topk.top1_rate() - theirs->topk.top1_rate();
    }
    out.push_back(std::move(e));
  }
  return out;
}

void write_results(const EvalResults& r, const std::string& out_dir) {
  fs::create_directories(out_dir);
  nlohmann::json j;
  j["scenario"] = {{"dir", r.scenario_dir}, {"name", r.scenario_name}, {"seed", r.scenario_seed}};
  j["drones"] = r.drones;
  j["strategies"] = r.strategies;
  j["densities"] = r.densities;
  j["text_reader"] = r.text_reader;
  j["vocabulary"] = r.vocabulary;
  j["place_tolerance_m"] = r.place_tolerance_m;
  j["query_every"] = r.query_every;
  j["jpeg_quality"] = r.jpeg_quality;
  j["encodings"] = nlohmann::json::array();
  for (const auto& e : r.encodings)
    j["encodings"].push_back({{"name", e.name},
                              {"jpeg_quality", e.jpeg_quality},
                              {"scale", e.scale},
                              {"text_aware", e.text_aware}});
  j["place_retrievals"] = r.place_retrievals;
  j["encoding_points"] = nlohmann::json::array();
  for (const auto& p : compare_encodings(r))
    j["encoding_points"].push_back({{"encoding", p.encoding},
                                    {"strategy", p.strategy},
                                    {"density", p.density},
                                    {"keyframes", p.keyframes},
                                    {"kb_per_keyframe", p.kb_per_keyframe},
                                    {"words_read", p.words_read},
                                    {"words_in_sequence", p.words_in_sequence},
                                    {"word_recall", p.word_recall},
                                    {"words_vs_reference", p.words_vs_reference},
                                    {"top1", p.top1},
                                    {"top1_vs_reference", p.top1_vs_reference}});
  j["summary"] = nlohmann::json::array();
  for (const auto& p : r.summary) j["summary"].push_back(to_json(p));
  j["words"] = nlohmann::json::array();
  for (const auto& w : r.words)
    j["words"].push_back({{"drone", w.drone},
                          {"strategy", w.strategy},
                          {"encoding", w.encoding},
                          {"density", w.density},
                          {"vslam_keyframes", w.vslam_keyframes},
                          {"keyframes", w.keyframes},
                          {"words_in_sequence", w.words_in_sequence},
                          {"full_words", w.full_words},
                          {"words_read", w.words_read},
                          {"bytes", w.bytes}});
  j["places"] = nlohmann::json::array();
  for (const auto& p : r.places)
    j["places"].push_back({{"query_drone", p.query_drone},
                           {"database_drone", p.database_drone},
                           {"strategy", p.strategy},
                           {"encoding", p.encoding},
                           {"retrieval", p.retrieval},
                           {"density", p.density},
                           {"database_keyframes", p.database_keyframes},
                           {"queries", p.topk.queries},
                           {"unanswerable", p.unanswerable},
                           {"top1", p.topk.top1},
                           {"top5", p.topk.top5}});
  const auto& c = r.cost;
  j["cost"] = {{"frames", c.frames},
               {"trigger_ms_per_frame", c.trigger_ms_per_frame},
               {"selection_runs", c.selection_runs},
               {"selection_cpu_ms", c.selection_cpu_ms},
               {"segmenter_requests", c.segmenter_requests},
               {"segmenter_frames", c.segmenter_frames},
               {"segmenter_cpu_ms", c.segmenter_cpu_ms},
               {"ocr_frames", c.ocr_frames},
               {"ocr_wall_s", c.ocr_wall_s},
               {"ocr_median_ms", c.ocr_median_ms},
               {"orb_frames", c.orb_frames},
               {"orb_ms", c.orb_ms},
               {"encoded_frames", c.encoded_frames},
               {"encode_ms", c.encode_ms},
               {"wall_s", c.wall_s}};
  const fs::path dir(out_dir);
  write_file(dir / "results.json", j.dump(2) + "\n");
  write_file(dir / "results.csv", csv(r));
  write_file(dir / "report.md", report(r));
}

bool plot_results(const std::string& out_dir, const std::string& python, std::string& problem,
                  const std::string& script_name) {
  std::vector<fs::path> candidates;
  std::error_code error;
  const fs::path self = fs::read_symlink("/proc/self/exe", error);
  if (!error) candidates.push_back(self.parent_path() / "../share/keyfleet/report" / script_name);
#ifdef KEYFLEET_EVAL_REPORT_SOURCE_DIR
  candidates.push_back(fs::path(KEYFLEET_EVAL_REPORT_SOURCE_DIR) / script_name);
#endif
  for (const auto& script : candidates) {
    if (!fs::is_regular_file(script)) continue;
    const std::string command =
        "'" + python + "' '" + script.lexically_normal().string() + "' '" + out_dir + "'";
    if (std::system(command.c_str()) == 0) return true;
    problem = command + " failed (is python3-matplotlib installed?)";
    return false;
  }
  problem = script_name + " not found beside the binaries nor in the source tree";
  return false;
}

std::vector<PointSummary> read_summary(const std::string& results_json) {
  std::ifstream in(results_json);
  if (!in) throw StartupError(results_json + ": cannot read evaluation results");
  try {
    const nlohmann::json doc = nlohmann::json::parse(in);
    std::vector<PointSummary> summary;
    for (const auto& j : doc.at("summary")) summary.push_back(summary_from_json(j));
    return summary;
  } catch (const nlohmann::json::exception& e) {
    throw StartupError(results_json + ": malformed evaluation results: " + e.what());
  }
}

}  // namespace keyfleet::eval
