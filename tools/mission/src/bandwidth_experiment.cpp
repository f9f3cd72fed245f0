#include "keyfleet/mission/bandwidth_experiment.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <set>
#include <sstream>

#include "keyfleet/common/error.hpp"
#include "keyfleet/common/scenario_truth.hpp"
#include "keyfleet/common/topic_names.hpp"
#include "keyfleet/eval/run_place_score.hpp"
#include "keyfleet/eval/run_text_score.hpp"
#include "keyfleet/mission/experiment_config.hpp"
#include "keyfleet/mission/link_shaping.hpp"
#include "keyfleet/mission/mission_config.hpp"
#include "keyfleet/mission/wire_capture.hpp"
#include "keyfleet/scenario/scenario_config.hpp"
#include "keyfleet/scenario/scenario_generator.hpp"

namespace keyfleet::mission {
namespace {

namespace fs = std::filesystem;

std::string timestamp() {
  const std::time_t now = std::time(nullptr);
  char text[32];
  std::strftime(text, sizeof text, "%Y%m%d-%H%M%S", std::localtime(&now));
  return text;
}

std::uint64_t rate_bytes_per_s(double kbit_s) {
  return static_cast<std::uint64_t>(kbit_s * 1000.0 / 8.0);
}

// The keyframe writer's entity id, as the agent logged it ("... 'keyfleet/keyframes/<id>':
// entity 000001.03").
std::set<std::uint32_t> keyframe_writer_entities(const std::string& agent_log) {
  std::set<std::uint32_t> ids;
  std::ifstream log(agent_log);
  const std::string marker = std::string("DDS writer on '") + kKeyframeTopicPrefix;
  for (std::string line; std::getline(log, line);) {
    if (line.find(marker) == std::string::npos) continue;
    const auto at = line.find("entity ");
    unsigned key = 0, kind = 0;
    if (at != std::string::npos &&
        std::sscanf(line.c_str() + at, "entity %6x.%2x", &key, &kind) == 2)
      ids.insert((key << 8) | kind);
  }
  return ids;
}

double seconds_between(std::int64_t from_ns, std::int64_t to_ns) {
  return static_cast<double>(to_ns - from_ns) / 1e9;
}

// From the agent's start (its log's first line): its station match and its first keyframe
// stored (`mine`: the robot's stored keyframes).
void add_start_times(RobotOutcome& r, const std::string& agent_log,
                     const std::vector<DeliveredKeyframe>& mine) {
  const auto start = log_time_of(agent_log, {});
  if (!start) return;
  // The agent's "station matched" (or "... matched after rejoining"), not its warning "no
  // station matched for N s".
  if (const auto matched = log_time_of(agent_log, {"info station matched"}))
    r.matched_s = seconds_between(*start, *matched);
  const auto first = std::min_element(mine.begin(), mine.end(),
                                      [](const DeliveredKeyframe& a, const DeliveredKeyframe& b) {
                                        return a.received_ns < b.received_ns;
                                      });
  if (first != mine.end()) r.first_keyframe_s = seconds_between(*start, first->received_ns);
}

// Where the drone's bytes went, from the capture of its link, the idle chatter while the agent
// lingered, and the goodput. Throws StartupError for an unreadable capture.
void add_wire_account(RobotOutcome& r, const std::string& agent_log, const std::string& pcap,
                      const std::string& drone_address, double rate_kbit_s) {
  WireAccountingOptions options;
  const auto quiet_from = log_time_of(agent_log, {"lingering"});
  const auto quiet_to = log_time_of(agent_log, {"lingering done"});
  // The first second of the linger still carries the last acknowledgements.
  if (quiet_from && quiet_to && *quiet_to - *quiet_from > 2'000'000'000LL)
    options.quiet_window = TimeWindow{*quiet_from + 1'000'000'000LL, *quiet_to};
  WireAccountant accountant(keyframe_writer_entities(agent_log), options);
  for (const auto& packet : read_pcap(pcap, drone_address)) accountant.add(packet);
  r.wire_account = accountant.account();
  if (r.wire_account->keyframe_busy_ns > 0 && rate_kbit_s > 0)
    r.goodput_fraction = static_cast<double>(r.metrics.payload_bytes) /
                         seconds_between(0, r.wire_account->keyframe_busy_ns) /
                         (rate_kbit_s * 1000.0 / 8.0);
}

}  // namespace

BandwidthExperiment::BandwidthExperiment(BandwidthExperimentConfig config, MissionBinaries binaries,
                                         Logger logger, std::ostream& progress)
    : config_(std::move(config)),
      binaries_(std::move(binaries)),
      logger_(std::move(logger)),
      progress_(progress) {}

// A scenario is generated once, into the experiment's folder, and every mission replays its
// first `drones` drones: the same flight over every link.
void BandwidthExperiment::prepare_scenario(const std::string& dir) {
  scenario_dir_ = config_.mission.scenario_dir;
  if (!config_.mission.scenario.empty()) {
    scenario_dir_ = (fs::path(dir) / "scenario").string();
    progress_ << "generating scenario " << config_.mission.scenario << " ...\n" << std::flush;
    scenario::generate_scenario(load_scenario_config(config_.mission.scenario), scenario_dir_,
                                logger_);
  }
  if (scenario_dir_.empty()) return;
  const scenario::Scenario street = scenario::read_scenario(scenario_dir_);
  std::uint64_t frames = 0;
  double fps = config_.mission.agent.source.fps;
  for (const auto& drone : street.drones) {
    scenario_drones_.push_back(drone.robot_id);
    frames = std::max(frames, drone.frames);
    if (drone.fps > 0) fps = drone.fps;
  }
  if (config_.mission.agent.source.max_frames > 0)
    frames = std::min(frames, config_.mission.agent.source.max_frames);
  scenario_flight_s_ = fps > 0 ? static_cast<double>(frames) / fps : 0;
  for (int drones : config_.drones)
    if (drones < 1 || drones > static_cast<int>(scenario_drones_.size()))
      throw StartupError("experiment: drones: " + std::to_string(drones) +
                         " asked for, but the scenario " + scenario_dir_ + " has " +
                         std::to_string(scenario_drones_.size()) + " drones (1.." +
                         std::to_string(scenario_drones_.size()) + ")");
  progress_ << "scenario: " << scenario_drones_.size() << " drones, " << scenario_flight_s_
            << " s of flight each, replayed by every mission\n";
}

// The station's reading and place matches against the street's truth.
void BandwidthExperiment::add_analysis(
    ExperimentMission& out, const std::set<std::pair<std::string, std::int64_t>>& in_time,
    bool in_time_known) const {
  const std::string db = (fs::path(out.run_dir) / "station" / "station.sqlite").string();
  try {
    const auto text = eval::score_run_text(scenario_dir_, db);
    const auto timely = eval::score_run_text(scenario_dir_, db,
                                             [&](const std::string& robot, std::int64_t sequence) {
                                               return in_time.count({robot, sequence}) > 0;
                                             });
    const auto places = eval::score_run_places(scenario_dir_, db);
    MissionAnalysis a;
    a.keyframes = places.keyframes;
    a.analysed = places.analysed;
    a.visible_words = text.visible_words;
    a.words_read = text.read_visible;
    a.words_read_in_time = timely.read_visible;
    a.in_time_known = in_time_known;
    a.words_reported = text.words_reported;
    a.junk = text.junk;
    a.place_matches = places.matches;
    a.place_matches_right = places.right;
    a.read_words = text.read_words;
    out.analysis = std::move(a);
  } catch (const std::exception& e) {
    out.analysis_error = std::string("not scored against the scenario: ") + e.what();
  }
}

ExperimentResult BandwidthExperiment::run(const StopToken& stop) {
  ExperimentResult result;
  const fs::path dir = fs::absolute(config_.run_root) /
                       (config_.name + "-" + timestamp() + "-" + std::to_string(::getpid()));
  fs::create_directories(dir / "config");
  result.dir = dir.string();
  std::ofstream(dir / "config" / "experiment.yaml") << to_yaml(config_);
  progress_ << "bandwidth experiment '" << config_.name << "': " << dir.string() << "\n";
  prepare_scenario(dir.string());
  result.scenario_dir = scenario_dir_;
  const auto& source = config_.mission.agent.source;
  result.flight_s = scenario_flight_s_ > 0  ? scenario_flight_s_
                    : source.max_frames > 0 ? static_cast<double>(source.max_frames) / source.fps
                                            : 0;

  std::vector<std::string> links;
  for (const auto& link : config_.links) {
    if (link == "netns") {
      if (const auto reason = netns_unavailable_reason()) {
        result.skipped.push_back("netns links skipped: " + *reason);
        progress_ << result.skipped.back() << "\n" << std::flush;
        continue;
      }
      remove_stale_namespaces(logger_);
    }
    links.push_back(link);
  }
  std::vector<std::string> security_modes = config_.security;
  if (security_modes.empty()) security_modes = {config_.mission.security ? "on" : "off"};
  std::vector<std::string> adaptation_modes = config_.link_adaptation;
  if (adaptation_modes.empty())
    adaptation_modes = {config_.mission.agent.link_adaptation.enabled ? "on" : "off"};
  for (const auto& link : links)
    for (const auto& security : security_modes)
      for (int drones : config_.drones)
        for (const auto& profile : config_.profiles)
          for (const auto& adaptation : adaptation_modes) {
            if (stop.requested()) {
              result.interrupted = true;
              break;
            }
            result.missions.push_back(run_mission(dir.string(), link, security == "on",
                                                  adaptation == "on", drones, profile, stop));
          }
  if (stop.requested()) result.interrupted = true;

  write_experiment_json(result, config_, (dir / "results.json").string());
  write_experiment_csv(result, (dir / "results.csv").string());
  const std::string script = find_report_script();
  if (script.empty()) {
    result.report_error = "tools/report/bandwidth_report.py not found";
  } else {
    const auto plot = run_command({config_.python, script, dir.string()});
    result.report_written = plot.exit_code == 0;
    if (!result.report_written)
      result.report_error = config_.python + " " + script + " failed: " + plot.output;
  }
  return result;
}

ExperimentMission BandwidthExperiment::run_mission(const std::string& dir, const std::string& link,
                                                   bool security, bool adaptation, int drones,
                                                   const LinkProfileConfig& profile,
                                                   const StopToken& stop) {
  ExperimentMission out;
  out.link = link;
  out.security = security;
  out.link_adaptation = adaptation;
  out.profile = profile;
  out.drones = drones;
  out.name = "d" + std::to_string(drones) + "-" + link + "-" + profile.name +
             (security ? "-sec" : "-plain") + (adaptation ? "-adapt" : "");
  progress_ << "\n=== " << out.name << " ===\n" << std::flush;

  MissionConfig mission = config_.mission;
  mission.name = out.name;
  mission.drones = drones;
  mission.security = security;
  mission.agent.link_adaptation.enabled = adaptation;
  size_drain(mission, profile, config_, scenario_flight_s_);
  mission.run_root = (fs::path(dir) / "missions").string();
  std::vector<std::string> robot_ids;
  if (!scenario_dir_.empty()) {
    mission.scenario.clear();
    mission.scenario_dir = scenario_dir_;
    mission.scenario_drones = drones;
    robot_ids.assign(scenario_drones_.begin(), scenario_drones_.begin() + drones);
  } else {
    for (int i = 0; i < drones; ++i)
      robot_ids.push_back(mission.robot_id_prefix + std::to_string(i));
  }

  std::unique_ptr<NetnsLinks> netns;
  MissionHooks hooks;
  const std::uint64_t rate = rate_bytes_per_s(profile.rate_kbit_s);
  if (link == "flow_control") {
    out.dds_cap_bytes_per_s = rate;
    out.notes.push_back(rate > 0 ? "DDS flow controller at " + std::to_string(rate) +
                                       " bytes/s per agent, localhost transport"
                                 : "no cap, localhost transport");
    if (profile.delay_ms > 0 || profile.loss_percent > 0)
      out.notes.push_back("delay/loss NOT applied: only netns links can add them");
  } else {
    try {
      netns = std::make_unique<NetnsLinks>(robot_ids, profile, logger_);
    } catch (const StartupError& e) {
      out.failures.push_back(e.what());
      progress_ << "skipped: " << e.what() << "\n";
      return out;
    }
    out.notes = netns->notes();
    if (config_.dds_link && profile.rate_kbit_s > 0) {
      out.dds_link = true;
      mission.agent.dds.link.rate_kbit_s = profile.rate_kbit_s;
      mission.station.dds.link.rate_kbit_s = profile.rate_kbit_s;
      out.dds_cap_bytes_per_s =
          static_cast<std::uint64_t>(static_cast<double>(rate) * mission.agent.dds.link.pacing);
      out.notes.push_back("DDS tuned for the link (dds.link): pacing " +
                          std::to_string(mission.agent.dds.link.pacing) + " of the rate, MTU " +
                          std::to_string(mission.agent.dds.link.mtu_bytes));
    } else {
      out.dds_cap_bytes_per_s =
          static_cast<std::uint64_t>(static_cast<double>(rate) * config_.netns_dds_cap_fraction);
      if (out.dds_cap_bytes_per_s > 0)
        out.notes.push_back("DDS flow controller at " + std::to_string(out.dds_cap_bytes_per_s) +
                            " bytes/s per agent (netns_dds_cap_fraction of the link rate)");
    }
    mission.agent.linger_s = std::max(mission.agent.linger_s, config_.idle_window_s);
    mission.station.dds.transport = DdsSettings::Transport::kNetwork;
    mission.station.dds.shared_memory = false;
    mission.station.dds.initial_peers = netns->drone_addresses();
    NetnsLinks* links = netns.get();
    hooks.command_prefix = [links](const std::string& process) {
      return links->command_prefix(process);
    };
    hooks.adjust_agent = [links](std::size_t i, AgentConfig& agent) {
      agent.dds.transport = DdsSettings::Transport::kNetwork;
      agent.dds.shared_memory = false;
      agent.dds.initial_peers = {links->station_address(i)};
    };
  }
  if (!out.dds_link) mission.agent.dds.max_bytes_per_s = out.dds_cap_bytes_per_s;
  for (const auto& note : out.notes) progress_ << "link: " << note << "\n";

  std::vector<std::unique_ptr<WireCapture>> captures(robot_ids.size());
  if (netns && config_.capture) {
    fs::create_directories(fs::path(dir) / "captures");
    for (std::size_t i = 0; i < robot_ids.size(); ++i) {
      WireCaptureOptions options;
      options.command_prefix = netns->command_prefix(robot_ids[i]);
      options.interface = netns->drone_interface(i);
      options.pcap_path =
          (fs::path(dir) / "captures" / (out.name + "-" + robot_ids[i] + ".pcap")).string();
      options.log_path = options.pcap_path + ".log";
      try {
        captures[i] = std::make_unique<WireCapture>(options);
      } catch (const StartupError& e) {
        out.notes.push_back(std::string("no capture for ") + robot_ids[i] + ": " + e.what());
      }
    }
  }

  const auto start = std::chrono::steady_clock::now();
  MissionRunner runner(mission, binaries_, logger_, progress_);
  runner.set_hooks(hooks);
  const MissionResult mission_result = runner.run(stop);
  out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  out.run_dir = mission_result.run_dir;
  out.failures = mission_result.failures;
  for (auto& capture : captures)
    if (capture) capture->stop();

  std::set<std::pair<std::string, std::int64_t>> in_time;  // keyframes stored in time
  bool in_time_known = true;  // every robot's stream start was found (latency measurable)
  try {
    const auto records =
        read_station_records((fs::path(out.run_dir) / "station" / "station.sqlite").string());
    std::int64_t first_ns = 0;
    for (const auto& k : records.keyframes)
      if (first_ns == 0 || k.received_ns < first_ns) first_ns = k.received_ns;
    for (std::size_t i = 0; i < robot_ids.size(); ++i) {
      const std::string& robot = robot_ids[i];
      RobotOutcome r;
      const std::string log = (fs::path(out.run_dir) / robot / "agent.log").string();
      const auto origin = stream_start_from_log(log);
      const auto agent = records.agents.find(robot);
      std::optional<AgentTotals> totals;
      if (agent != records.agents.end()) totals = agent->second;
      r.metrics = robot_metrics(robot, records.keyframes, totals,
                                netns ? netns->counters(robot) : std::nullopt, origin.value_or(0));
      r.latency_measured = origin.has_value();
      in_time_known = in_time_known && origin.has_value();
      r.metrics.refused_writes = count_refused_writes(log);
      r.frames_seen = totals ? totals->frames_seen : 0;
      r.pending = totals ? totals->keyframes_pending : 0;
      std::vector<DeliveredKeyframe> mine;
      for (const auto& k : records.keyframes)
        if (k.robot_id == robot) mine.push_back(k);
      for (const auto& k : mine)
        if (origin && static_cast<double>(k.received_ns - (*origin + k.capture_time_ns)) <=
                          config_.words_in_time_s * 1e9)
          in_time.insert({robot, k.sequence_number});
      add_start_times(r, log, mine);
      if (captures[i]) {
        try {
          add_wire_account(r, log, captures[i]->pcap_path(), netns->drone_addresses()[i],
                           profile.rate_kbit_s);
        } catch (const StartupError& e) {
          r.capture_error = e.what();
        }
      } else if (netns && config_.capture) {
        r.capture_error = "no capture ran (see the mission's notes)";
      }
      r.bytes_per_bin =
          bytes_per_bin(mine, first_ns, static_cast<std::int64_t>(config_.bin_s * 1e9));
      out.robots.push_back(std::move(r));
    }
  } catch (const StartupError& e) {
    out.failures.push_back(e.what());
  }
  if (!scenario_dir_.empty()) {
    add_analysis(out, in_time, in_time_known);
    if (out.analysis)
      progress_ << "station read " << out.analysis->words_read << " of "
                << out.analysis->visible_words << " sign words visible ("
                << (in_time_known ? std::to_string(out.analysis->words_read_in_time) : "?")
                << " in keyframes stored within " << config_.words_in_time_s << " s of capture) in "
                << out.analysis->keyframes << " keyframes (" << out.analysis->analysed
                << " analysed); " << out.analysis->place_matches
                << " place matches between robots, " << out.analysis->place_matches_right
                << " right\n";
    else
      progress_ << out.analysis_error << "\n";
  }
  out.ok = out.failures.empty();
  progress_ << out.name << (out.ok ? ": OK" : ": FAILED") << " in " << static_cast<int>(out.wall_s)
            << " s\n"
            << std::flush;
  return out;
}

void size_drain(MissionConfig& mission, const LinkProfileConfig& profile,
                const BandwidthExperimentConfig& config, double flight_s) {
  const auto& source = mission.agent.source;
  if (flight_s <= 0 && source.max_frames > 0)
    flight_s = static_cast<double>(source.max_frames) / source.fps;
  if (profile.rate_kbit_s <= 0 || flight_s <= 0) return;
  const double offered = config.offered_bytes_per_s * flight_s;
  // What the flight offers beyond what the link carries during it, plus the margin. The link
  // carries about 0.7 of its rate in keyframe payload (pacing and headers), less what is lost.
  const double link_bytes_per_s =
      profile.rate_kbit_s * 1000.0 / 8.0 * 0.7 * std::max(0.05, 1.0 - profile.loss_percent / 100);
  const double drain = std::max(0.0, offered / link_bytes_per_s - flight_s) + config.drain_margin_s;
  mission.agent.drain_timeout_s = std::max(mission.agent.drain_timeout_s, drain);
  const double needed = mission.agent.wait_for_station_s + flight_s * 1.5 +
                        mission.agent.drain_timeout_s + mission.agent.linger_s +
                        config.idle_window_s + 30.0;
  mission.agent_timeout_s = std::max(mission.agent_timeout_s, needed);
}

std::string find_report_script() {
  std::error_code error;
  const fs::path self = fs::read_symlink("/proc/self/exe", error);
  std::vector<fs::path> candidates;
  if (!error)
    candidates.push_back(self.parent_path().parent_path() / "share" / "keyfleet" / "report" /
                         "bandwidth_report.py");
#ifdef KEYFLEET_REPORT_SOURCE_DIR
  candidates.push_back(fs::path(KEYFLEET_REPORT_SOURCE_DIR) / "bandwidth_report.py");
#endif
  for (const auto& candidate : candidates)
    if (fs::exists(candidate)) return candidate.string();
  return {};
}

}  // namespace keyfleet::mission
