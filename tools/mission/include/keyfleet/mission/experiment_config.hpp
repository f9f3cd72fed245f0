#pragma once
// `keyfleet experiment bandwidth`, loaded from YAML by experiment_config.cpp.
#include <string>
#include <vector>

#include "keyfleet/mission/mission_config.hpp"

namespace keyfleet {

// One link of the bandwidth experiment, per drone (not shared between drones).
struct LinkProfileConfig {
  std::string name = "unlimited";  // [A-Za-z0-9_.-]
  double rate_kbit_s = 0;          // 0 = unlimited
  double delay_ms = 0;             // netns links only, and only where the kernel has netem
  double loss_percent = 0;         // netns links only: netem, else an nftables random-drop rule
};

// `keyfleet experiment bandwidth`: one mission per drone count x link kind x profile.
struct BandwidthExperimentConfig {
  std::string name = "bandwidth";
  std::string run_root = "runs";  // the experiment's folder: <run_root>/<name>-<time>-<pid>/
  std::vector<int> drones = {2, 4, 8};
  std::vector<LinkProfileConfig> profiles = {LinkProfileConfig{}};
  // flow_control: each agent's DDS flow controller at the profile's rate (localhost transport).
  // netns (root only, else skipped with the reason): each drone in its own network namespace,
  // a veth link to the station's namespace shaped by tbf (+ netem where the kernel has it).
  std::vector<std::string> links = {"flow_control", "netns"};
  // netns: the agents' DDS cap as a fraction of the link rate, so that RTPS, UDP and IP
  // headers fit under it; at 0.9 a 500 kbit/s tbf link overflowed and most bytes on the wire
  // were repairs (0 = no DDS cap, the link alone limits).
  double netns_dds_cap_fraction = 0.7;
  // netns: the agents and the station tune DDS for each profile's link (dds.link.rate_kbit_s =
  // the profile's rate; MTU, pacing and discovery periods from mission.agent.dds.link and
  // mission.station.dds.link). false: only the older cap above, in 10 ms periods.
  bool dds_link = true;
  // Each mission with DDS-Security ("on"), without ("off"), or both, in this order; empty: as
  // mission.security says.
  std::vector<std::string> security;
  // Each mission with the agents' link adaptation off, on, or both, in this order; empty: as
  // mission.agent.link_adaptation.enabled says.
  std::vector<std::string> link_adaptation;
  // Sizing each mission's drain to its link: the keyframe bytes a drone is expected to offer per
  // second of flight. The agents' drain_timeout_s becomes at least the flight's offered bytes
  // over the link's rate plus drain_margin_s, so "delivered" measures the transport.
  double offered_bytes_per_s = 60000;
  double drain_margin_s = 30;
  // netns: each agent stays connected this long after draining (agent linger_s): the idle
  // chatter of a connected fleet is measured over it.
  double idle_window_s = 10;
  // netns: tcpdump on each drone's end of its link, classified by RTPS submessage (where the
  // bytes go: keyframe data, repairs, control, discovery, security, other topics).
  bool capture = true;
  double bin_s = 1.0;  // bandwidth-over-time bins (s)
  // A replayed scenario's words are also counted over the keyframes that reached the station
  // within this long of their capture ("read in time"; the link targets' latency bound).
  double words_in_time_s = 5.0;
  std::string python = "/usr/bin/python3";  // runs tools/report/bandwidth_report.py (matplotlib)
  // Agent and station templates; name and drones are set per mission. With mission.scenario (or
  // scenario_dir) the scenario is generated once and every mission replays its first `drones`
  // drones (each count at most the scenario's); the station's words read and place matches are
  // then judged against the street's truth and reported beside the link figures.
  MissionConfig mission;
};

BandwidthExperimentConfig load_bandwidth_experiment_config(const std::string& path);
BandwidthExperimentConfig parse_bandwidth_experiment_config(const std::string& text,
                                                            const std::string& origin);
std::string to_yaml(const BandwidthExperimentConfig& config);

}  // namespace keyfleet
