#pragma once
#include <atomic>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "keyfleet/common/config.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/station/analysis_pool.hpp"
#include "keyfleet/station/web/event_hub.hpp"

namespace httplib {
class Server;
}

namespace keyfleet::station::web {

class RunView;

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
// With a token configured every request must carry it (?token= or "Authorization: Bearer").
class DashboardServer {
 public:
  // Opens the database read-only and binds; throws StartupError naming the address or file.
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
  void add_routes();
  void publish_loop();
  void publish_summary();
  bool authorised(const std::string& token_param, const std::string& authorization) const;

  DashboardConfig config_;
  LiveQueue live_;
  Logger logger_;
  std::unique_ptr<RunView> view_;
  std::mutex view_mutex_;  // one database connection for every handler thread
  std::unique_ptr<httplib::Server> server_;
  EventHub events_;
  int port_ = 0;
  std::thread listener_, publisher_;
  std::mutex poke_mutex_;
  std::condition_variable poked_;
  bool poke_ = false;
  std::atomic<bool> stopping_{false};
  std::atomic<int> listeners_{0};  // open event streams
};

}  // namespace keyfleet::station::web
