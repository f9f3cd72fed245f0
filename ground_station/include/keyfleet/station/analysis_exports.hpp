#pragma once
#include <string>

#include "keyfleet/station/analysis_store.hpp"
#include "keyfleet/station/map/topo_map.hpp"
#include "keyfleet/station/station_analysis.hpp"

namespace keyfleet::station {

// Writes what data tools read directly into `run_dir`: map.graphml, map.json, words.csv,
// place_matches.csv. Returns a short text summary for the report.
// `text` as one CSV cell: quoted, quotes doubled, and a leading = + - @ tab or CR neutralised
// with an apostrophe so that a spreadsheet shows it rather than evaluates it.
std::string csv_cell(const std::string& text);

std::string write_analysis_exports(const AnalysisStore& store, const TopoMap& map,
                                   const StationAnalysis::Summary& summary,
                                   const std::string& run_dir);

}  // namespace keyfleet::station
