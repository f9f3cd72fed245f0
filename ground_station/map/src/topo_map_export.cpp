// GraphML and JSON exports of the topological map.
#include <boost/graph/graphml.hpp>
#include <boost/property_map/dynamic_property_map.hpp>
#include <boost/property_map/function_property_map.hpp>

#include <limits>

#include "keyfleet/station/map/topo_map.hpp"

namespace keyfleet::station {
namespace {

std::string join_words(const std::vector<std::string>& words) {
  std::string out;
  for (const auto& word : words) {
    if (!out.empty()) out += ' ';
    out += word;
  }
  return out;
}

}  // namespace

void TopoMap::write_graphml(std::ostream& out) const {
  using Vertex = Graph::vertex_descriptor;
  using Edge = Graph::edge_descriptor;
  const Graph& g = graph_;
  const auto vertex_map = [&g](auto get) {
    return boost::make_function_property_map<Vertex>([&g, get](Vertex v) { return get(g[v]); });
  };
  const auto edge_map = [&g](auto get) {
    return boost::make_function_property_map<Edge>([&g, get](Edge e) { return get(g[e]); });
  };
  // GraphML needs a value for every node, so an unknown pose is NaN plus has_pose = false.
  const auto coordinate = [](double Pose::*member) {
    return [member](const MapNode& n) {
      return n.pose ? (*n.pose).*member : std::numeric_limits<double>::quiet_NaN();
    };
  };

  boost::dynamic_properties dp;
  dp.property("robot", vertex_map([](const MapNode& n) { return n.robot_id; }));
  dp.property("sequence", vertex_map([](const MapNode& n) { return n.sequence; }));
  dp.property("time", vertex_map([](const MapNode& n) { return n.capture_time_ns; }));
  dp.property("has_pose", vertex_map([](const MapNode& n) { return n.pose.has_value(); }));
  dp.property("x", vertex_map(coordinate(&Pose::tx)));
  dp.property("y", vertex_map(coordinate(&Pose::ty)));
  dp.property("z", vertex_map(coordinate(&Pose::tz)));
  dp.property("words", vertex_map([](const MapNode& n) { return join_words(n.words); }));
  dp.property("kind", edge_map([](const MapEdge& e) { return std::string(to_string(e.kind)); }));
  dp.property("inliers", edge_map([](const MapEdge& e) { return e.link.inliers; }));
  dp.property("ratio", edge_map([](const MapEdge& e) { return e.link.inlier_ratio; }));
  dp.property("score", edge_map([](const MapEdge& e) { return e.link.bow_score; }));
  boost::write_graphml(out, g, dp, true);
}

nlohmann::json TopoMap::to_json() const {
  auto nodes = nlohmann::json::array();
  for (MapNodeId id = 0; id < node_count(); ++id) {
    const MapNode& n = graph_[id];
    nlohmann::json pose = nullptr;
    if (n.pose) {
      const Pose& p = *n.pose;
      pose = {{"tx", p.tx}, {"ty", p.ty}, {"tz", p.tz}, {"qx", p.qx},
              {"qy", p.qy}, {"qz", p.qz}, {"qw", p.qw}};
    }
    nodes.push_back({{"id", id},
                     {"robot", n.robot_id},
                     {"sequence", n.sequence},
                     {"capture_time_ns", n.capture_time_ns},
                     {"pose", pose},
                     {"words", n.words}});
  }
  auto edges = nlohmann::json::array();
  for (auto [it, end] = boost::edges(graph_); it != end; ++it) {
    const MapEdge& e = graph_[*it];
    nlohmann::json edge = {{"source", boost::source(*it, graph_)},
                           {"target", boost::target(*it, graph_)},
                           {"kind", to_string(e.kind)}};
    if (e.kind == EdgeKind::kPlaceMatch) {
      edge["inliers"] = e.link.inliers;
      edge["inlier_ratio"] = e.link.inlier_ratio;
      edge["bow_score"] = e.link.bow_score;
    }
    edges.push_back(std::move(edge));
  }
  return {{"nodes", std::move(nodes)}, {"edges", std::move(edges)}};
}

}  // namespace keyfleet::station
