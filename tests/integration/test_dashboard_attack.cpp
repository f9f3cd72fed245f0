// Strangers at the dashboard's door of a real station process: slow request heads, a flood of
// connections opened and closed, and many held open from several addresses, all under a
// 1,024 open-file limit (a common default). The station must keep storing and acknowledging a
// robot's keyframes, answer (or refuse) an ordinary request at once, and stop on SIGTERM with
// its reports, while the attack goes on.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <fstream>
#include <iostream>
#include <sstream>
#include <thread>

#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/mission/child_process.hpp"
#include "keyfleet/station/station_config.hpp"
#include "support/fleet_fixture.hpp"

namespace keyfleet::testing {
namespace {

namespace fs = std::filesystem;
using std::chrono::milliseconds;
using std::chrono::seconds;

// A connected socket from a loopback address, or -1.
int connect_from(const std::string& from, int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in local{};
  local.sin_family = AF_INET;
  ::inet_pton(AF_INET, from.c_str(), &local.sin_addr);
  sockaddr_in server{};
  server.sin_family = AF_INET;
  server.sin_port = htons(static_cast<std::uint16_t>(port));
  ::inet_pton(AF_INET, "127.0.0.1", &server.sin_addr);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&local), sizeof local) != 0 ||
      ::connect(fd, reinterpret_cast<sockaddr*>(&server), sizeof server) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// The status line of the answer to a GET sent from `from`, or "" when none came in `timeout`.
std::string status_line(const std::string& from, int port, milliseconds timeout) {
  const int fd = connect_from(from, port);
  if (fd < 0) return "";
  const std::string request = "GET /api/summary HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n";
  ::send(fd, request.data(), request.size(), MSG_NOSIGNAL);
  std::string answer;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (answer.find("\r\n") == std::string::npos && std::chrono::steady_clock::now() < deadline) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 100) <= 0) continue;
    char buffer[512];
    const ssize_t n = ::recv(fd, buffer, sizeof buffer, 0);
    if (n <= 0) break;
    answer.append(buffer, static_cast<std::size_t>(n));
  }
  ::close(fd);
  return answer.substr(0, answer.find("\r\n"));
}

// Bytes of `head` then `filler` (repeated) sent until the peer stops taking them (closed or
// not reading for 2 s), at most 256 MiB.
std::uint64_t send_until_closed(int port, const std::string& head, const std::string& filler) {
  const int fd = connect_from("127.0.0.1", port);
  if (fd < 0) return 0;
  std::uint64_t sent = 0;
  bool open = ::send(fd, head.data(), head.size(), MSG_NOSIGNAL) > 0;
  while (open && sent < (256u << 20)) {
    pollfd p{fd, POLLOUT, 0};
    if (::poll(&p, 1, 2000) <= 0 || (p.revents & (POLLERR | POLLHUP))) break;
    const ssize_t n = ::send(fd, filler.data(), filler.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n < 0 && errno != EAGAIN) break;
    if (n > 0) sent += static_cast<std::uint64_t>(n);
  }
  ::close(fd);
  return sent;
}

// The process's resident memory in KiB (VmRSS), 0 when unknown.
std::uint64_t resident_kib(int pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::stoull(line.substr(6));
  return 0;
}

class DashboardAttack : public FleetFixture {};

TEST_F(DashboardAttack, SlowClientsAndAConnectionFloodDoNotStopTheStation) {
  std::signal(SIGPIPE, SIG_IGN);
  StationConfig config = station_config();
  config.dashboard.enabled = true;
  config.dds.security.enabled = false;  // the dashboard is what this test is about
  fs::create_directories(station_dir());
  const fs::path yaml = run_dir_ / "station.yaml";
  std::ofstream(yaml) << to_yaml(config);
  // The station under a hard limit of 1,024 open files, as on many machines.
  mission::ChildProcess station(
      "ground_station",
      {"/usr/bin/prlimit", "--nofile=1024:1024", "--", KEYFLEET_STATION_BIN, "--config",
       yaml.string(), "--run-dir", station_dir().string()},
      (station_dir() / "station.log").string());
  const fs::path url_file = station_dir() / "dashboard.url";
  wait_until([&] { return !read_file(url_file).empty() || station.poll().has_value(); },
             milliseconds(30000));
  ASSERT_FALSE(read_file(url_file).empty()) << "no dashboard\n"
                                            << mission::tail_of_file(station.log_path(), 20);
  const std::string url = read_file(url_file);
  const int port = std::stoi(url.substr(url.rfind(':') + 1));

  std::atomic<bool> attacking{true};
  std::atomic<std::uint64_t> flood_connections{0};
  std::vector<std::thread> attackers;
  // Four heads that never end: a line each second.
  attackers.emplace_back([&] {
    std::vector<int> slow;
    for (int i = 0; i < 4; ++i) {
      const int fd = connect_from("127.0.0.1", port);
      const std::string head = "GET /api/summary HTTP/1.1\r\nHost: 127.0.0.1\r\n";
      if (fd >= 0) ::send(fd, head.data(), head.size(), MSG_NOSIGNAL);
      slow.push_back(fd);
    }
    while (attacking) {
      for (int& fd : slow) {
        if (fd < 0 || ::send(fd, "X-Slow: 1\r\n", 11, MSG_NOSIGNAL) < 0) {
          if (fd >= 0) ::close(fd);
          fd = connect_from("127.0.0.1", port);  // cut off: come back
        }
      }
      for (int i = 0; i < 10 && attacking; ++i) std::this_thread::sleep_for(milliseconds(100));
    }
    for (int fd : slow)
      if (fd >= 0) ::close(fd);
  });
  // Connections opened and closed as fast as they go.
  attackers.emplace_back([&] {
    while (attacking) {
      const int fd = connect_from("127.0.0.1", port);
      if (fd < 0) continue;
      ::close(fd);
      ++flood_connections;
    }
  });
  // Hundreds held open from eight addresses: more than the dashboard's whole bound.
  attackers.emplace_back([&] {
    std::vector<int> held;
    for (int round = 0; attacking && held.size() < 400; ++round) {
      const int fd = connect_from("127.0.0." + std::to_string(2 + round % 8), port);
      if (fd >= 0) held.push_back(fd);
    }
    while (attacking) std::this_thread::sleep_for(milliseconds(50));
    for (int fd : held) ::close(fd);
  });

  // Oversized requests cost the station no memory: a body streamed after its head, and a head
  // of endless fields, each sent until the station closes the connection.
  const auto rss_before = resident_kib(station.pid());
  std::uint64_t body_sent = send_until_closed(
      port, "POST /api/summary HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 1073741824\r\n\r\n",
      std::string(1 << 16, 'x'));
  std::uint64_t fields_sent =
      send_until_closed(port, "GET /api/summary HTTP/1.1\r\nHost: 127.0.0.1\r\n", "X-Field: 1\r\n");
  const auto rss_after = resident_kib(station.pid());
  std::cout << "oversized requests: " << body_sent << " body bytes and " << fields_sent
            << " header bytes sent before the station closed; station RSS " << rss_before << " -> "
            << rss_after << " KiB\n";
  EXPECT_LT(body_sent, 64u << 20) << "the station kept reading a body";
  EXPECT_LT(fields_sent, 1u << 20) << "the station kept reading a head";
  EXPECT_LT(rss_after, rss_before + 32 * 1024) << "oversized requests grew the station";

  const auto flood_start = std::chrono::steady_clock::now();
  ASSERT_TRUE(wait_until([&] { return flood_connections > 1100; }, milliseconds(60000)));
  // An ordinary client from an address of its own gets an answer at once (the page, or 503
  // while every place is taken), never silence.
  const std::string status = status_line("127.0.0.20", port, milliseconds(5000));
  EXPECT_TRUE(status.rfind("HTTP/1.1 200", 0) == 0 || status.rfind("HTTP/1.1 503", 0) == 0)
      << "'" << status << "'";

  // A robot flies through the attack: every keyframe stored and acknowledged.
  AgentConfig agent = agent_config("drone_0");
  agent.dds.security.enabled = false;
  auto robot = start_agent(agent);
  const auto robot_status = robot->wait_for(seconds(120));
  ASSERT_TRUE(robot_status.has_value()) << "the robot did not finish";
  EXPECT_TRUE(robot_status->ok()) << mission::tail_of_file(robot->log_path(), 20);
  EXPECT_EQ(outbox_pending("drone_0"), 0) << "keyframes still waiting for the station";
  EXPECT_EQ(stored_counts()["drone_0"], outbox_created("drone_0"));
  EXPECT_GT(outbox_created("drone_0"), 0);

  // SIGTERM while the attack goes on: the station stops in time and writes its reports.
  const auto term = std::chrono::steady_clock::now();
  station.signal(SIGTERM);
  const auto station_status = station.wait_for(seconds(30));
  const auto now = std::chrono::steady_clock::now();
  std::cout << "attack: " << flood_connections << " connections opened and closed in "
            << std::chrono::duration<double>(now - flood_start).count()
            << " s, 400 held open from 8 addresses, 4 endless heads; robot: "
            << stored_counts()["drone_0"] << " of " << outbox_created("drone_0")
            << " keyframes stored and acknowledged; station stopped "
            << std::chrono::duration<double>(now - term).count() << " s after SIGTERM\n";
  attacking = false;
  for (auto& t : attackers) t.join();
  ASSERT_TRUE(station_status.has_value()) << "the station did not stop within 30 s of SIGTERM";
  EXPECT_TRUE(station_status->ok()) << mission::tail_of_file(station.log_path(), 20);
  EXPECT_TRUE(fs::exists(station_dir() / "report.txt"));
  EXPECT_TRUE(fs::exists(station_dir() / "report.json"));
  const std::string log = read_file(station.log_path());
  EXPECT_EQ(log.find("Too many open files"), std::string::npos) << "descriptors ran out";
  EXPECT_NE(log.find("refused"), std::string::npos) << "the dashboard's refusals are logged";
  EXPECT_LT(log.size(), 1u << 20) << "the attack flooded the log";
}

}  // namespace
}  // namespace keyfleet::testing
