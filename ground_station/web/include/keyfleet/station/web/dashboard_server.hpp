#pragma once
#include <atomic>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "keyfleet/common/logging.hpp"
#include "keyfleet/station/analysis_pool.hpp"
#include "keyfleet/station/dashboard_config.hpp"
#include "keyfleet/station/web/event_hub.hpp"

namespace keyfleet::station::web {

class RunView;
class HttpServer;
struct HttpRequest;
struct HttpResponse;

// The running station's analysis queue, asked from the server's threads (AnalysisPool's
// counters are thread-safe); empty for a run no station is analysing.
using LiveQueue = std::function<std::optional<AnalysisPool::Counters>()>;

// The live dashboard: a read-only web page and its JSON/SVG endpoints over the station's
// database, with the station's counters pushed to open pages as server-sent events.
//   GET /                   the page (assets compiled in)
//   GET /api/summary        RunView::summary
//   GET /api/keyframes      ?robot=R&limit=N: the robot's latest keyframes with words and figure
//   GET /api/image          ?robot=R&sequence=N: the stored JPEG
//   GET /api/search         ?q=WORD: FTS5 word search (400 on bad syntax)
//   GET /api/map, /api/map.svg, /api/bandwidth.svg
//   GET /api/events         text/event-stream of "summary" events
// With a token configured every request must carry it (?token= or "Authorization: Bearer");
// off loopback one is generated when the config gives none. Clients are bounded (connections in
// all and per address, live pages, request head size and time: DashboardConfig), so that no
// client can take the file descriptors, threads or memory the station needs; stop() never
// waits on a client.
class DashboardServer {
 public:
  // Opens the database read-only and binds; throws StartupError naming the address or file.
  // Keeps the connections within what the process's open-file limit leaves beside the station's
  // own needs.
  DashboardServer(const DashboardConfig& config, const std::string& database, LiveQueue live,
                  Logger logger);
  ~DashboardServer();  // stops
  DashboardServer(const DashboardServer&) = delete;
  DashboardServer& operator=(const DashboardServer&) = delete;

  int port() const { return port_; }
  // "http://127.0.0.1:PORT/" (with ?token=... when one is configured).
  std::string url() const;
  // Something changed (a keyframe stored, an analysis saved): update open pages now.
  void poke();
  void stop();

 private:
  HttpResponse answer(const HttpRequest& request);
  HttpResponse open_events();
  HttpResponse data_answer(const std::string& path, const HttpRequest& request);
  static std::string event_text(const EventHub::Event& event);
  void publish_loop();
  void publish_summary();
  bool authorised(const std::string& token_param, const std::string& authorization) const;

  DashboardConfig config_;
  LiveQueue live_;
  Logger logger_;
  std::unique_ptr<RunView> view_;
  std::mutex view_mutex_;
  std::mutex publish_mutex_;  // one database connection for every handler thread
  EventHub events_;           // the latest summary, numbered
  std::unique_ptr<HttpServer> server_;
  int port_ = 0;
  std::thread publisher_;
  std::mutex poke_mutex_;
  std::condition_variable poked_;
  bool poke_ = false;
  std::atomic<bool> stopping_{false};
};

}  // namespace keyfleet::station::web
