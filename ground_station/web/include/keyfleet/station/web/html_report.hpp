#pragma once
#include <string>
#include <vector>

namespace keyfleet::station::web {

struct HtmlReportInputs {
  std::string title;         // e.g. the mission's run folder name
  std::string database;      // the station's station.sqlite (opened read-only)
  std::string scenario_dir;  // the generated scenario the run replayed; empty = no ground truth
  std::string text_report;   // the station's report.txt, shown as it is
};

// Writes a self-contained report.html to `path` (images inlined as data URIs, plots as inline
// SVG): the text report's numbers, bytes over time against the two baselines, the map by pose
// with place matches, and a contact sheet of every robot's keyframes with the words read (and
// the words fully in view, from the scenario's ground truth). Throws std::runtime_error.
void write_html_report(const HtmlReportInputs& inputs, const std::string& path);

// RFC 4648 base64 (for data URIs).
std::string base64(const std::vector<unsigned char>& bytes);

}  // namespace keyfleet::station::web
