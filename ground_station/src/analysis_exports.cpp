#include "keyfleet/station/analysis_exports.hpp"

#include <filesystem>
#include <map>
#include <set>
#include <sstream>

#include "keyfleet/common/error.hpp"
#include "keyfleet/common/file_output.hpp"

namespace keyfleet::station {

std::string csv_cell(const std::string& text) {
  std::string quoted = "\"";
  // A cell a spreadsheet would take for a formula (a painted sign can read "=HYPERLINK(...)")
  // is kept as text by a leading apostrophe, as OWASP recommends for CSV exports.
  if (!text.empty() && std::string("=+-@\t\r").find(text.front()) != std::string::npos)
    quoted += '\'';
  for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

std::string write_analysis_exports(const AnalysisStore& store, const TopoMap& map,
                                   const StationAnalysis::Summary& summary,
                                   const std::string& run_dir) {
  namespace fs = std::filesystem;
  const fs::path dir(run_dir);
  {
    std::ostringstream out;
    map.write_graphml(out);
    write_file(dir / "map.graphml", out.str());
  }
  // Words are what a reader made of a picture: not always UTF-8, which JSON needs.
  write_file(dir / "map.json",
             map.to_json().dump(1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");

  const std::vector<StoredWord> words = store.words();
  std::set<std::string> distinct;
  {
    std::ostringstream out;
    out << "robot_id,sequence_number,capture_time_ns,text,confidence,x,y,width,height\n";
    for (const StoredWord& w : words) {
      out << w.keyframe.robot_id << ',' << w.keyframe.sequence << ',' << w.capture_time_ns << ','
          << csv_cell(w.text) << ',' << w.confidence << ',' << w.box.x << ',' << w.box.y << ','
          << w.box.width << ',' << w.box.height << '\n';
      std::string upper;
      for (char c : w.text) upper += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
      distinct.insert(upper);
    }
    write_file(dir / "words.csv", out.str());
  }
  {
    std::ostringstream out;
    out << "robot_id,sequence_number,match_robot_id,match_sequence_number,matches,inliers,"
           "bow_score\n";
    for (const StoredPlaceMatch& m : store.place_matches()) {
      out << m.query.robot_id << ',' << m.query.sequence << ',' << m.match.robot_id << ','
          << m.match.sequence << ',' << m.matches << ',' << m.inliers << ',' << m.bow_score << '\n';
    }
    write_file(dir / "place_matches.csv", out.str());
  }
  std::ostringstream text;
  text << "Station analysis: " << summary.analysed << " keyframe(s) analysed";
  if (summary.deferred) text << ", " << summary.deferred << " deferred (analysed at next start)";
  if (summary.failed) text << ", " << summary.failed << " failed";
  text << "\n  words read: " << words.size() << " (" << distinct.size() << " distinct)";
  std::size_t shown = 0;
  for (const std::string& w : distinct) {
    text << (shown == 0 ? ": " : ", ") << w;
    if (++shown == 12) {
      if (distinct.size() > shown) text << ", ...";
      break;
    }
  }
  text << "\n  place matches: " << summary.place_matches << " (" << summary.cross_robot_matches
       << " across robots)\n  map: " << map.node_count() << " keyframes, "
       << map.edge_count(EdgeKind::kTemporal) << " temporal + "
       << map.edge_count(EdgeKind::kPlaceMatch) << " place edges -> map.graphml, map.json\n";
  return text.str();
}

}  // namespace keyfleet::station
