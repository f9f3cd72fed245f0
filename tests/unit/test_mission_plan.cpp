// A mission's plan, made before any process starts: which robots the station serves, what each
// agent replays, with which seed, on which domain and partition, with which credentials.
#include <gtest/gtest.h>

#include "keyfleet/common/topic_names.hpp"
#include "keyfleet/mission/fleet_credentials.hpp"
#include "keyfleet/mission/mission_runner.hpp"

namespace keyfleet::mission {
namespace {

TEST(MissionPlan, TheStationServesThePlannedDronesAndEachAgentGetsItsOwnBundle) {
  MissionConfig config;
  config.security = true;
  config.agent.source.seed = 7;
  config.station.limits.max_robots = 1;
  const MissionPlan plan =
      plan_mission(config, "/runs/m-1", {"drone_0", "drone_1"}, "", 42, "keyfleet-m-1");
  EXPECT_EQ(plan.station.limits.allowed_robots, (std::vector<std::string>{"drone_0", "drone_1"}));
  EXPECT_EQ(plan.station.limits.max_robots, 2) << "room for every planned drone";
  EXPECT_EQ(plan.station.dds.domain_id, 42);
  EXPECT_EQ(plan.station.dds.partition, "keyfleet-m-1");
  EXPECT_TRUE(plan.station.dds.security.enabled);
  EXPECT_EQ(plan.station.dds.security.directory, host_bundle("/runs/m-1/security", "station"));
  ASSERT_EQ(plan.agents.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const AgentConfig& agent = plan.agents[i];
    EXPECT_EQ(agent.robot_id, plan.robot_ids[i]);
    EXPECT_EQ(agent.source.seed, 7u + i) << "each drone flies its own street";
    EXPECT_EQ(agent.dds.domain_id, 42);
    EXPECT_EQ(agent.dds.partition, "keyfleet-m-1");
    EXPECT_EQ(agent.dds.security.directory, host_bundle("/runs/m-1/security", agent.robot_id));
  }
}

TEST(MissionPlan, AScenarioIsReplayedPerDroneAndSecurityOffIsOffForAll) {
  MissionConfig config;
  config.security = false;
  const MissionPlan plan = plan_mission(config, "/runs/m-2", {"d0", "d1"}, "/runs/m-2/scenario", 5,
                                        "p", [](std::size_t index, AgentConfig& agent) {
                                          if (index == 1) agent.dds.link.rate_kbit_s = 250;
                                        });
  EXPECT_FALSE(plan.station.dds.security.enabled);
  for (const AgentConfig& agent : plan.agents) {
    EXPECT_FALSE(agent.dds.security.enabled) << agent.robot_id;
    EXPECT_EQ(agent.source.kind, SourceConfig::Kind::kScenario);
    EXPECT_EQ(agent.source.path, "/runs/m-2/scenario");
    EXPECT_EQ(agent.source.drone, agent.robot_id);
  }
  EXPECT_EQ(plan.agents[0].dds.link.rate_kbit_s, 0) << "the hook changes its own drone only";
  EXPECT_EQ(plan.agents[1].dds.link.rate_kbit_s, 250);
}

}  // namespace
}  // namespace keyfleet::mission
