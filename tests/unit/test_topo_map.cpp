// The topological map: temporal chains, place matches, queries and exports.
#include <gtest/gtest.h>

#include <boost/graph/adjacency_list.hpp>
#include <boost/graph/graphml.hpp>
#include <boost/property_map/dynamic_property_map.hpp>

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "keyfleet/station/map/topo_map.hpp"

namespace keyfleet::station {
namespace {

MapNode keyframe(const std::string& robot, std::uint64_t sequence,
                 std::vector<std::string> words = {}) {
  MapNode n;
  n.robot_id = robot;
  n.sequence = sequence;
  n.capture_time_ns = static_cast<std::int64_t>(sequence) * 1'000'000'000;
  n.words = std::move(words);
  return n;
}

// Temporal edges as (earlier sequence, later sequence) for one robot, from the JSON export.
std::set<std::pair<std::uint64_t, std::uint64_t>> temporal_pairs(const TopoMap& map) {
  std::set<std::pair<std::uint64_t, std::uint64_t>> pairs;
  const nlohmann::json exported = map.to_json();
  for (const auto& e : exported["edges"]) {
    if (e["kind"] != "temporal") continue;
    pairs.emplace(map.node(e["source"].get<MapNodeId>()).sequence,
                  map.node(e["target"].get<MapNodeId>()).sequence);
  }
  return pairs;
}

TEST(TopoMap, OutOfOrderArrivalStillGivesOneChainInCaptureOrder) {
  TopoMap map;
  // An outage: 3 and 4 arrive after 7, then 1 and 9 at the ends, 5 in the middle.
  for (std::uint64_t seq : {2, 6, 7, 3, 4, 1, 9, 5, 8}) map.add_keyframe(keyframe("r1", seq));
  EXPECT_EQ(map.node_count(), 9u);
  EXPECT_EQ(map.edge_count(EdgeKind::kTemporal), 8u);
  std::set<std::pair<std::uint64_t, std::uint64_t>> expected;
  for (std::uint64_t s = 1; s < 9; ++s) expected.emplace(s, s + 1);
  EXPECT_EQ(temporal_pairs(map), expected);
}

TEST(TopoMap, OrdersByCaptureTimeNotSequence) {
  TopoMap map;
  MapNode late = keyframe("r1", 1);
  late.capture_time_ns = 50;
  MapNode early = keyframe("r1", 2);
  early.capture_time_ns = 10;
  MapNode middle = keyframe("r1", 3);
  middle.capture_time_ns = 30;
  map.add_keyframe(late);
  map.add_keyframe(early);
  map.add_keyframe(middle);
  const std::set<std::pair<std::uint64_t, std::uint64_t>> expected{{2, 3}, {3, 1}};
  EXPECT_EQ(temporal_pairs(map), expected);
}

TEST(TopoMap, RobotsHaveSeparateChainsAndDuplicatesAreIgnored) {
  TopoMap map;
  const MapNodeId a = map.add_keyframe(keyframe("r1", 1));
  map.add_keyframe(keyframe("r2", 1));
  map.add_keyframe(keyframe("r1", 2));
  map.add_keyframe(keyframe("r2", 2));
  map.add_keyframe(keyframe("r2", 3));
  MapNode again = keyframe("r1", 1, {"EXIT"});
  again.capture_time_ns = 99'000'000'000;
  EXPECT_EQ(map.add_keyframe(again), a);
  EXPECT_EQ(map.node_count(), 5u);
  EXPECT_EQ(map.edge_count(EdgeKind::kTemporal), 3u);  // r1: 1, r2: 2
  EXPECT_TRUE(map.node(a).words.empty());
  EXPECT_EQ(map.find("r2", 3), MapNodeId{4});
  EXPECT_FALSE(map.find("r3", 1).has_value());
  EXPECT_FALSE(map.find("r1", 7).has_value());
  EXPECT_THROW(map.node(42), std::out_of_range);
}

TEST(TopoMap, PlaceMatchesWithinAndAcrossRobotsAreCountedOnce) {
  TopoMap map;
  const MapNodeId r1a = map.add_keyframe(keyframe("r1", 1));
  const MapNodeId r1b = map.add_keyframe(keyframe("r1", 2));
  const MapNodeId r1c = map.add_keyframe(keyframe("r1", 3));
  const MapNodeId r2a = map.add_keyframe(keyframe("r2", 1));
  const PlaceLink link{40, 0.5, 0.2};
  EXPECT_TRUE(map.add_place_match(r1c, r1a, link));  // loop closure within r1
  EXPECT_TRUE(map.add_place_match(r1b, r2a, link));
  EXPECT_TRUE(map.add_place_match(r1a, r1b, link));   // alongside their temporal edge
  EXPECT_FALSE(map.add_place_match(r2a, r1b, link));  // duplicate, either direction
  EXPECT_FALSE(map.add_place_match(r1a, r1a, link));
  EXPECT_FALSE(map.add_place_match(r1a, 99, link));
  EXPECT_EQ(map.edge_count(EdgeKind::kPlaceMatch), 3u);
  EXPECT_EQ(map.edge_count(EdgeKind::kTemporal), 2u);
  EXPECT_EQ(map.cross_robot_match_count(), 1u);
  const std::vector<std::pair<MapNodeId, MapNodeId>> expected{{r1a, r1b}, {r1a, r1c}, {r1b, r2a}};
  EXPECT_EQ(map.place_matches(), expected);
}

TEST(TopoMap, LateKeyframeKeepsPlaceMatchBetweenItsNeighbours) {
  TopoMap map;
  const MapNodeId first = map.add_keyframe(keyframe("r1", 1));
  const MapNodeId third = map.add_keyframe(keyframe("r1", 3));
  ASSERT_TRUE(map.add_place_match(first, third, {}));
  map.add_keyframe(keyframe("r1", 2));  // replaces the 1-3 temporal edge, not the place match
  EXPECT_EQ(map.edge_count(EdgeKind::kTemporal), 2u);
  EXPECT_EQ(map.edge_count(EdgeKind::kPlaceMatch), 1u);
  const std::set<std::pair<std::uint64_t, std::uint64_t>> expected{{1, 2}, {2, 3}};
  EXPECT_EQ(temporal_pairs(map), expected);
}

TEST(TopoMap, RobotsAtPlaceFollowsPlaceMatchesUpToTheHopLimit) {
  TopoMap map;
  const MapNodeId a = map.add_keyframe(keyframe("r1", 1));
  const MapNodeId b = map.add_keyframe(keyframe("r2", 1));
  const MapNodeId c = map.add_keyframe(keyframe("r3", 1));
  const MapNodeId d = map.add_keyframe(keyframe("r4", 1));
  map.add_keyframe(keyframe("r1", 2));  // temporal neighbour of a: not a place hop
  const MapNodeId e = map.add_keyframe(keyframe("r5", 1));
  map.add_place_match(a, b, {});
  map.add_place_match(b, c, {});
  map.add_place_match(c, d, {});
  map.add_place_match(*map.find("r1", 2), e, {});
  EXPECT_EQ(map.robots_at_place(a, 0), (std::set<std::string>{"r1"}));
  EXPECT_EQ(map.robots_at_place(a, 1), (std::set<std::string>{"r1", "r2"}));
  EXPECT_EQ(map.robots_at_place(a), (std::set<std::string>{"r1", "r2", "r3"}));
  EXPECT_EQ(map.robots_at_place(a, 5), (std::set<std::string>{"r1", "r2", "r3", "r4"}));
  EXPECT_EQ(map.robots_at_place(c, 1), (std::set<std::string>{"r2", "r3", "r4"}));
  EXPECT_TRUE(map.robots_at_place(99).empty());
}

TEST(TopoMap, WordsQueryIsCaseInsensitiveAndExact) {
  TopoMap map;
  const MapNodeId a = map.add_keyframe(keyframe("r1", 1, {"EXIT", "Lab"}));
  const MapNodeId b = map.add_keyframe(keyframe("r2", 1));
  map.add_words(b, {"exit", "EXITS", "exit"});
  map.add_words(77, {"exit"});  // unknown id: ignored
  EXPECT_EQ(map.nodes_with_word("Exit"), (std::vector<MapNodeId>{a, b}));
  EXPECT_EQ(map.nodes_with_word("exits"), (std::vector<MapNodeId>{b}));
  EXPECT_EQ(map.nodes_with_word("lab"), (std::vector<MapNodeId>{a}));
  EXPECT_TRUE(map.nodes_with_word("ex").empty());
  EXPECT_EQ(map.node(b).words, (std::vector<std::string>{"exit", "EXITS"}));
}

TEST(TopoMap, ShortestPathCrossesRobotsThroughAPlaceMatch) {
  TopoMap map;
  for (std::uint64_t s = 1; s <= 5; ++s) map.add_keyframe(keyframe("r1", s));
  for (std::uint64_t s = 1; s <= 5; ++s) map.add_keyframe(keyframe("r2", s));
  const MapNodeId island = map.add_keyframe(keyframe("r3", 1));
  const MapNodeId r1_4 = *map.find("r1", 4);
  const MapNodeId r2_2 = *map.find("r2", 2);
  map.add_place_match(r1_4, r2_2, {});
  const MapNodeId from = *map.find("r1", 5);
  const MapNodeId to = *map.find("r2", 1);
  EXPECT_EQ(map.shortest_path(from, to), (std::vector<MapNodeId>{from, r1_4, r2_2, to}));
  EXPECT_EQ(map.shortest_path(from, from), (std::vector<MapNodeId>{from}));
  EXPECT_TRUE(map.shortest_path(from, island).empty());
  EXPECT_TRUE(map.shortest_path(from, 1000).empty());
}

// A graph of plain strings and numbers to read the GraphML back into.
struct ReadNode {
  std::string robot, words;
  long sequence = 0, time = 0;
  bool has_pose = false;
  double x = 0, y = 0, z = 0;
};
struct ReadEdge {
  std::string kind;
  long inliers = 0;
  double ratio = 0, score = 0;
};

TopoMap two_robot_map() {
  TopoMap map;
  MapNode posed = keyframe("r1", 1, {"EXIT", "Room <12> & co"});
  posed.pose = Pose{1.5, -2.25, 3.0};
  map.add_keyframe(posed);
  map.add_keyframe(keyframe("r1", 2));
  map.add_keyframe(keyframe("r2", 7));
  map.add_place_match(0, 2, {42, 0.375, 0.125});
  return map;
}

TEST(TopoMap, GraphmlReadsBackWithCountsAndAttributes) {
  const TopoMap map = two_robot_map();
  std::stringstream xml;
  map.write_graphml(xml);

  boost::adjacency_list<boost::vecS, boost::vecS, boost::undirectedS, ReadNode, ReadEdge> g;
  boost::dynamic_properties dp(boost::ignore_other_properties);
  dp.property("robot", boost::get(&ReadNode::robot, g));
  dp.property("words", boost::get(&ReadNode::words, g));
  dp.property("sequence", boost::get(&ReadNode::sequence, g));
  dp.property("time", boost::get(&ReadNode::time, g));
  dp.property("has_pose", boost::get(&ReadNode::has_pose, g));
  dp.property("x", boost::get(&ReadNode::x, g));
  dp.property("y", boost::get(&ReadNode::y, g));
  dp.property("z", boost::get(&ReadNode::z, g));
  dp.property("kind", boost::get(&ReadEdge::kind, g));
  dp.property("inliers", boost::get(&ReadEdge::inliers, g));
  dp.property("ratio", boost::get(&ReadEdge::ratio, g));
  dp.property("score", boost::get(&ReadEdge::score, g));
  ASSERT_NO_THROW(boost::read_graphml(xml, g, dp));

  ASSERT_EQ(boost::num_vertices(g), 3u);
  ASSERT_EQ(boost::num_edges(g), 2u);
  EXPECT_EQ(g[0].robot, "r1");
  EXPECT_EQ(g[0].words, "EXIT Room <12> & co");
  EXPECT_EQ(g[0].sequence, 1);
  EXPECT_EQ(g[0].time, 1'000'000'000);
  EXPECT_TRUE(g[0].has_pose);
  EXPECT_DOUBLE_EQ(g[0].x, 1.5);
  EXPECT_DOUBLE_EQ(g[0].y, -2.25);
  EXPECT_DOUBLE_EQ(g[0].z, 3.0);
  EXPECT_EQ(g[2].robot, "r2");
  EXPECT_EQ(g[2].sequence, 7);
  EXPECT_FALSE(g[2].has_pose);
  EXPECT_TRUE(std::isnan(g[2].x));

  int temporal = 0, place = 0;
  for (auto [it, end] = boost::edges(g); it != end; ++it) {
    const ReadEdge& e = g[*it];
    const std::size_t a = boost::source(*it, g);
    const std::size_t b = boost::target(*it, g);
    const auto ends = std::make_pair(std::min(a, b), std::max(a, b));
    if (e.kind == "temporal") {
      ++temporal;
      EXPECT_EQ(ends, std::make_pair(std::size_t{0}, std::size_t{1}));
    } else if (e.kind == "place_match") {
      ++place;
      EXPECT_EQ(ends, std::make_pair(std::size_t{0}, std::size_t{2}));
      EXPECT_EQ(e.inliers, 42);
      EXPECT_DOUBLE_EQ(e.ratio, 0.375);
      EXPECT_DOUBLE_EQ(e.score, 0.125);
    }
  }
  EXPECT_EQ(temporal, 1);
  EXPECT_EQ(place, 1);
}

TEST(TopoMap, JsonHasDocumentedShape) {
  const nlohmann::json j = two_robot_map().to_json();
  ASSERT_EQ(j["nodes"].size(), 3u);
  ASSERT_EQ(j["edges"].size(), 2u);
  const auto& n0 = j["nodes"][0];
  EXPECT_EQ(n0["id"], 0);
  EXPECT_EQ(n0["robot"], "r1");
  EXPECT_EQ(n0["sequence"], 1);
  EXPECT_EQ(n0["capture_time_ns"], 1'000'000'000);
  EXPECT_DOUBLE_EQ(n0["pose"]["ty"].get<double>(), -2.25);
  EXPECT_DOUBLE_EQ(n0["pose"]["qw"].get<double>(), 1.0);
  EXPECT_EQ(n0["words"], (nlohmann::json{"EXIT", "Room <12> & co"}));
  EXPECT_TRUE(j["nodes"][1]["pose"].is_null());
  EXPECT_TRUE(j["nodes"][1]["words"].is_array());

  const auto place = std::find_if(j["edges"].begin(), j["edges"].end(),
                                  [](const auto& e) { return e["kind"] == "place_match"; });
  ASSERT_NE(place, j["edges"].end());
  EXPECT_EQ((*place)["inliers"], 42);
  EXPECT_DOUBLE_EQ((*place)["inlier_ratio"].get<double>(), 0.375);
  EXPECT_DOUBLE_EQ((*place)["bow_score"].get<double>(), 0.125);
  const auto temporal = std::find_if(j["edges"].begin(), j["edges"].end(),
                                     [](const auto& e) { return e["kind"] == "temporal"; });
  ASSERT_NE(temporal, j["edges"].end());
  EXPECT_EQ((*temporal)["source"], 0);
  EXPECT_EQ((*temporal)["target"], 1);
  EXPECT_FALSE(temporal->contains("inliers"));
}

}  // namespace
}  // namespace keyfleet::station
