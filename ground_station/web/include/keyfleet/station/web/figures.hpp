#pragma once
// The pictures of a run as SVG/HTML text, drawn once here for both the live dashboard (served
// as they are) and report.html (inlined).
#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "keyfleet/station/bandwidth_report.hpp"
#include "keyfleet/station/web/run_view.hpp"

namespace keyfleet::station::web {

std::string html_escape(const std::string& text);

// A keyframe thumbnail (`image_href`: a URL or a data: URI) with each word read boxed, and a
// caption naming it and its words; `truth` (the words fully in view when the run replayed a
// generated scenario) is added to the caption when given, the words read in it marked.
std::string keyframe_figure(const KeyframeCard& card, const std::string& image_href,
                            const std::vector<std::string>* truth = nullptr);

// Cumulative bytes over time, one panel per robot: received against stream-all and every
// V-SLAM keyframe (log scale).
std::string bandwidth_svg(const std::vector<BandwidthSeries>& series);

// The topological map (TopoMap::to_json): keyframes at their pose (x along, y across; or in
// robot lanes by time where no keyframe has a pose), temporal edges per robot, place matches.
std::string map_svg(const nlohmann::json& map);

}  // namespace keyfleet::station::web
