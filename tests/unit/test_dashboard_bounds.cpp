// The dashboard against clients that try to take the station's resources: slow and endless
// request heads, too many connections (from one address and in all), bodies, oversized heads,
// many live pages, and a stop while such clients hang on. Real server, raw sockets on 127.0.0.x.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <httplib.h>
#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "keyfleet/common/logging.hpp"
#include "keyfleet/station/analysis_store.hpp"
#include "keyfleet/station/dashboard_config.hpp"
#include "keyfleet/station/keyframe_store.hpp"
#include "keyfleet/station/web/dashboard_server.hpp"
#include "test_support.hpp"

namespace keyfleet::station::web {
namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

// A TCP client that sends what the test says, when it says, from a chosen loopback address.
class RawClient {
 public:
  RawClient(int port, const std::string& from = "127.0.0.1") {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in local{};
    local.sin_family = AF_INET;
    ::inet_pton(AF_INET, from.c_str(), &local.sin_addr);
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&local), sizeof local) != 0)
      throw std::runtime_error("cannot bind to " + from + ": " + std::strerror(errno));
    sockaddr_in server{};
    server.sin_family = AF_INET;
    server.sin_port = htons(static_cast<std::uint16_t>(port));
    ::inet_pton(AF_INET, "127.0.0.1", &server.sin_addr);
    if (::connect(fd_, reinterpret_cast<sockaddr*>(&server), sizeof server) != 0)
      throw std::runtime_error("cannot connect");
  }
  ~RawClient() { ::close(fd_); }
  RawClient(const RawClient&) = delete;
  RawClient& operator=(const RawClient&) = delete;

  bool send(const std::string& text) {
    return ::send(fd_, text.data(), text.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(text.size());
  }
  // What arrives within `timeout`, until `until` is in it or the server closes (closed()).
  std::string read(milliseconds timeout, const std::string& until = "") {
    const auto deadline = Clock::now() + timeout;
    while (!closed_ && (until.empty() || received_.find(until) == std::string::npos)) {
      const auto left = std::chrono::duration_cast<milliseconds>(deadline - Clock::now()).count();
      if (left <= 0) break;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left)) <= 0) continue;
      char buffer[4096];
      const ssize_t n = ::recv(fd_, buffer, sizeof buffer, 0);
      if (n <= 0) {
        closed_ = true;
      } else {
        received_.append(buffer, static_cast<std::size_t>(n));
      }
    }
    return received_;
  }
  bool closed() const { return closed_; }

 private:
  int fd_ = -1;
  std::string received_;
  bool closed_ = false;
};

const std::string kHead = "GET /api/summary HTTP/1.1\r\nHost: 127.0.0.1\r\n";

class DashboardBounds : public ::testing::Test {
 protected:
  DashboardBounds() {
    Keyframe k = test::make_valid_keyframe("drone_0", 1, 64, 48);
    keyframes_.store(k, k.image.size(), 1);
  }
  std::unique_ptr<DashboardServer> serve(DashboardConfig config) {
    config.update_period_s = 0.05;
    return std::make_unique<DashboardServer>(config, db_, nullptr, make_logger("test", "warn"));
  }
  // An authorised request from an ordinary client: its status, or 0 without an answer.
  static int summary_status(int port) {
    httplib::Client client("127.0.0.1", port);
    client.set_connection_timeout(2, 0);
    client.set_read_timeout(2, 0);
    const auto res = client.Get("/api/summary");
    return res ? res->status : 0;
  }

  test::TempDir dir_;
  std::string db_ = dir_.file("station.sqlite");
  KeyframeStore keyframes_{db_};
  AnalysisStore analysis_{db_};
};

TEST_F(DashboardBounds, SlowRequestHeadsAreCutOffWhileOthersAreServed) {
  DashboardConfig config;
  config.request_timeout_s = 0.5;
  auto server = serve(config);
  // Six clients whose heads never end, one line every 100 ms: each line arrives in time, the
  // whole head does not.
  std::vector<std::unique_ptr<RawClient>> slow;
  for (int i = 0; i < 6; ++i) {
    slow.push_back(std::make_unique<RawClient>(server->port()));
    ASSERT_TRUE(slow.back()->send(kHead));
  }
  const auto start = Clock::now();
  EXPECT_EQ(summary_status(server->port()), 200) << "served while the slow heads hang";
  bool all_closed = false;
  while (!all_closed && Clock::now() - start < std::chrono::seconds(5)) {
    all_closed = true;
    for (auto& client : slow) {
      client->send("X-Slow: 1\r\n");
      client->read(milliseconds(100));
      all_closed = all_closed && client->closed();
    }
  }
  EXPECT_TRUE(all_closed) << "a head still open after 5 s with a 0.5 s request timeout";
  EXPECT_LT(Clock::now() - start, std::chrono::seconds(3));
}

TEST_F(DashboardBounds, ConnectionsAreBoundedPerClientAndInAll) {
  DashboardConfig config;
  config.max_connections = 8;
  config.max_connections_per_client = 4;
  config.max_event_streams = 2;
  config.request_timeout_s = 30;  // the idle connections stay
  auto server = serve(config);
  std::vector<std::unique_ptr<RawClient>> idle;
  for (int i = 0; i < 4; ++i) idle.push_back(std::make_unique<RawClient>(server->port()));
  // One address over its share: 503 at once, while another address is served.
  RawClient fifth(server->port());
  const std::string refused = fifth.read(milliseconds(3000), "\r\n\r\n");
  EXPECT_EQ(refused.rfind("HTTP/1.1 503", 0), 0u) << refused;
  EXPECT_NE(refused.find("Retry-After"), std::string::npos);
  EXPECT_NE(refused.find("Content-Security-Policy"), std::string::npos) << "on refusals too";
  RawClient other(server->port(), "127.0.0.2");
  ASSERT_TRUE(other.send(kHead + "\r\n"));
  EXPECT_EQ(other.read(milliseconds(3000), "\r\n\r\n").rfind("HTTP/1.1 200", 0), 0u);
  // All connections in use (4 + 4 from two addresses): a third address is refused too.
  for (int i = 0; i < 3; ++i)
    idle.push_back(std::make_unique<RawClient>(server->port(), "127.0.0.2"));
  RawClient third(server->port(), "127.0.0.3");
  EXPECT_EQ(third.read(milliseconds(3000), "\r\n\r\n").rfind("HTTP/1.1 503", 0), 0u);
  // Closed connections free their places.
  idle.clear();
  const auto deadline = Clock::now() + std::chrono::seconds(5);
  int status = 0;
  while (status != 200 && Clock::now() < deadline) status = summary_status(server->port());
  EXPECT_EQ(status, 200);
}

TEST_F(DashboardBounds, OversizedHeadsAndBodiesAreRefusedUnread) {
  auto server = serve({});
  RawClient long_head(server->port());
  long_head.send(kHead + "X-Long: " + std::string(9000, 'a') + "\r\n\r\n");
  EXPECT_EQ(long_head.read(milliseconds(3000), "\r\n\r\n").rfind("HTTP/1.1 431", 0), 0u);
  RawClient many_fields(server->port());
  std::string head = kHead;
  for (int i = 0; i < 100; ++i) head += "X-" + std::to_string(i) + ": 1\r\n";
  many_fields.send(head + "\r\n");
  EXPECT_EQ(many_fields.read(milliseconds(3000), "\r\n\r\n").rfind("HTTP/1.1 431", 0), 0u);
  // A gigabyte announced, none sent: refused at once, the connection closed.
  RawClient big_body(server->port());
  big_body.send(
      "POST /api/summary HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 1073741824\r\n\r\n");
  EXPECT_EQ(big_body.read(milliseconds(3000)).rfind("HTTP/1.1 413", 0), 0u);
  EXPECT_TRUE(big_body.closed());
  RawClient chunked(server->port());
  chunked.send("POST / HTTP/1.1\r\nHost: 127.0.0.1\r\nTransfer-Encoding: chunked\r\n\r\n");
  EXPECT_EQ(chunked.read(milliseconds(3000)).rfind("HTTP/1.1 413", 0), 0u);
  // Only GET is answered.
  RawClient head_request(server->port());
  head_request.send("HEAD /api/summary HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n");
  EXPECT_EQ(head_request.read(milliseconds(3000), "\r\n\r\n").rfind("HTTP/1.1 405", 0), 0u);
  EXPECT_EQ(summary_status(server->port()), 200);
}

TEST_F(DashboardBounds, LivePagesHoldNoThreadAndBeyondTheirBoundAreRefused) {
  DashboardConfig config;
  config.threads = 1;
  config.max_event_streams = 5;
  auto server = serve(config);
  // Five open live pages on one handler thread: each gets its summary, and the rest of the
  // page still answers.
  std::vector<std::unique_ptr<RawClient>> pages;
  for (int i = 0; i < 5; ++i) {
    pages.push_back(std::make_unique<RawClient>(server->port()));
    pages.back()->send("GET /api/events HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n");
    const std::string first = pages.back()->read(milliseconds(5000), "\"keyframes\":1");
    EXPECT_NE(first.find("text/event-stream"), std::string::npos) << first;
    EXPECT_NE(first.find("\"keyframes\":1"), std::string::npos) << first;
  }
  EXPECT_EQ(summary_status(server->port()), 200);
  RawClient sixth(server->port());
  sixth.send("GET /api/events HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n");
  EXPECT_EQ(sixth.read(milliseconds(3000), "\r\n\r\n").rfind("HTTP/1.1 503", 0), 0u);
  // A change reaches every open page.
  Keyframe k = test::make_valid_keyframe("drone_0", 2, 64, 48);
  keyframes_.store(k, k.image.size(), 2);
  server->poke();
  for (auto& page : pages)
    EXPECT_NE(page->read(milliseconds(5000), "\"keyframes\":2").find("\"keyframes\":2"),
              std::string::npos);
  // A closed page frees its place at once.
  pages.pop_back();
  const auto deadline = Clock::now() + std::chrono::seconds(5);
  bool reopened = false;
  while (!reopened && Clock::now() < deadline) {
    RawClient again(server->port());
    again.send("GET /api/events HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n");
    reopened = again.read(milliseconds(1000), "\r\n\r\n").rfind("HTTP/1.1 200", 0) == 0;
  }
  EXPECT_TRUE(reopened);
}

TEST_F(DashboardBounds, StopDoesNotWaitForClients) {
  auto server = serve({});
  std::vector<std::unique_ptr<RawClient>> clients;
  for (int i = 0; i < 4; ++i) {
    clients.push_back(std::make_unique<RawClient>(server->port()));
    clients.back()->send(kHead);  // a head that never ends
  }
  for (int i = 0; i < 3; ++i) {
    clients.push_back(std::make_unique<RawClient>(server->port()));
    clients.back()->send("GET /api/events HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n");
    clients.back()->read(milliseconds(5000), "data: ");
  }
  const auto start = Clock::now();
  server->stop();
  EXPECT_LT(Clock::now() - start, std::chrono::seconds(1));
  for (auto& client : clients) {
    client->read(milliseconds(3000), "\xff");
    EXPECT_TRUE(client->closed());
  }
}

}  // namespace
}  // namespace keyfleet::station::web
