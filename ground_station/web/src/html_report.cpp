#include "keyfleet/station/web/html_report.hpp"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <filesystem>
#include <map>
#include <set>
#include <sstream>

#include "keyfleet/common/file_output.hpp"
#include "keyfleet/common/scenario_truth.hpp"
#include "keyfleet/station/web/figures.hpp"
#include "keyfleet/station/web/run_view.hpp"

namespace keyfleet::station::web {
namespace {

constexpr int kThumbnailWidth = 320;

constexpr const char* kStyle = R"css(
body { font-family: sans-serif; margin: 1.5em; color: #222; }
pre { background: #f6f6f6; padding: .8em; overflow-x: auto; font-size: 12px; }
.plot { max-width: 900px; width: 100%; border: 1px solid #ddd; }
.sheet { display: flex; flex-wrap: wrap; gap: 8px; }
figure.kf { margin: 0; width: 240px; font-size: 11px; }
figure.kf svg { width: 100%; display: block; }
rect.word { fill: none; stroke: #ff0; stroke-width: 2px; vector-effect: non-scaling-stroke; }
.hit { color: #2ca02c; font-weight: bold; } .miss { color: #999; }
)css";

// The frame's words fully in view (legible, not cut or occluded), per robot and frame index.
using Truth = std::map<std::string, std::map<std::uint64_t, std::vector<std::string>>>;

Truth read_truth(const std::string& scenario_dir) {
  Truth truth;
  if (scenario_dir.empty()) return truth;
  const scenario::Scenario s = scenario::read_scenario(scenario_dir);
  for (const auto& drone : s.drones) {
    auto& frames = truth[drone.robot_id];
    const auto dir = (std::filesystem::path(scenario_dir) / drone.folder).string();
    for (const scenario::FrameTruth& f : scenario::read_frame_truth(dir)) {
      std::set<std::string> seen;
      for (const auto& w : f.words)
        if (w.legible && w.visibility == scenario::WordVisibility::kFull &&
            seen.insert(w.text).second)
          frames[f.index].push_back(w.text);
    }
  }
  return truth;
}

// A smaller JPEG as a data URI; the word boxes stay in the keyframe's own pixels (the SVG's
// viewBox), so they need no rescaling.
std::string thumbnail_uri(const std::vector<std::uint8_t>& jpeg) {
  const cv::Mat image = cv::imdecode(jpeg, cv::IMREAD_COLOR);
  if (image.empty()) return "";
  cv::Mat small = image;
  if (image.cols > kThumbnailWidth)
    cv::resize(image, small, cv::Size(kThumbnailWidth, image.rows * kThumbnailWidth / image.cols),
               0, 0, cv::INTER_AREA);
  std::vector<unsigned char> out;
  cv::imencode(".jpg", small, out, {cv::IMWRITE_JPEG_QUALITY, 75});
  return "data:image/jpeg;base64," + base64(out);
}

}  // namespace

std::string base64(const std::vector<unsigned char>& bytes) {
  static const char* kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    const std::size_t n = std::min<std::size_t>(3, bytes.size() - i);
    std::uint32_t v = std::uint32_t(bytes[i]) << 16;
    if (n > 1) v |= std::uint32_t(bytes[i + 1]) << 8;
    if (n > 2) v |= bytes[i + 2];
    for (std::size_t k = 0; k < 4; ++k) out += k <= n ? kAlphabet[(v >> (18 - 6 * k)) & 63] : '=';
  }
  return out;
}

void write_html_report(const HtmlReportInputs& in, const std::string& path) {
  const RunView view(in.database);
  const Truth truth = read_truth(in.scenario_dir);
  std::ostringstream html;
  html << "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>keyfleet report "
       << html_escape(in.title) << "</title><style>" << kStyle << "</style></head><body>"
       << "<h1>keyfleet run " << html_escape(in.title) << "</h1>"
       << "<h2>Numbers</h2><pre>" << html_escape(in.text_report) << "</pre>"
       << "<h2>Bytes over time</h2><p>Cumulative bytes per robot: received by the station "
          "against streaming every frame and sending every V-SLAM keyframe (as each robot "
          "counted them).</p>"
       << bandwidth_svg(view.bandwidth_timeline()) << "<h2>Map</h2><p>Keyframes at their "
       << "camera pose" << (in.scenario_dir.empty() ? "" : " (the scenario's true pose)")
       << ", each robot's keyframes linked in time, verified place matches dashed.</p>"
       << map_svg(view.map()) << "<h2>Keyframes</h2>";
  if (!truth.empty())
    html << "<p>Under each keyframe: the words read, and the words fully in view by the "
            "scenario's ground truth (<span class=\"hit\">read</span>, <span "
            "class=\"miss\">not read</span>).</p>";
  std::vector<KeyframeCard> cards = view.keyframes("", 0);
  std::stable_sort(cards.begin(), cards.end(), [](const auto& a, const auto& b) {
    return std::tie(a.info.robot_id, a.info.capture_time_ns) <
           std::tie(b.info.robot_id, b.info.capture_time_ns);
  });
  std::string robot;
  for (const KeyframeCard& card : cards) {
    if (card.info.robot_id != robot) {
      html << (robot.empty() ? "" : "</div>") << "<h3>" << html_escape(card.info.robot_id)
           << "</h3><div class=\"sheet\">";
      robot = card.info.robot_id;
    }
    const auto jpeg = view.jpeg({card.info.robot_id, card.info.sequence});
    const std::vector<std::string>* words = nullptr;
    if (auto r = truth.find(robot); r != truth.end()) {
      static const std::vector<std::string> kNone;
      const auto f = r->second.find(card.info.frame_index);
      words = f == r->second.end() ? &kNone : &f->second;
    }
    html << keyframe_figure(card, jpeg ? thumbnail_uri(*jpeg) : "", words);
  }
  html << (robot.empty() ? "<p>No keyframes were stored.</p>" : "</div>") << "</body></html>\n";
  write_file(path, html.str());
}

}  // namespace keyfleet::station::web
