#include "keyfleet/station/map/topo_map.hpp"

#include <boost/graph/breadth_first_search.hpp>
#include <boost/graph/visitors.hpp>

#include <algorithm>
#include <cctype>
#include <deque>
#include <stdexcept>

namespace keyfleet::station {
namespace {

std::string lower(const std::string& word) {
  std::string out = word;
  std::transform(out.begin(), out.end(), out.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return out;
}

}  // namespace

const char* to_string(EdgeKind kind) {
  switch (kind) {
    case EdgeKind::kTemporal: return "temporal";
    case EdgeKind::kPlaceMatch: return "place_match";
  }
  return "unknown";
}

MapNodeId TopoMap::add_keyframe(const MapNode& node) {
  const auto key = std::make_pair(node.robot_id, node.sequence);
  if (auto it = by_key_.find(key); it != by_key_.end()) return it->second;

  MapNode stored = node;
  stored.words.clear();
  const MapNodeId id = boost::add_vertex(stored, graph_);
  by_key_.emplace(key, id);
  add_words(id, node.words);

  auto& line = timeline_[node.robot_id];
  const auto [pos, inserted] = line.emplace(TimeKey{node.capture_time_ns, node.sequence}, id);
  (void)inserted;  // (time, sequence) is unique because (robot, sequence) is new
  const bool has_prev = pos != line.begin();
  const bool has_next = std::next(pos) != line.end();
  const MapNodeId prev = has_prev ? std::prev(pos)->second : id;
  const MapNodeId next = has_next ? std::next(pos)->second : id;
  if (has_prev && has_next) remove_temporal_edge(prev, next);
  // Source is always the earlier keyframe, so exports read in capture order.
  if (has_prev) boost::add_edge(prev, id, MapEdge{EdgeKind::kTemporal, {}}, graph_);
  if (has_next) boost::add_edge(id, next, MapEdge{EdgeKind::kTemporal, {}}, graph_);
  return id;
}

void TopoMap::remove_temporal_edge(MapNodeId a, MapNodeId b) {
  for (auto [it, end] = boost::out_edges(a, graph_); it != end; ++it) {
    if (boost::target(*it, graph_) == b && graph_[*it].kind == EdgeKind::kTemporal) {
      boost::remove_edge(*it, graph_);
      return;
    }
  }
}

void TopoMap::add_words(MapNodeId id, const std::vector<std::string>& words) {
  if (!valid(id)) return;
  auto& stored = graph_[id].words;
  for (const auto& word : words) {
    if (word.empty() || std::find(stored.begin(), stored.end(), word) != stored.end()) continue;
    stored.push_back(word);
    word_index_[lower(word)].insert(id);
  }
}

bool TopoMap::add_place_match(MapNodeId a, MapNodeId b, const PlaceLink& link) {
  if (a == b || !valid(a) || !valid(b)) return false;
  for (auto [it, end] = boost::out_edges(a, graph_); it != end; ++it) {
    if (boost::target(*it, graph_) == b && graph_[*it].kind == EdgeKind::kPlaceMatch) return false;
  }
  boost::add_edge(a, b, MapEdge{EdgeKind::kPlaceMatch, link}, graph_);
  return true;
}

std::optional<MapNodeId> TopoMap::find(const std::string& robot_id, std::uint64_t sequence) const {
  const auto it = by_key_.find({robot_id, sequence});
  if (it == by_key_.end()) return std::nullopt;
  return it->second;
}

const MapNode& TopoMap::node(MapNodeId id) const {
  if (!valid(id)) throw std::out_of_range("TopoMap: no node " + std::to_string(id));
  return graph_[id];
}

std::size_t TopoMap::node_count() const { return boost::num_vertices(graph_); }

std::size_t TopoMap::edge_count(EdgeKind kind) const {
  const auto [begin, end] = boost::edges(graph_);
  return static_cast<std::size_t>(
      std::count_if(begin, end, [&](const auto& e) { return graph_[e].kind == kind; }));
}

std::set<std::string> TopoMap::robots_at_place(MapNodeId id, int max_place_hops) const {
  if (!valid(id)) return {};
  // A hop-limited BFS over place-match edges only; Boost's BFS has no depth limit or edge filter.
  std::vector<int> depth(node_count(), -1);
  std::deque<MapNodeId> queue{id};
  depth[id] = 0;
  std::set<std::string> robots;
  while (!queue.empty()) {
    const MapNodeId u = queue.front();
    queue.pop_front();
    robots.insert(graph_[u].robot_id);
    if (depth[u] >= max_place_hops) continue;
    for (auto [it, end] = boost::out_edges(u, graph_); it != end; ++it) {
      const MapNodeId v = boost::target(*it, graph_);
      if (graph_[*it].kind != EdgeKind::kPlaceMatch || depth[v] >= 0) continue;
      depth[v] = depth[u] + 1;
      queue.push_back(v);
    }
  }
  return robots;
}

std::vector<MapNodeId> TopoMap::nodes_with_word(const std::string& word) const {
  const auto it = word_index_.find(lower(word));
  if (it == word_index_.end()) return {};
  return {it->second.begin(), it->second.end()};
}

std::vector<MapNodeId> TopoMap::shortest_path(MapNodeId from, MapNodeId to) const {
  if (!valid(from) || !valid(to)) return {};
  const std::size_t none = node_count();
  std::vector<MapNodeId> parent(node_count(), none);
  parent[from] = from;
  boost::breadth_first_search(graph_, from,
                              boost::visitor(boost::make_bfs_visitor(boost::record_predecessors(
                                  boost::make_iterator_property_map(
                                      parent.begin(), boost::get(boost::vertex_index, graph_)),
                                  boost::on_tree_edge()))));
  if (parent[to] == none) return {};
  std::vector<MapNodeId> path{to};
  while (path.back() != from) path.push_back(parent[path.back()]);
  std::reverse(path.begin(), path.end());
  return path;
}

std::vector<std::pair<MapNodeId, MapNodeId>> TopoMap::place_matches() const {
  std::vector<std::pair<MapNodeId, MapNodeId>> pairs;
  for (auto [it, end] = boost::edges(graph_); it != end; ++it) {
    if (graph_[*it].kind != EdgeKind::kPlaceMatch) continue;
    const MapNodeId a = boost::source(*it, graph_);
    const MapNodeId b = boost::target(*it, graph_);
    pairs.emplace_back(std::min(a, b), std::max(a, b));
  }
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

std::size_t TopoMap::cross_robot_match_count() const {
  std::size_t count = 0;
  for (const auto& [a, b] : place_matches()) {
    if (graph_[a].robot_id != graph_[b].robot_id) ++count;
  }
  return count;
}

}  // namespace keyfleet::station
