#include "keyfleet/station/web/dashboard_server.hpp"

#include <sys/resource.h>

#include <random>

#include "assets.hpp"
#include "http_server.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/common/thread_name.hpp"
#include "keyfleet/station/web/figures.hpp"
#include "keyfleet/station/web/run_view.hpp"

namespace keyfleet::station::web {
namespace {

using std::chrono::milliseconds;

std::string content_type_of(const std::string& path) {
  if (path.size() > 4 && path.compare(path.size() - 4, 4, ".css") == 0) return "text/css";
  if (path.size() > 3 && path.compare(path.size() - 3, 3, ".js") == 0)
    return "application/javascript";
  return "text/html; charset=utf-8";
}

nlohmann::json word_json(const StoredWord& w) {
  return {{"robot_id", w.keyframe.robot_id},
          {"sequence", w.keyframe.sequence},
          {"text", w.text},
          {"confidence", w.confidence},
          {"box", {w.box.x, w.box.y, w.box.width, w.box.height}}};
}

std::string image_href(const StoredKeyframeInfo& k) {
  return "api/image?robot=" + k.robot_id + "&sequence=" + std::to_string(k.sequence);
}

nlohmann::json card_json(const KeyframeCard& card) {
  nlohmann::json words = nlohmann::json::array();
  for (const StoredWord& w : card.words) words.push_back(word_json(w));
  return {{"robot_id", card.info.robot_id},
          {"sequence", card.info.sequence},
          {"capture_time_ns", card.info.capture_time_ns},
          {"received_ns", card.info.received_ns},
          {"words", words},
          {"figure", keyframe_figure(card, image_href(card.info))}};
}

std::size_t size_param(const HttpRequest& req, const char* name, std::size_t fallback,
                       std::size_t most) {
  if (!req.has_param(name)) return fallback;
  try {
    return std::min<std::size_t>(std::stoul(req.param(name)), most);
  } catch (const std::exception&) {
    return fallback;
  }
}

// Words are what a reader made of a picture and queries what a client sent: not always UTF-8,
// which JSON needs. Each invalid byte is sent as U+FFFD instead of failing the request.
std::string json_text(const nlohmann::json& doc) {
  return doc.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

// RFC 3986: everything but the unreserved characters as %XX, so any token survives a URL.
std::string percent_encoded(const std::string& text) {
  static const char* kHex = "0123456789ABCDEF";
  std::string out;
  for (const char c : text) {
    const auto byte = static_cast<unsigned char>(c);
    if (std::isalnum(byte) || c == '-' || c == '.' || c == '_' || c == '~') {
      out += c;
    } else {
      out += '%';
      out += kHex[byte >> 4];
      out += kHex[byte & 0x0F];
    }
  }
  return out;
}

// A Host header naming this machine's loopback (is_loopback_address), with or without a port.
bool is_loopback_host(const std::string& host) {
  std::string name = host;
  if (!name.empty() && name.front() == '[') {
    const auto end = name.find(']');  // "[::1]:8080" -> "::1"
    name = end == std::string::npos ? std::string() : name.substr(1, end - 1);
  } else if (const auto colon = name.find(':'); colon != std::string::npos) {
    name = name.substr(0, colon);
  }
  for (auto& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return is_loopback_address(name);
}

// Compares in time that depends on the lengths only, not on where the first difference is.
bool same_secret(const std::string& given, const std::string& secret) {
  unsigned char differ = given.size() == secret.size() ? 0 : 1;
  for (std::size_t i = 0; i < given.size(); ++i)
    differ |=
        static_cast<unsigned char>(given[i] ^ secret[i % std::max<std::size_t>(secret.size(), 1)]);
  return differ == 0 && !secret.empty();
}

bool is_utf8(const std::string& text) {
  try {
    (void)nlohmann::json(text).dump();
    return true;
  } catch (const nlohmann::json::type_error&) {
    return false;
  }
}

HttpResponse json_answer(const nlohmann::json& doc, int status = 200) {
  return {status, "application/json", json_text(doc), {}, false};
}

HttpResponse error_answer(int status, const std::string& message) {
  return json_answer({{"error", message}}, status);
}

// 32 bytes from the system's random source, as 64 hex digits.
std::string generated_token() {
  std::random_device source;  // getrandom(2) on Linux
  static const char* kHex = "0123456789abcdef";
  std::string token;
  for (int i = 0; i < 8; ++i) {
    const std::uint32_t word = source();
    for (int nibble = 0; nibble < 8; ++nibble) token += kHex[(word >> (4 * nibble)) & 0xF];
  }
  return token;
}

// File descriptors the dashboard's connections may hold: what is left of the process's limit
// after those kept for DDS, the databases, the reports and the logs (kReservedDescriptors),
// and never more than `wanted`.
constexpr std::size_t kReservedDescriptors = 512;

std::size_t connection_budget(std::size_t wanted, const Logger& logger) {
  rlimit limit{};
  // The process's soft limit, as its main left it (raise_open_file_limit).
  if (getrlimit(RLIMIT_NOFILE, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return wanted;
  const std::size_t spare = limit.rlim_cur > 2 * kReservedDescriptors
                                ? limit.rlim_cur - kReservedDescriptors
                                : limit.rlim_cur / 2;
  if (spare >= wanted) return wanted;
  logger->warn("dashboard: {} connections at most (open-file limit {}, {} kept for the station)",
               spare, static_cast<unsigned long long>(limit.rlim_cur), limit.rlim_cur - spare);
  return std::max<std::size_t>(spare, 4);
}

// On every answer, errors and the server's own refusals included: scripts only from the page's
// own origin, no framing (the dashboard cannot be clicked through from another page), types as
// sent, no referrer (the token travels in the URL).
HttpHeaders browser_protections() {
  return {{"Content-Security-Policy",
           "default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; "
           "img-src 'self' data:; object-src 'none'; base-uri 'none'; "
           "form-action 'self'; frame-ancestors 'none'"},
          {"X-Content-Type-Options", "nosniff"},
          {"X-Frame-Options", "DENY"},
          {"Referrer-Policy", "no-referrer"}};
}

}  // namespace

DashboardServer::DashboardServer(const DashboardConfig& config, const std::string& database,
                                 LiveQueue live, Logger logger)
    : config_(config), live_(std::move(live)), logger_(std::move(logger)) {
  if (!config_.token.empty() && config_.token.size() < DashboardConfig::kMinTokenLength)
    throw StartupError("dashboard: the token is shorter than " +
                       std::to_string(DashboardConfig::kMinTokenLength) + " characters");
  if (!is_loopback_address(config_.address) && config_.token.empty()) {
    config_.token = generated_token();
    logger_->info("dashboard: serving {} with a generated token (see the printed URL)",
                  config_.address);
  }
  try {
    view_ = std::make_unique<RunView>(database);
  } catch (const std::exception& e) {
    throw StartupError("dashboard: cannot open " + database + ": " + e.what());
  }
  HttpLimits limits;
  limits.max_connections =
      connection_budget(static_cast<std::size_t>(config_.max_connections), logger_);
  limits.max_connections_per_client = std::min(
      limits.max_connections, static_cast<std::size_t>(config_.max_connections_per_client));
  limits.max_event_streams =
      std::min(limits.max_connections - 1, static_cast<std::size_t>(config_.max_event_streams));
  limits.request_timeout =
      std::chrono::milliseconds(static_cast<long>(config_.request_timeout_s * 1000));
  limits.threads = config_.threads;
  server_ = std::make_unique<HttpServer>(
      config_.address, config_.port, limits,
      [this](const HttpRequest& request) { return answer(request); }, browser_protections(),
      logger_);
  port_ = server_->port();
  publisher_ = std::thread([this] {
    name_this_thread("dashboard");
    publish_loop();
  });
}

DashboardServer::~DashboardServer() { stop(); }

std::string DashboardServer::url() const {
  const std::string host = config_.address == "0.0.0.0" ? "127.0.0.1" : config_.address;
  return "http://" + host + ":" + std::to_string(port_) + "/" +
         (config_.token.empty() ? "" : "?token=" + percent_encoded(config_.token));
}

void DashboardServer::poke() {
  {
    std::lock_guard<std::mutex> lock(poke_mutex_);
    poke_ = true;
  }
  poked_.notify_one();
}

void DashboardServer::stop() {
  if (stopping_.exchange(true)) return;
  poke();
  if (publisher_.joinable()) publisher_.join();
  server_->stop();
  const HttpCounters c = server_->counters();
  if (c.refused_busy + c.refused_streams + c.refused_requests + c.timed_out + c.descriptor_waits >
      0)
    logger_->info(
        "dashboard: {} connections; refused {} when busy, {} live pages over the bound, {} bad "
        "or oversized requests; {} timed out; {} accept pauses for file descriptors",
        c.connections, c.refused_busy, c.refused_streams, c.refused_requests, c.timed_out,
        c.descriptor_waits);
}

bool DashboardServer::authorised(const std::string& token_param,
                                 const std::string& authorization) const {
  if (config_.token.empty()) return true;
  return same_secret(token_param, config_.token) ||
         same_secret(authorization, "Bearer " + config_.token);
}

// While a page is open: recomputes the summary every update period, or at once when poked;
// pages get it when it changed. With no page open the station pays nothing for it.
void DashboardServer::publish_loop() {
  const auto period = milliseconds(static_cast<long>(config_.update_period_s * 1000));
  while (!stopping_) {
    try {
      if (server_->open_event_streams() > 0) publish_summary();
    } catch (const std::exception& e) {
      logger_->warn("dashboard: summary not updated: {}", e.what());
    }
    std::unique_lock<std::mutex> lock(poke_mutex_);
    poked_.wait_for(lock, period, [this] { return poke_ || stopping_; });
    poke_ = false;
  }
}

// From the publisher and from a page opening: one at a time, so that pages get the summaries in
// the order they were taken.
void DashboardServer::publish_summary() {
  std::lock_guard<std::mutex> publishing(publish_mutex_);
  const auto live = live_ ? live_() : std::nullopt;
  std::string summary;
  {
    std::lock_guard<std::mutex> lock(view_mutex_);
    summary = json_text(view_->summary(live));
  }
  if (events_.publish(summary)) server_->broadcast(event_text(events_.latest()));
}

std::string DashboardServer::event_text(const EventHub::Event& event) {
  return "id: " + std::to_string(event.id) + "\nevent: summary\ndata: " + event.data + "\n\n";
}

HttpResponse DashboardServer::answer(const HttpRequest& req) {
  // Without a token the dashboard serves loopback only, and only under a loopback name: a
  // page from elsewhere whose name re-resolves to 127.0.0.1 (DNS rebinding) is refused.
  if (config_.token.empty() && !is_loopback_host(req.host))
    return error_answer(403, "this dashboard answers to localhost, 127.0.0.1 or [::1] only");
  if (!authorised(req.param("token"), req.authorization))
    return error_answer(401, "this dashboard needs its token: open it with ?token=...");
  if (req.method != "GET") return error_answer(405, "this dashboard only answers GET");
  const std::string path = req.path == "/" ? "/dashboard.html" : req.path;
  for (const auto& [asset, content] : page_assets())
    if (asset == path) return {200, content_type_of(asset), content, {}, false};
  if (path == "/api/events") return open_events();
  try {
    std::lock_guard<std::mutex> lock(view_mutex_);  // one database connection for all threads
    return data_answer(path, req);
  } catch (const std::exception& e) {
    return error_answer(500, e.what());
  }
}

// A new page starts with a fresh summary; later ones come by broadcast.
HttpResponse DashboardServer::open_events() {
  publish_summary();
  HttpResponse res{200, "text/event-stream", event_text(events_.latest()), {}, true};
  res.headers.push_back({"Cache-Control", "no-cache"});
  return res;
}

HttpResponse DashboardServer::data_answer(const std::string& path, const HttpRequest& req) {
  if (path == "/api/summary") return json_answer(view_->summary(live_ ? live_() : std::nullopt));
  if (path == "/api/keyframes") {
    const std::string robot = req.param("robot");
    if (robot.empty()) return error_answer(400, "robot=ROBOT is required");
    const std::size_t limit =
        size_param(req, "limit", std::size_t(config_.thumbnails_per_robot), 1000);
    nlohmann::json list = nlohmann::json::array();
    for (const KeyframeCard& card : view_->keyframes(robot, std::max<std::size_t>(limit, 1)))
      list.push_back(card_json(card));
    return json_answer({{"robot_id", robot}, {"keyframes", list}});
  }
  if (path == "/api/image") {
    KeyframeKey key{req.param("robot"), 0};
    try {
      key.sequence = std::stoull(req.param("sequence"));
    } catch (const std::exception&) {
      return error_answer(400, "sequence=N is required");
    }
    const auto jpeg = view_->jpeg(key);
    if (!jpeg) return error_answer(404, "no keyframe " + to_string(key));
    // Stored keyframes never change.
    return {200,
            "image/jpeg",
            std::string(jpeg->begin(), jpeg->end()),
            {{"Cache-Control", "max-age=86400"}},
            false};
  }
  if (path == "/api/search") {
    const std::string query = req.param("q");
    if (query.empty()) return error_answer(400, "q=WORD is required");
    if (!is_utf8(query)) return error_answer(400, "q= is not UTF-8 text");
    std::vector<StoredWord> words;
    try {
      words = view_->search(query, size_param(req, "limit", 50, 500));
    } catch (const std::exception&) {
      return error_answer(400, "not a valid search (FTS5 syntax): " + query);
    }
    nlohmann::json results = nlohmann::json::array();
    for (const StoredWord& w : words) results.push_back(word_json(w));
    return json_answer({{"query", query}, {"results", results}});
  }
  if (path == "/api/map") return json_answer(view_->map());
  if (path == "/api/map.svg") return {200, "image/svg+xml", map_svg(view_->map()), {}, false};
  if (path == "/api/bandwidth.svg")
    return {200, "image/svg+xml", bandwidth_svg(view_->bandwidth_timeline()), {}, false};
  return error_answer(404, "no such page: " + path);
}

}  // namespace keyfleet::station::web
