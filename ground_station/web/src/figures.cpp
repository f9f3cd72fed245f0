#include "keyfleet/station/web/figures.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <set>
#include <sstream>

namespace keyfleet::station::web {
namespace {

constexpr const char* kRobotColours[] = {"#1f77b4", "#2ca02c", "#9467bd", "#8c564b",
                                         "#e377c2", "#17becf", "#bcbd22", "#7f7f7f"};

std::string colour_of(const std::map<std::string, std::size_t>& order, const std::string& robot) {
  const auto it = order.find(robot);
  const std::size_t i = it == order.end() ? 0 : it->second;
  return kRobotColours[i % (sizeof kRobotColours / sizeof *kRobotColours)];
}

std::string num(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f", v);
  return text;
}

std::string upper(std::string text) {
  for (char& c : text) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return text;
}

std::string seconds_label(std::int64_t ns) {
  char text[32];
  std::snprintf(text, sizeof text, "t+%.1f s", double(ns) * 1e-9);
  return text;
}

// A linear map from [lo, hi] onto [a, b].
struct Axis {
  double lo = 0, hi = 1, a = 0, b = 1;
  double operator()(double v) const { return a + (v - lo) / (hi - lo) * (b - a); }
};

}  // namespace

std::string html_escape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string keyframe_figure(const KeyframeCard& card, const std::string& image_href,
                            const std::vector<std::string>* truth) {
  const StoredKeyframeInfo& k = card.info;
  const std::string key = k.robot_id + "#" + std::to_string(k.sequence);
  std::ostringstream out;
  out << "<figure class=\"kf\" data-key=\"" << html_escape(key) << "\"><svg viewBox=\"0 0 "
      << k.width << ' ' << k.height << "\" role=\"img\" aria-label=\"keyframe " << html_escape(key)
      << "\"><image href=\"" << html_escape(image_href) << "\" width=\"" << k.width
      << "\" height=\"" << k.height << "\"/>";
  std::set<std::string> read;
  for (const StoredWord& w : card.words) {
    read.insert(upper(w.text));
    out << "<rect class=\"word\" x=\"" << w.box.x << "\" y=\"" << w.box.y << "\" width=\""
        << w.box.width << "\" height=\"" << w.box.height << "\"><title>" << html_escape(w.text)
        << "</title></rect>";
  }
  out << "</svg><figcaption><b>" << html_escape(key) << "</b> " << seconds_label(k.capture_time_ns)
      << "<br>read:";
  if (card.words.empty()) out << " &ndash;";
  for (const StoredWord& w : card.words)
    out << " <span class=\"read\">" << html_escape(w.text) << "</span>";
  if (truth) {
    out << "<br>truth:";
    if (truth->empty()) out << " &ndash;";
    for (const std::string& t : *truth)
      out << " <span class=\"" << (read.count(upper(t)) ? "hit" : "miss") << "\">" << html_escape(t)
          << "</span>";
  }
  out << "</figcaption></figure>";
  return out.str();
}

std::string bandwidth_svg(const std::vector<BandwidthSeries>& series) {
  constexpr double kWidth = 640, kPanel = 150, kLeft = 60, kRight = 10, kTop = 18, kBottom = 24;
  std::int64_t t0 = std::numeric_limits<std::int64_t>::max(), t1 = 0;
  std::uint64_t top = 1;
  for (const auto& s : series) {
    for (const auto* points : {&s.received, &s.stream_all, &s.vslam_keyframes}) {
      for (const BandwidthPoint& p : *points) {
        t0 = std::min(t0, p.time_ns);
        t1 = std::max(t1, p.time_ns);
        top = std::max(top, p.bytes);
      }
    }
  }
  const double height = kPanel * double(std::max<std::size_t>(series.size(), 1));
  std::ostringstream out;
  out << "<svg class=\"plot\" xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 " << kWidth << ' '
      << height << "\" font-size=\"11\">";
  if (series.empty()) return out.str() + "<text x=\"10\" y=\"20\">no keyframes yet</text></svg>";
  const double span_s = std::max(1.0, double(t1 - t0) * 1e-9);
  const int top_decade = std::max(4, int(std::ceil(std::log10(double(top)))));
  const int low_decade = std::min(3, top_decade - 1);
  for (std::size_t i = 0; i < series.size(); ++i) {
    const double y0 = double(i) * kPanel;
    const Axis x{0, span_s, kLeft, kWidth - kRight};
    const Axis y{double(low_decade), double(top_decade), y0 + kPanel - kBottom, y0 + kTop};
    out << "<text x=\"" << kLeft << "\" y=\"" << y0 + 12 << "\" font-weight=\"bold\">"
        << html_escape(series[i].robot_id) << "</text>";
    for (int d = low_decade; d <= top_decade; ++d) {
      out << "<line x1=\"" << kLeft << "\" x2=\"" << kWidth - kRight << "\" y1=\"" << num(y(d))
          << "\" y2=\"" << num(y(d)) << "\" stroke=\"#ddd\"/><text x=\"" << kLeft - 4 << "\" y=\""
          << num(y(d) + 4) << "\" text-anchor=\"end\">1e" << d << " B</text>";
    }
    out << "<text x=\"" << kWidth - kRight << "\" y=\"" << y0 + kPanel - 8
        << "\" text-anchor=\"end\">" << num(span_s) << " s</text>";
    auto line = [&](const std::vector<BandwidthPoint>& points, const char* style) {
      if (points.empty()) return;
      out << "<polyline fill=\"none\" " << style << " points=\"";
      for (const BandwidthPoint& p : points) {
        const double decades = std::log10(std::max<double>(double(p.bytes), 1.0));
        out << num(x(double(p.time_ns - t0) * 1e-9)) << ','
            << num(y(std::max<double>(decades, low_decade))) << ' ';
      }
      out << "\"/>";
    };
    line(series[i].stream_all, "stroke=\"#d62728\" stroke-dasharray=\"6 3\"");
    line(series[i].vslam_keyframes, "stroke=\"#ff7f0e\" stroke-dasharray=\"2 2\"");
    line(series[i].received, "stroke=\"#1f77b4\" stroke-width=\"2\"");
  }
  out << "<g transform=\"translate(" << kWidth - 330
      << ",4)\"><text x=\"0\" y=\"10\" "
         "fill=\"#1f77b4\">&#9473; received</text><text x=\"90\" y=\"10\" fill=\"#d62728\">"
         "- - stream-all</text><text x=\"190\" y=\"10\" fill=\"#ff7f0e\">&#183;&#183; every "
         "V-SLAM kf</text></g></svg>";
  return out.str();
}

std::string map_svg(const nlohmann::json& map) {
  constexpr double kWidth = 640, kPad = 20;
  const auto& nodes = map.at("nodes");
  std::map<std::string, std::size_t> order;
  for (const auto& n : nodes) order.emplace(n.at("robot").get<std::string>(), 0);
  std::size_t next = 0;
  for (auto& [robot, i] : order) i = next++;
  const bool by_pose = !nodes.empty() && std::all_of(nodes.begin(), nodes.end(), [](const auto& n) {
    return !n.at("pose").is_null();
  });
  // Where: (along, across) in metres by pose, else (capture time, robot lane).
  std::map<std::int64_t, std::pair<double, double>> at;
  for (const auto& n : nodes) {
    const std::int64_t id = n.at("id").get<std::int64_t>();
    if (by_pose)
      at[id] = {n["pose"]["tx"].get<double>(), -n["pose"]["ty"].get<double>()};
    else
      at[id] = {double(n.at("capture_time_ns").get<std::int64_t>()) * 1e-9,
                double(order[n.at("robot").get<std::string>()])};
  }
  double x0 = 0, x1 = 1, y0 = 0, y1 = 1;
  if (!at.empty()) {
    x0 = y0 = std::numeric_limits<double>::max();
    x1 = y1 = std::numeric_limits<double>::lowest();
    for (const auto& [id, p] : at) {
      x0 = std::min(x0, p.first), x1 = std::max(x1, p.first);
      y0 = std::min(y0, p.second), y1 = std::max(y1, p.second);
    }
  }
  // The same scale on both axes while the drawing stays 100..280 px high; a narrower map is
  // stretched across to 100 px, a taller one squeezed to 280.
  const double xr = std::max(x1 - x0, 1e-6);
  const double along = (kWidth - 2 * kPad) / xr;  // px per unit
  const double inner = std::clamp((y1 - y0) * along, 100.0, 280.0);
  const double kHeight = inner + 2 * kPad;
  const double yr = std::max(y1 - y0, inner / along);
  const double ym = (y0 + y1) / 2;
  const Axis x{x0, x0 + xr, kPad, kWidth - kPad};
  const Axis y{ym - yr / 2, ym + yr / 2, kPad, kHeight - kPad};
  std::ostringstream out;
  out << "<svg class=\"plot\" xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 " << kWidth << ' '
      << kHeight + 20 << "\" font-size=\"11\">";
  std::map<std::int64_t, std::string> robot_of;
  for (const auto& n : nodes) robot_of[n.at("id").get<std::int64_t>()] = n.at("robot");
  std::size_t place_edges = 0;
  for (const auto& e : map.at("edges")) {
    const auto a = at.find(e.at("source").get<std::int64_t>());
    const auto b = at.find(e.at("target").get<std::int64_t>());
    if (a == at.end() || b == at.end()) continue;
    const bool place = e.at("kind") == "place_match";
    place_edges += place;
    out << "<line x1=\"" << num(x(a->second.first)) << "\" y1=\"" << num(y(a->second.second))
        << "\" x2=\"" << num(x(b->second.first)) << "\" y2=\"" << num(y(b->second.second)) << "\" "
        << (place
                ? std::string("class=\"place\" stroke=\"#d62728\" stroke-dasharray=\"4 2\"")
                : "stroke=\"" + colour_of(order, robot_of[a->first]) + "\" stroke-opacity=\"0.6\"")
        << "/>";
  }
  for (const auto& n : nodes) {
    const auto& p = at[n.at("id").get<std::int64_t>()];
    std::string words;
    for (const auto& w : n.at("words")) words += " " + w.get<std::string>();
    out << "<circle class=\"node\" cx=\"" << num(x(p.first)) << "\" cy=\"" << num(y(p.second))
        << "\" r=\"4\" fill=\"" << colour_of(order, n.at("robot")) << "\"><title>"
        << html_escape(n.at("robot").get<std::string>() + "#" +
                       std::to_string(n.at("sequence").get<std::uint64_t>()) + words)
        << "</title></circle>";
  }
  double legend_x = kPad;
  for (const auto& [robot, i] : order) {
    out << "<text x=\"" << num(legend_x) << "\" y=\"" << kHeight + 14 << "\" fill=\""
        << colour_of(order, robot) << "\">&#9679; " << html_escape(robot) << "</text>";
    legend_x += 90;
  }
  out << "<text x=\"" << num(legend_x) << "\" y=\"" << kHeight + 14 << "\" fill=\"#d62728\">- - "
      << place_edges << " place match(es); "
      << (by_pose ? "placed by pose (x along, y across)" : "no poses: robot lanes by time")
      << "</text></svg>";
  return out.str();
}

}  // namespace keyfleet::station::web
