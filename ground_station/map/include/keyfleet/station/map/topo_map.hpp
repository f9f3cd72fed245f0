#pragma once
// The fleet's shared topological map: one node per received keyframe, temporal edges
// between a robot's consecutive keyframes (by capture time), place-match edges from verified place
// recognition within and across robots. Not thread-safe: the owner serialises access.
#include <boost/graph/adjacency_list.hpp>
#include <nlohmann/json.hpp>

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <ostream>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "keyfleet/common/types.hpp"

namespace keyfleet::station {

using MapNodeId = std::size_t;

struct MapNode {
  std::string robot_id;
  std::uint64_t sequence = 0;
  std::int64_t capture_time_ns = 0;
  std::optional<Pose> pose;
  std::vector<std::string> words;  // as read; exact duplicates kept once
};

enum class EdgeKind { kTemporal, kPlaceMatch };

const char* to_string(EdgeKind kind);  // "temporal", "place_match"

struct PlaceLink {
  std::size_t inliers = 0;
  double inlier_ratio = 0;
  double bow_score = 0;
};

struct MapEdge {
  EdgeKind kind = EdgeKind::kTemporal;
  PlaceLink link;  // zero for temporal edges
};

class TopoMap {
 public:
  // Links the node temporally to its robot's neighbours in (capture time, sequence) order; a late
  // keyframe is spliced in (prev->new->next replaces prev->next). The same (robot, sequence) again
  // returns the existing node unchanged.
  MapNodeId add_keyframe(const MapNode& node);
  // Unknown ids are ignored (per-keyframe path).
  void add_words(MapNodeId id, const std::vector<std::string>& words);
  // False for a == b, unknown ids, or when the pair already has a place-match edge. A place match
  // may coexist with a temporal edge between the same two nodes.
  bool add_place_match(MapNodeId a, MapNodeId b, const PlaceLink& link);

  std::optional<MapNodeId> find(const std::string& robot_id, std::uint64_t sequence) const;
  const MapNode& node(MapNodeId id) const;  // throws std::out_of_range for an unknown id
  std::size_t node_count() const;
  std::size_t edge_count(EdgeKind kind) const;

  // Robots whose keyframes reach this one over at most max_place_hops place-match edges
  // (temporal edges are not followed), the node's own robot included; empty for an unknown id.
  std::set<std::string> robots_at_place(MapNodeId id, int max_place_hops = 2) const;
  // Case-insensitive (ASCII) exact word; ids ascending.
  std::vector<MapNodeId> nodes_with_word(const std::string& word) const;
  // Fewest edges from `from` to `to`, both included (Boost BFS: temporal and place-match edges
  // weigh 1 each); empty when unreachable or an id is unknown.
  std::vector<MapNodeId> shortest_path(MapNodeId from, MapNodeId to) const;
  // Each place-match edge once, as (smaller id, larger id), sorted.
  std::vector<std::pair<MapNodeId, MapNodeId>> place_matches() const;
  std::size_t cross_robot_match_count() const;

  // GraphML (boost::write_graphml). Node keys: robot (string), sequence (long), time (long, capture
  // ns), has_pose (boolean), x, y, z (double, translation; "nan" when the pose is unknown), words
  // (string, space-separated). Edge keys: kind ("temporal"/"place_match"), inliers (long), ratio,
  // score (double; 0 for temporal edges). Node ids are "n<MapNodeId>". Boost prints doubles with 6
  // significant digits and booleans as 1/0; to_json keeps full precision.
  void write_graphml(std::ostream& out) const;
  // {"nodes": [{"id", "robot", "sequence", "capture_time_ns",
  //             "pose": null | {"tx","ty","tz","qx","qy","qz","qw"}, "words": [..]}],
  //  "edges": [{"source", "target", "kind": "temporal"} |
  //            {"source", "target", "kind": "place_match", "inliers", "inlier_ratio",
  //            "bow_score"}]}
  // Temporal edges go from the earlier keyframe to the later one.
  nlohmann::json to_json() const;

 private:
  using Graph =
      boost::adjacency_list<boost::vecS, boost::vecS, boost::undirectedS, MapNode, MapEdge>;
  using TimeKey = std::pair<std::int64_t, std::uint64_t>;  // (capture time, sequence)

  bool valid(MapNodeId id) const { return id < boost::num_vertices(graph_); }
  void remove_temporal_edge(MapNodeId a, MapNodeId b);
  void index_words(MapNodeId id, const std::vector<std::string>& words);

  Graph graph_;
  std::map<std::pair<std::string, std::uint64_t>, MapNodeId> by_key_;
  std::map<std::string, std::map<TimeKey, MapNodeId>> timeline_;  // per robot
  std::map<std::string, std::set<MapNodeId>> word_index_;         // lower-cased word -> nodes
};

}  // namespace keyfleet::station
