#include "keyfleet/station/web/dashboard_server.hpp"

#include <httplib.h>

#include "assets.hpp"
#include "keyfleet/common/error.hpp"
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

std::size_t size_param(const httplib::Request& req, const char* name, std::size_t fallback,
                       std::size_t most) {
  if (!req.has_param(name)) return fallback;
  try {
    return std::min<std::size_t>(std::stoul(req.get_param_value(name)), most);
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

void send_json(httplib::Response& res, const nlohmann::json& doc) {
  res.set_content(json_text(doc), "application/json");
}

void send_error(httplib::Response& res, int status, const std::string& message) {
  res.status = status;
  send_json(res, {{"error", message}});
}

}  // namespace

DashboardServer::DashboardServer(const DashboardConfig& config, const std::string& database,
                                 LiveQueue live, Logger logger)
    : config_(config), live_(std::move(live)), logger_(std::move(logger)) {
  if (!is_loopback_address(config_.address) && config_.token.empty())
    throw StartupError("dashboard: a token is required to serve on " + config_.address);
  try {
    view_ = std::make_unique<RunView>(database);
  } catch (const std::exception& e) {
    throw StartupError("dashboard: cannot open " + database + ": " + e.what());
  }
  server_ = std::make_unique<httplib::Server>();
  const int threads = config_.threads;
  server_->new_task_queue = [threads] { return new httplib::ThreadPool(threads); };
  server_->set_keep_alive_timeout(1);
  // The dashboard only answers GETs: a request body of any size is refused (413) unread.
  server_->set_payload_max_length(0);
  add_routes();
  port_ = config_.port == 0
              ? server_->bind_to_any_port(config_.address)
              : (server_->bind_to_port(config_.address, config_.port) ? config_.port : -1);
  if (port_ <= 0)
    throw StartupError("dashboard: cannot listen on " + config_.address + ":" +
                       std::to_string(config_.port) + " (address in use or not on this host)");
  listener_ = std::thread([this] { server_->listen_after_bind(); });
  publisher_ = std::thread([this] { publish_loop(); });
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
  events_.close();
  poke();
  if (publisher_.joinable()) publisher_.join();
  server_->stop();
  if (listener_.joinable()) listener_.join();
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
      if (listeners_ > 0) publish_summary();
    } catch (const std::exception& e) {
      logger_->warn("dashboard: summary not updated: {}", e.what());
    }
    std::unique_lock<std::mutex> lock(poke_mutex_);
    poked_.wait_for(lock, period, [this] { return poke_ || stopping_; });
    poke_ = false;
  }
}

void DashboardServer::publish_summary() {
  const auto live = live_ ? live_() : std::nullopt;
  std::string summary;
  {
    std::lock_guard<std::mutex> lock(view_mutex_);
    summary = json_text(view_->summary(live));
  }
  events_.publish(std::move(summary));
}

void DashboardServer::add_routes() {
  httplib::Server& s = *server_;
  // On every answer, errors included: scripts only from the page's own origin, no framing (the
  // dashboard cannot be clicked through from another page), types as sent, no referrer (the
  // token travels in the URL).
  s.set_post_routing_handler([](const httplib::Request&, httplib::Response& res) {
    res.set_header("Content-Security-Policy",
                   "default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; "
                   "img-src 'self' data:; object-src 'none'; base-uri 'none'; "
                   "form-action 'self'; frame-ancestors 'none'");
    res.set_header("X-Content-Type-Options", "nosniff");
    res.set_header("X-Frame-Options", "DENY");
    res.set_header("Referrer-Policy", "no-referrer");
  });
  s.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
    // Without a token the dashboard serves loopback only, and only under a loopback name: a
    // page from elsewhere whose name re-resolves to 127.0.0.1 (DNS rebinding) is refused.
    if (config_.token.empty() && !is_loopback_host(req.get_header_value("Host"))) {
      send_error(res, 403, "this dashboard answers to localhost, 127.0.0.1 or [::1] only");
      return httplib::Server::HandlerResponse::Handled;
    }
    if (authorised(req.get_param_value("token"), req.get_header_value("Authorization")))
      return httplib::Server::HandlerResponse::Unhandled;
    send_error(res, 401, "this dashboard needs its token: open it with ?token=...");
    return httplib::Server::HandlerResponse::Handled;
  });
  for (const auto& [path, content] : page_assets()) {
    const std::string type = content_type_of(path);
    const std::string* body = &content;
    auto handler = [body, type](const httplib::Request&, httplib::Response& res) {
      res.set_content(*body, type.c_str());
    };
    s.Get(path == "/dashboard.html" ? "/" : path, handler);
  }
  // Every data handler reads through the one connection, and never lets an exception out.
  auto guarded = [this](auto body) {
    return [this, body](const httplib::Request& req, httplib::Response& res) {
      try {
        std::lock_guard<std::mutex> lock(view_mutex_);
        body(req, res);
      } catch (const std::exception& e) {
        send_error(res, 500, e.what());
      }
    };
  };
  s.Get("/api/summary", guarded([this](const httplib::Request&, httplib::Response& res) {
          send_json(res, view_->summary(live_ ? live_() : std::nullopt));
        }));
  s.Get("/api/keyframes", guarded([this](const httplib::Request& req, httplib::Response& res) {
          const std::string robot = req.get_param_value("robot");
          if (robot.empty()) return send_error(res, 400, "robot=ROBOT is required");
          const std::size_t limit =
              size_param(req, "limit", std::size_t(config_.thumbnails_per_robot), 1000);
          nlohmann::json list = nlohmann::json::array();
          for (const KeyframeCard& card : view_->keyframes(robot, std::max<std::size_t>(limit, 1)))
            list.push_back(card_json(card));
          send_json(res, {{"robot_id", robot}, {"keyframes", list}});
        }));
  s.Get("/api/image", guarded([this](const httplib::Request& req, httplib::Response& res) {
          KeyframeKey key{req.get_param_value("robot"), 0};
          try {
            key.sequence = std::stoull(req.get_param_value("sequence"));
          } catch (const std::exception&) {
            return send_error(res, 400, "sequence=N is required");
          }
          const auto jpeg = view_->jpeg(key);
          if (!jpeg) return send_error(res, 404, "no keyframe " + to_string(key));
          res.set_header("Cache-Control", "max-age=86400");  // stored keyframes never change
          res.set_content(reinterpret_cast<const char*>(jpeg->data()), jpeg->size(), "image/jpeg");
        }));
  s.Get("/api/search", guarded([this](const httplib::Request& req, httplib::Response& res) {
          const std::string query = req.get_param_value("q");
          if (query.empty()) return send_error(res, 400, "q=WORD is required");
          if (!is_utf8(query)) return send_error(res, 400, "q= is not UTF-8 text");
          std::vector<StoredWord> words;
          try {
            words = view_->search(query, size_param(req, "limit", 50, 500));
          } catch (const std::exception&) {
            return send_error(res, 400, "not a valid search (FTS5 syntax): " + query);
          }
          nlohmann::json results = nlohmann::json::array();
          for (const StoredWord& w : words) results.push_back(word_json(w));
          send_json(res, {{"query", query}, {"results", results}});
        }));
  s.Get("/api/map", guarded([this](const httplib::Request&, httplib::Response& res) {
          send_json(res, view_->map());
        }));
  s.Get("/api/map.svg", guarded([this](const httplib::Request&, httplib::Response& res) {
          res.set_content(map_svg(view_->map()), "image/svg+xml");
        }));
  s.Get("/api/bandwidth.svg", guarded([this](const httplib::Request&, httplib::Response& res) {
          res.set_content(bandwidth_svg(view_->bandwidth_timeline()), "image/svg+xml");
        }));
  s.Get("/api/events", [this](const httplib::Request&, httplib::Response& res) {
    res.set_header("Cache-Control", "no-cache");
    auto last = std::make_shared<std::uint64_t>(0);
    ++listeners_;
    poke();  // a fresh summary for the new page
    res.set_chunked_content_provider(
        "text/event-stream",
        [this, last](std::size_t, httplib::DataSink& sink) {
          const auto event = events_.next(*last, milliseconds(15000));
          if (events_.closed()) return false;
          // A comment line keeps idle connections (and proxies) open.
          const std::string text = event ? "id: " + std::to_string(event->id) +
                                               "\nevent: summary\ndata: " + event->data + "\n\n"
                                         : std::string(": idle\n\n");
          if (event) *last = event->id;
          return sink.write(text.data(), text.size());
        },
        [this](bool) { --listeners_; });
  });
}

}  // namespace keyfleet::station::web
