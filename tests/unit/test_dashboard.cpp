// The dashboard's HTTP endpoints against a real server on an ephemeral localhost port, the
// event hub behind its server-sent events, and report.html.
#include <httplib.h>
#include <nlohmann/json.hpp>

#include <csignal>
#include <fstream>
#include <future>
#include <sstream>
#include <thread>

#include "keyfleet/common/config_error.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/station/analysis_store.hpp"
#include "keyfleet/station/keyframe_store.hpp"
#include "keyfleet/station/station_config.hpp"
#include "keyfleet/station/web/dashboard_server.hpp"
#include "keyfleet/station/web/event_hub.hpp"
#include "keyfleet/station/web/html_report.hpp"
#include "test_support.hpp"

namespace keyfleet::station::web {
namespace {

using nlohmann::json;

// A station database with two robots' keyframes, words read in some, and stats.
class DashboardTest : public ::testing::Test {
 protected:
  DashboardTest() {
    for (std::uint64_t s = 1; s <= 3; ++s) add_keyframe("drone_0", s);
    add_keyframe("drone_1", 1);
    analysis_.save(words_of("drone_0", 2, {"HOTEL", "BAKERY"}));
    analysis_.save(words_of("drone_1", 1, {"PHARMACY"}));
    AgentStats stats;
    stats.robot_id = "drone_0";
    stats.report_time_ns = 2'000'000'000;
    stats.frames_seen = 60;
    stats.stream_all_bytes = 600'000;
    stats.vslam_keyframe_bytes = 90'000;
    keyframes_.record_stats(stats);
  }

  void add_keyframe(const std::string& robot, std::uint64_t sequence) {
    Keyframe k = test::make_valid_keyframe(robot, sequence, 128, 96);
    k.capture_time_ns = static_cast<std::int64_t>(sequence) * 1'000'000'000;
    keyframes_.store(k, k.image.size() + 100, k.capture_time_ns + 5);
  }
  static AnalysisResult words_of(const std::string& robot, std::uint64_t sequence,
                                 const std::vector<std::string>& words) {
    AnalysisResult r;
    r.key = {robot, sequence};
    r.capture_time_ns = static_cast<std::int64_t>(sequence) * 1'000'000'000;
    int x = 4;
    for (const auto& w : words) {
      r.words.push_back(ReadWord{w, 0.9f, cv::Rect(x, 10, 40, 12)});
      x += 44;
    }
    return r;
  }
  std::unique_ptr<DashboardServer> serve(DashboardConfig config = {}) {
    config.update_period_s = 0.05;
    return std::make_unique<DashboardServer>(
        config, db_, [this] { return std::optional(live_); }, make_logger("test", "warn"));
  }
  static json get_json(httplib::Client& client, const std::string& path, int status = 200) {
    const auto res = client.Get(path.c_str());
    if (!res) throw std::runtime_error("no answer to " + path);
    EXPECT_EQ(res->status, status) << path << ": " << res->body;
    return json::parse(res->body);
  }

  test::TempDir dir_;
  std::string db_ = dir_.file("station.sqlite");
  KeyframeStore keyframes_{db_};
  AnalysisStore analysis_{db_};
  AnalysisPool::Counters live_{3, 1, 2, 0};
};

TEST_F(DashboardTest, ServesThePageAndASummaryOfTheRunWithTheLiveQueue) {
  auto server = serve();
  ASSERT_GT(server->port(), 0);
  EXPECT_EQ(server->url(), "http://127.0.0.1:" + std::to_string(server->port()) + "/");
  httplib::Client client("127.0.0.1", server->port());
  const auto page = client.Get("/");
  ASSERT_TRUE(page);
  EXPECT_NE(page->body.find("<script src=\"dashboard.js\">"), std::string::npos);
  EXPECT_EQ(client.Get("/dashboard.js")->status, 200);

  const json summary = get_json(client, "/api/summary");
  EXPECT_EQ(summary["keyframes"], 4);
  EXPECT_EQ(summary["live"], true);
  ASSERT_EQ(summary["robots"].size(), 2u);
  EXPECT_EQ(summary["robots"][0]["robot_id"], "drone_0");
  EXPECT_EQ(summary["robots"][0]["keyframes_stored"], 3);
  EXPECT_EQ(summary["robots"][0]["stream_all_bytes"], 600000);
  EXPECT_EQ(summary["fleet"]["keyframes_stored"], 4);
  EXPECT_EQ(summary["analysis"]["waiting"], 3);
  EXPECT_EQ(summary["analysis"]["running"], 1);
  EXPECT_EQ(summary["analysis"]["done"], 2);
  EXPECT_EQ(summary["analysis"]["unanalysed"], 2);
}

TEST_F(DashboardTest, KeyframesComeNewestFirstWithTheirWordsBoxed) {
  auto server = serve();
  httplib::Client client("127.0.0.1", server->port());
  const json doc = get_json(client, "/api/keyframes?robot=drone_0&limit=2");
  ASSERT_EQ(doc["keyframes"].size(), 2u);
  EXPECT_EQ(doc["keyframes"][0]["sequence"], 3);
  const json& second = doc["keyframes"][1];
  EXPECT_EQ(second["sequence"], 2);
  ASSERT_EQ(second["words"].size(), 2u);
  EXPECT_EQ(second["words"][0]["text"], "HOTEL");
  EXPECT_EQ(second["words"][0]["box"], json({4, 10, 40, 12}));
  const std::string figure = second["figure"];
  EXPECT_NE(figure.find("<rect class=\"word\" x=\"4\" y=\"10\""), std::string::npos) << figure;
  EXPECT_NE(figure.find("api/image?robot=drone_0&amp;sequence=2"), std::string::npos) << figure;
  get_json(client, "/api/keyframes", 400);
}

TEST_F(DashboardTest, ImagesAreTheStoredJpegsAndUnknownOnesAre404) {
  auto server = serve();
  httplib::Client client("127.0.0.1", server->port());
  const auto image = client.Get("/api/image?robot=drone_1&sequence=1");
  ASSERT_TRUE(image);
  EXPECT_EQ(image->status, 200);
  EXPECT_EQ(image->get_header_value("Content-Type"), "image/jpeg");
  const auto stored = keyframes_.load("drone_1", 1)->image;
  EXPECT_EQ(image->body, std::string(stored.begin(), stored.end()));
  get_json(client, "/api/image?robot=drone_1&sequence=9", 404);
  get_json(client, "/api/image?robot=drone_1", 400);
}

TEST_F(DashboardTest, WordSearchFindsTheKeyframeAndRefusesBadSyntax) {
  auto server = serve();
  httplib::Client client("127.0.0.1", server->port());
  const json doc = get_json(client, "/api/search?q=pharm*");
  ASSERT_EQ(doc["results"].size(), 1u);
  EXPECT_EQ(doc["results"][0]["robot_id"], "drone_1");
  EXPECT_EQ(doc["results"][0]["sequence"], 1);
  EXPECT_TRUE(get_json(client, "/api/search?q=castle")["results"].empty());
  EXPECT_NE(get_json(client, "/api/search?q=%22open", 400)["error"].get<std::string>().find("FTS5"),
            std::string::npos);
}

TEST_F(DashboardTest, WordsThatAreNotUtf8AreServedReplacedAndSuchQueriesRefused) {
  // A reader's output from a hostile picture: a cut sequence and bytes that are never UTF-8.
  analysis_.save(words_of("drone_0", 3, {"CAF\xC3", "\xFF\xFEX"}));
  auto server = serve();
  httplib::Client client("127.0.0.1", server->port());
  const json keyframes = get_json(client, "/api/keyframes?robot=drone_0");
  EXPECT_NE(keyframes.dump().find("CAF\xEF\xBF\xBD"), std::string::npos) << keyframes.dump();
  EXPECT_NE(keyframes.dump().find("\xEF\xBF\xBD\xEF\xBF\xBDX"), std::string::npos);
  EXPECT_EQ(get_json(client, "/api/map")["nodes"].size(), 4u);
  EXPECT_NE(get_json(client, "/api/search?q=%FF", 400)["error"].get<std::string>().find("UTF-8"),
            std::string::npos);
}

TEST_F(DashboardTest, WithoutATokenItAnswersOnlyToLoopbackNames) {
  auto server = serve();
  httplib::Client client("127.0.0.1", server->port());
  const std::string port = std::to_string(server->port());
  for (const std::string& host : std::vector<std::string>{"127.0.0.1:" + port, "localhost:" + port,
                                                          "LOCALHOST", "[::1]:" + port})
    EXPECT_EQ(client.Get("/api/map", {{"Host", host}})->status, 200) << host;
  // A name that re-resolved to 127.0.0.1 (DNS rebinding), or one that merely starts alike.
  for (const std::string& host : std::vector<std::string>{
           "attacker.example", "attacker.example:" + port, "localhost.attacker.example", ""})
    EXPECT_EQ(client.Get("/api/map", {{"Host", host}})->status, 403) << "'" << host << "'";
}

TEST_F(DashboardTest, EveryAnswerCarriesTheBrowserProtections) {
  DashboardConfig config;
  config.token = "correct-horse-battery";
  auto server = serve(config);
  httplib::Client client("127.0.0.1", server->port());
  for (const std::string path :
       {"/?token=correct-horse-battery", "/api/map?token=correct-horse-battery",
        "/api/image?robot=nobody&sequence=1&token=correct-horse-battery", "/api/map?token=wrong"}) {
    SCOPED_TRACE(path);
    const auto res = client.Get(path.c_str());
    ASSERT_TRUE(res);
    const std::string csp = res->get_header_value("Content-Security-Policy");
    EXPECT_NE(csp.find("frame-ancestors 'none'"), std::string::npos) << csp;
    EXPECT_NE(csp.find("script-src 'self'"), std::string::npos) << csp;
    EXPECT_EQ(res->get_header_value("X-Content-Type-Options"), "nosniff");
    EXPECT_EQ(res->get_header_value("Referrer-Policy"), "no-referrer");
  }
  // A token that is not URL-safe is percent-encoded in the URL the station prints.
  DashboardConfig odd;
  odd.token = "a b&c=d/e+f%g-hijk";
  auto odd_server = serve(odd);
  EXPECT_NE(odd_server->url().find("?token=a%20b%26c%3Dd%2Fe%2Bf%25g-hijk"), std::string::npos)
      << odd_server->url();
  httplib::Client odd_client("127.0.0.1", odd_server->port());
  EXPECT_EQ(odd_client.Get("/api/map?token=a%20b%26c%3Dd%2Fe%2Bf%25g-hijk")->status, 200);
  // No request body is read, whatever its size: with the token the answer is 413, without it
  // 401 (the token is checked before any body would be), or the connection is closed while
  // the client is still sending.
  const std::string body(1 << 20, 'x');
  std::signal(SIGPIPE, SIG_IGN);  // the server may close while the client still sends
  for (const auto& [path, refusal] :
       {std::pair<std::string, int>{"/api/map?token=correct-horse-battery", 413},
        std::pair<std::string, int>{"/api/map", 401}}) {
    httplib::Client poster("127.0.0.1", server->port());
    const auto posted = poster.Post(path.c_str(), body, "application/octet-stream");
    if (posted) {
      EXPECT_TRUE(posted->status == refusal || posted->status == 413)
          << path << ": " << posted->status;
    }
  }
  EXPECT_EQ(client.Get("/api/map?token=correct-horse-battery")->status, 200) << "still serving";
  // The token is compared whole: a prefix, a longer string or another of the same length fail.
  EXPECT_EQ(client.Get("/api/map?token=correct-horse")->status, 401);
  EXPECT_EQ(client.Get("/api/map?token=correct-horse-battery-x")->status, 401);
  EXPECT_EQ(client.Get("/api/map?token=correct-horse-batterz")->status, 401);
  EXPECT_EQ(client.Get("/api/map?token=correct-horse-battery")->status, 200);
}

TEST_F(DashboardTest, MapAndBandwidthComeAsJsonAndSvg) {
  auto server = serve();
  httplib::Client client("127.0.0.1", server->port());
  const json map = get_json(client, "/api/map");
  EXPECT_EQ(map["nodes"].size(), 4u);
  EXPECT_EQ(map["edges"].size(), 2u);  // drone_0's three keyframes in time
  const auto svg = client.Get("/api/map.svg");
  EXPECT_EQ(svg->get_header_value("Content-Type"), "image/svg+xml");
  EXPECT_EQ(svg->body.rfind("<svg", 0), 0u);
  EXPECT_NE(svg->body.find("placed by pose"), std::string::npos);
  const auto plot = client.Get("/api/bandwidth.svg");
  EXPECT_NE(plot->body.find("<polyline"), std::string::npos);
  EXPECT_NE(plot->body.find("drone_1"), std::string::npos);
}

TEST_F(DashboardTest, BoundWiderItNeedsItsTokenOnEveryRequest) {
  DashboardConfig config;
  config.address = "0.0.0.0";
  config.token = "s3cret";  // too short to be one
  EXPECT_THROW(serve(config), StartupError);
  config.token = "s3cret-s3cret-s3cret";
  auto server = serve(config);
  EXPECT_NE(server->url().find("?token=s3cret-s3cret-s3cret"), std::string::npos);
  httplib::Client client("127.0.0.1", server->port());
  EXPECT_EQ(client.Get("/api/summary")->status, 401);
  EXPECT_EQ(client.Get("/")->status, 401);
  EXPECT_EQ(client.Get("/api/summary?token=wrong")->status, 401);
  EXPECT_EQ(client.Get("/api/summary?token=s3cret-s3cret-s3cret")->status, 200);
  EXPECT_EQ(client.Get("/api/summary", {{"Authorization", "Bearer s3cret-s3cret-s3cret"}})->status,
            200);
}

TEST_F(DashboardTest, BoundWiderWithoutATokenItGeneratesAStrongOne) {
  DashboardConfig config;
  config.address = "0.0.0.0";
  auto first = serve(config);
  auto second = serve(config);
  const std::string url = first->url();
  const auto at = url.find("?token=");
  ASSERT_NE(at, std::string::npos) << url;
  const std::string token = url.substr(at + 7);
  EXPECT_EQ(token.size(), 64u);  // 32 random bytes in hex
  EXPECT_EQ(token.find_first_not_of("0123456789abcdef"), std::string::npos) << token;
  EXPECT_EQ(second->url().find(token), std::string::npos) << "two stations, one token";
  httplib::Client client("127.0.0.1", first->port());
  EXPECT_EQ(client.Get("/api/summary")->status, 401);
  EXPECT_EQ(client.Get(("/api/summary?token=" + token).c_str())->status, 200);
}

TEST_F(DashboardTest, OpenPagesAreSentTheSummaryAndEachChange) {
  auto server = serve();
  httplib::Client client("127.0.0.1", server->port());
  client.set_read_timeout(20, 0);
  std::vector<json> events;
  std::string buffer;
  bool stored = false;
  // Reads events until one shows the keyframe stored after the first event.
  const auto res = client.Get("/api/events", [&](const char* data, std::size_t size) {
    buffer.append(data, size);
    for (auto end = buffer.find("\n\n"); end != std::string::npos; end = buffer.find("\n\n")) {
      const std::string event = buffer.substr(0, end);
      buffer.erase(0, end + 2);
      const auto at = event.find("data: ");
      if (at != std::string::npos) events.push_back(json::parse(event.substr(at + 6)));
    }
    if (!events.empty() && !stored) {
      add_keyframe("drone_1", 2);
      server->poke();
      stored = true;
    }
    return events.empty() || events.back()["keyframes"] != 5;
  });
  ASSERT_GE(events.size(), 2u);
  EXPECT_EQ(events.front()["keyframes"], 4);
  EXPECT_EQ(events.back()["keyframes"], 5);
  EXPECT_EQ(events.back()["robots"][1]["keyframes_stored"], 2);
}

TEST_F(DashboardTest, StopEndsOpenEventStreams) {
  auto server = serve();
  httplib::Client client("127.0.0.1", server->port());
  client.set_read_timeout(20, 0);
  std::promise<void> opened;
  std::thread reader([&] {
    bool first = true;
    client.Get("/api/events", [&](const char*, std::size_t) {
      if (first) opened.set_value();
      first = false;
      return true;
    });
  });
  // Once the first event has arrived the stream is open: stop must not hang on it.
  EXPECT_EQ(opened.get_future().wait_for(std::chrono::seconds(20)), std::future_status::ready);
  const auto start = std::chrono::steady_clock::now();
  server->stop();
  reader.join();
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(10));
}

TEST(EventHub, ReadersGetTheNewestEventOnceAndCloseWakesThem) {
  EventHub hub;
  EXPECT_FALSE(hub.next(0, std::chrono::milliseconds(1)));
  EXPECT_TRUE(hub.publish("a"));
  EXPECT_FALSE(hub.publish("a"));  // unchanged: nothing new to send
  EXPECT_TRUE(hub.publish("b"));
  const auto latest = hub.next(0, std::chrono::milliseconds(1));
  ASSERT_TRUE(latest);
  EXPECT_EQ(latest->data, "b");
  EXPECT_FALSE(hub.next(latest->id, std::chrono::milliseconds(1)));
  std::thread closer([&] { hub.close(); });
  EXPECT_FALSE(hub.next(latest->id, std::chrono::seconds(30)));
  closer.join();
  EXPECT_TRUE(hub.closed());
}

TEST(DashboardConfig, OffLoopbackTokensMustBeStrongAndBadValuesAreRefused) {
  EXPECT_NO_THROW(parse_station_config("dashboard: {address: 127.0.0.2, port: 8080}", "t"));
  // Off loopback without a token the station generates one; a given token must be strong.
  EXPECT_NO_THROW(parse_station_config("dashboard: {address: 0.0.0.0}", "t"));
  EXPECT_THROW(parse_station_config("dashboard: {address: 0.0.0.0, token: x}", "t"), ConfigError);
  EXPECT_THROW(parse_station_config("dashboard: {token: fifteen-chars-x}", "t"), ConfigError);
  EXPECT_NO_THROW(parse_station_config("dashboard: {token: sixteen-chars-xx}", "t"));
  EXPECT_THROW(parse_station_config("dashboard: {max_connections: 8, max_event_streams: 8}", "t"),
               ConfigError);
  EXPECT_THROW(
      parse_station_config("dashboard: {max_connections: 8, max_connections_per_client: 9}", "t"),
      ConfigError);
  EXPECT_NO_THROW(parse_station_config("dashboard: {address: 0.0.0.0, enabled: false}", "t"));
  EXPECT_THROW(parse_station_config("dashboard: {port: 70000}", "t"), ConfigError);
  EXPECT_THROW(parse_station_config("dashboard: {update_period_s: .nan}", "t"), ConfigError);
  EXPECT_THROW(parse_station_config("dashboard: {colour: red}", "t"), ConfigError);
  EXPECT_FALSE(is_loopback_address("127.evil.example"));
  EXPECT_TRUE(is_loopback_address("localhost"));
}

TEST_F(DashboardTest, ReportHtmlIsSelfContained) {
  const std::string path = dir_.file("report.html");
  write_html_report({"run-1", db_, "", "robot stored\nFLEET 4\n"}, path);
  std::stringstream html;
  html << std::ifstream(path).rdbuf();
  const std::string text = html.str();
  EXPECT_NE(text.find("FLEET 4"), std::string::npos);
  EXPECT_NE(text.find("data:image/jpeg;base64,"), std::string::npos);
  EXPECT_NE(text.find("<polyline"), std::string::npos);
  EXPECT_NE(text.find("class=\"node\""), std::string::npos);
  EXPECT_NE(text.find("BAKERY"), std::string::npos);
  EXPECT_EQ(text.find("src=\"http"), std::string::npos);
  EXPECT_EQ(text.find("href=\"http"), std::string::npos);
}

TEST(Base64, MatchesRfc4648) {
  auto b64 = [](const std::string& s) { return base64({s.begin(), s.end()}); };
  EXPECT_EQ(b64(""), "");
  EXPECT_EQ(b64("f"), "Zg==");
  EXPECT_EQ(b64("fo"), "Zm8=");
  EXPECT_EQ(b64("foo"), "Zm9v");
  EXPECT_EQ(b64("foobar"), "Zm9vYmFy");
}

}  // namespace
}  // namespace keyfleet::station::web
