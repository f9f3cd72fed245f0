#include "keyfleet/mission/mission_runner.hpp"
#include "keyfleet/mission/mission_config.hpp"

#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <random>
#include <sstream>

#include "keyfleet/common/error.hpp"
#include "keyfleet/common/scenario_truth.hpp"
#include "keyfleet/common/sqlite.hpp"
#include "keyfleet/common/topic_names.hpp"
#include "keyfleet/mission/child_process.hpp"
#include "keyfleet/mission/fleet_credentials.hpp"
#include "keyfleet/scenario/scenario_config.hpp"
#include "keyfleet/scenario/scenario_generator.hpp"
#include "keyfleet/station/web/html_report.hpp"

namespace keyfleet::mission {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

std::string timestamp() {
  const std::time_t now = std::time(nullptr);
  char text[32];
  std::strftime(text, sizeof text, "%Y%m%d-%H%M%S", std::localtime(&now));
  return text;
}

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  if (!out) throw StartupError("cannot write " + path.string());
}

// Stored keyframes per robot, read from the station's database while it runs.
std::map<std::string, std::int64_t> stored_per_robot(const fs::path& database) {
  std::map<std::string, std::int64_t> counts;
  if (!fs::exists(database)) return counts;
  try {
    SqliteDb db(database.string(), SqliteDb::Mode::kReadOnly);
    auto query = db.prepare("SELECT robot_id, COUNT(*) FROM keyframes GROUP BY robot_id");
    while (query.step()) counts[query.text(0)] = query.int64(1);
  } catch (const SqliteError&) {
    // The station may still be creating its schema: no progress figure this time.
  }
  return counts;
}

// The URL the station's dashboard serves at, once the station has written it.
std::string dashboard_url(const fs::path& station_dir) {
  std::ifstream in(station_dir / "dashboard.url");
  std::string url;
  std::getline(in, url);
  return url;
}

std::string failure_line(const ChildProcess& child, const ExitStatus& status) {
  return child.name() + " (pid " + std::to_string(child.pid()) + ") " + status.describe() +
         "; last lines of " + child.log_path() + ":\n" + tail_of_file(child.log_path(), 6);
}

}  // namespace

std::string find_sibling_executable(const std::string& name) {
  std::error_code error;
  const fs::path self = fs::read_symlink("/proc/self/exe", error);
  if (!error) {
    const fs::path sibling = self.parent_path() / name;
    if (fs::exists(sibling)) return sibling.string();
  }
  if (const char* path = std::getenv("PATH")) {
    std::stringstream dirs(path);
    std::string dir;
    while (std::getline(dirs, dir, ':'))
      if (!dir.empty() && ::access((fs::path(dir) / name).c_str(), X_OK) == 0)
        return (fs::path(dir) / name).string();
  }
  throw StartupError("cannot find the '" + name + "' executable next to " + self.string() +
                     " or on PATH (build the project first)");
}

MissionRunner::MissionRunner(MissionConfig config, MissionBinaries binaries, Logger logger,
                             std::ostream& progress)
    : config_(std::move(config)),
      binaries_(std::move(binaries)),
      logger_(std::move(logger)),
      progress_(progress) {}

std::vector<std::string> MissionRunner::command(const std::string& process,
                                                std::vector<std::string> argv) const {
  if (!hooks_.command_prefix) return argv;
  std::vector<std::string> full = hooks_.command_prefix(process);
  full.insert(full.end(), argv.begin(), argv.end());
  return full;
}

void MissionRunner::write_report_html(const fs::path& run_dir, MissionResult& result) const {
  const fs::path database = run_dir / "station" / config_.station.database;
  if (!fs::exists(database)) return;
  station::web::HtmlReportInputs inputs{run_dir.filename().string(), database.string(),
                                        result.scenario_dir, result.report_table};
  try {
    station::web::write_html_report(inputs, (run_dir / "report.html").string());
    result.report_html = (run_dir / "report.html").string();
  } catch (const std::exception& e) {
    result.failures.push_back("report.html not written: " + std::string(e.what()));
  }
}

MissionPlan plan_mission(const MissionConfig& config, const fs::path& run_dir,
                         std::vector<std::string> robot_ids, const std::string& scenario_dir,
                         int domain_id, const std::string& partition,
                         const std::function<void(std::size_t, AgentConfig&)>& adjust_agent) {
  MissionPlan plan;
  plan.run_dir = run_dir;
  plan.domain_id = domain_id;
  plan.partition = partition;
  plan.scenario_dir = scenario_dir;
  plan.robot_ids = std::move(robot_ids);
  const fs::path credentials = run_dir / "security";

  // The station serves this mission's drones only, with the station's bundle.
  plan.station = config.station;
  plan.station.dds.domain_id = domain_id;
  plan.station.dds.partition = partition;
  StationLimits& limits = plan.station.limits;
  limits.allowed_robots = plan.robot_ids;
  limits.max_robots = std::max(limits.max_robots, static_cast<int>(plan.robot_ids.size()));
  plan.station.dds.security =
      config.security ? DdsSecurity{true, host_bundle(credentials.string(), kStationIdentity)}
                      : DdsSecurity{false, ""};

  // Each agent: its drone (a scenario's, replayed), its own seed and its host's bundle only.
  for (std::size_t i = 0; i < plan.robot_ids.size(); ++i) {
    AgentConfig agent = config.agent;
    if (!scenario_dir.empty()) {
      agent.source.kind = SourceConfig::Kind::kScenario;
      agent.source.path = fs::absolute(scenario_dir).string();
    }
    agent.robot_id = plan.robot_ids[i];
    agent.source.drone = plan.robot_ids[i];
    agent.source.seed = config.agent.source.seed + static_cast<std::uint64_t>(i);
    agent.dds.domain_id = domain_id;
    agent.dds.partition = partition;
    agent.dds.security = config.security
                             ? DdsSecurity{true, host_bundle(credentials.string(), agent.robot_id)}
                             : DdsSecurity{false, ""};
    if (adjust_agent) adjust_agent(i, agent);
    plan.agents.push_back(std::move(agent));
  }
  return plan;
}

// The steps of a mission, in order: a run folder, the drones, the plan, its files, the
// processes, watching them, stopping them, and the report.
MissionResult MissionRunner::run(const StopToken& stop) {
  MissionResult result;
  const fs::path run_dir = make_run_folder();
  result.run_dir = run_dir.string();
  std::random_device entropy;
  const int domain = config_.domain_id.value_or(static_cast<int>(10 + entropy() % 200));
  const std::string partition = "keyfleet-" + config_.name + "-" + std::to_string(::getpid()) +
                                "-" + std::to_string(entropy() % 1000000);
  progress_ << "mission '" << config_.name << "': DDS domain " << domain << ", partition "
            << partition << "\nrun folder: " << run_dir.string() << "\n"
            << std::flush;

  std::string scenario_dir;
  std::vector<std::string> robot_ids = choose_drones(run_dir, scenario_dir);
  result.scenario_dir = scenario_dir;
  const MissionPlan plan = plan_mission(config_, run_dir, std::move(robot_ids), scenario_dir,
                                        domain, partition, hooks_.adjust_agent);
  write_plan(plan);
  Processes processes = start(plan);
  const bool station_died = watch(processes, plan, stop, result);
  stop_processes(processes, station_died, result);
  collect(plan, processes, result);
  return result;
}

fs::path MissionRunner::make_run_folder() const {
  const fs::path run_dir = fs::absolute(config_.run_root) /
                           (config_.name + "-" + timestamp() + "-" + std::to_string(::getpid()));
  fs::create_directories(run_dir / "config");
  return run_dir;
}

// A scenario decides the drones: one agent per scenario drone, replaying its frames.
std::vector<std::string> MissionRunner::choose_drones(const fs::path& run_dir,
                                                      std::string& scenario_dir) {
  scenario_dir = config_.scenario_dir;
  if (!config_.scenario.empty()) {
    scenario_dir = (run_dir / "scenario").string();
    progress_ << "generating scenario " << config_.scenario << " ...\n" << std::flush;
    const auto summary =
        scenario::generate_scenario(load_scenario_config(config_.scenario), scenario_dir, logger_);
    progress_ << "scenario: " << summary.frames << " frames in " << summary.seconds << " s\n";
  }
  std::vector<std::string> robot_ids;
  if (!scenario_dir.empty()) {
    for (const auto& drone : scenario::read_scenario(scenario_dir).drones)
      if (config_.scenario_drones == 0 || int(robot_ids.size()) < config_.scenario_drones)
        robot_ids.push_back(drone.robot_id);
  } else {
    for (int i = 0; i < config_.drones; ++i)
      robot_ids.push_back(config_.robot_id_prefix + std::to_string(i));
  }
  return robot_ids;
}

// The credentials (one bundle per host) and every process's config file.
void MissionRunner::write_plan(const MissionPlan& plan) {
  const fs::path credentials = plan.run_dir / "security";
  if (config_.security) {
    write_fleet_credentials({credentials.string(), plan.robot_ids}, logger_);
    progress_ << "DDS-Security on: one bundle per host in " << (credentials / "hosts").string()
              << "\n";
  } else {
    logger_->warn("DDS-Security off (mission security: false): plain DDS on domain {}",
                  plan.domain_id);
    progress_ << "DDS-Security off (security: false): anyone on DDS domain " << plan.domain_id
              << " can read and write this mission's keyframes\n";
  }
  // The mission as it ran: its station's config, and the agents' shared settings as planned.
  MissionConfig recorded = config_;
  recorded.station = plan.station;
  if (!plan.scenario_dir.empty()) {
    recorded.agent.source.kind = SourceConfig::Kind::kScenario;
    recorded.agent.source.path = fs::absolute(plan.scenario_dir).string();
  }
  if (!config_.security) recorded.agent.dds.security.enabled = false;
  write_text(plan.run_dir / "config" / "station.yaml", to_yaml(plan.station));
  write_text(plan.run_dir / "config" / "mission.yaml", to_yaml(recorded));
  for (const AgentConfig& agent : plan.agents)
    write_text(plan.run_dir / "config" / (agent.robot_id + ".yaml"), to_yaml(agent));
}

MissionRunner::Processes MissionRunner::start(const MissionPlan& plan) {
  progress_ << plan.robot_ids.size() << " drone(s) + station\n" << std::flush;
  Processes p;
  const fs::path station_dir = plan.run_dir / "station";
  fs::create_directories(station_dir);
  p.station = std::make_unique<ChildProcess>(
      "ground_station",
      command("ground_station", {binaries_.ground_station, "--config",
                                 (plan.run_dir / "config" / "station.yaml").string(), "--run-dir",
                                 station_dir.string()}),
      (station_dir / "station.log").string());
  for (const AgentConfig& agent : plan.agents) {
    const fs::path agent_dir = plan.run_dir / agent.robot_id;
    fs::create_directories(agent_dir);
    p.agents.push_back(std::make_unique<ChildProcess>(
        agent.robot_id,
        command(agent.robot_id, {binaries_.robot_agent, "--config",
                                 (plan.run_dir / "config" / (agent.robot_id + ".yaml")).string(),
                                 "--run-dir", agent_dir.string()}),
        (agent_dir / "agent.log").string()));
  }
  return p;
}

// Waits for the agents, reporting progress, failing fast if the station dies; true when it did.
bool MissionRunner::watch(Processes& p, const MissionPlan& plan, const StopToken& stop,
                          MissionResult& result) {
  const fs::path station_dir = plan.run_dir / "station";
  const auto start = Clock::now();
  const auto deadline = start + std::chrono::duration_cast<Clock::duration>(
                                    std::chrono::duration<double>(config_.agent_timeout_s));
  auto next_progress = start;
  std::size_t running = p.agents.size();
  bool station_died = false;
  std::vector<bool> finished(p.agents.size(), false);
  while (running > 0 && !stop.requested()) {
    running = 0;
    for (std::size_t i = 0; i < p.agents.size(); ++i) {
      const auto status = p.agents[i]->poll();
      if (!status) {
        ++running;
      } else if (!finished[i]) {
        finished[i] = true;
        if (!status->ok()) result.failures.push_back(failure_line(*p.agents[i], *status));
      }
    }
    if (auto status = p.station->poll(); status && !station_died) {
      station_died = true;
      result.failures.push_back(failure_line(*p.station, *status));
      break;
    }
    if (Clock::now() >= deadline) {
      for (auto& agent : p.agents) {
        if (!agent->poll()) {
          agent->signal(SIGTERM);
          result.failures.push_back(agent->name() + " still running after agent_timeout_s=" +
                                    std::to_string(config_.agent_timeout_s) + "; stopped");
        }
      }
      break;
    }
    note_dashboard(station_dir, result);
    if (Clock::now() >= next_progress) {
      const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
      progress_ << "[" << static_cast<int>(elapsed) << " s] stored:";
      for (const auto& [robot, count] : stored_per_robot(station_dir / "station.sqlite"))
        progress_ << " " << robot << "=" << count;
      progress_ << " | agents running " << running << "/" << p.agents.size() << "\n" << std::flush;
      next_progress += std::chrono::seconds(2);
    }
    stop.wait_for(milliseconds(100));
  }
  result.agents_wall_s = std::chrono::duration<double>(Clock::now() - start).count();
  if (stop.requested()) {
    progress_ << "interrupted: stopping agents and station\n";
    result.failures.push_back("mission interrupted by a signal");
  }
  return station_died;
}

// The station writes its dashboard's address once it serves it.
void MissionRunner::note_dashboard(const fs::path& station_dir, MissionResult& result) {
  if (!result.dashboard_url.empty() || !config_.station.dashboard.enabled) return;
  result.dashboard_url = dashboard_url(station_dir);
  if (!result.dashboard_url.empty())
    progress_ << "dashboard: " << result.dashboard_url << "\n" << std::flush;
}

// The agents first, then the station, given time to drain.
void MissionRunner::stop_processes(Processes& p, bool station_died, MissionResult& result) {
  for (auto& agent : p.agents) {
    if (!agent->poll()) agent->signal(SIGTERM);
    const auto status = agent->wait_for(milliseconds(10000));
    if (!status) {
      agent->signal(SIGKILL);
      result.failures.push_back(agent->name() + " ignored SIGTERM for 10 s; killed");
    }
  }
  if (station_died) return;
  note_dashboard(fs::path(result.run_dir) / "station", result);
  p.station->signal(SIGTERM);
  const auto drained =
      std::chrono::milliseconds(static_cast<long>(config_.station_drain_timeout_s * 1000));
  const auto status = p.station->wait_for(drained);
  if (!status) {
    p.station->signal(SIGKILL);
    p.station->wait_for(milliseconds(5000));
    result.failures.push_back("ground_station did not stop within station_drain_timeout_s; killed");
  } else if (!status->ok()) {
    result.failures.push_back(failure_line(*p.station, *status));
  }
}

// Each process's figures, the station's report and report.html.
void MissionRunner::collect(const MissionPlan& plan, Processes& p, MissionResult& result) {
  for (std::size_t i = 0; i < p.agents.size(); ++i) {
    const auto status = p.agents[i]->poll();
    result.agents.push_back({plan.robot_ids[i], (plan.run_dir / plan.robot_ids[i]).string(),
                             status ? status->cpu_s : 0.0});
  }
  const fs::path station_dir = plan.run_dir / "station";
  const auto station_status = p.station->poll();
  result.station = {"ground_station", station_dir.string(),
                    station_status ? station_status->cpu_s : 0.0};
  std::ifstream report(station_dir / "report.txt");
  std::stringstream table;
  table << report.rdbuf();
  result.report_table = table.str();
  write_report_html(plan.run_dir, result);
  result.ok = result.failures.empty();
}

}  // namespace keyfleet::mission
