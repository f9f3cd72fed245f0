#pragma once
// The station's dashboard settings (dashboard: in the station's config), read by the web
// library's DashboardServer. Their YAML description is part of the station's
// (station_config_yaml.cpp).
#include <cstddef>
#include <string>

namespace keyfleet {

// The station's live dashboard: a read-only web page served over HTTP while the station runs
// (ground_station/web). The URL it serves at is logged and written to <run>/dashboard.url.
struct DashboardConfig {
  bool enabled = true;
  // Loopback by default. Any other address (e.g. 0.0.0.0) needs a token, which every request
  // then carries (?token=... or an "Authorization: Bearer ..." header): when none is given the
  // station generates one and shows it only in the printed URL and <run>/dashboard.url (0600).
  std::string address = "127.0.0.1";
  int port = 0;  // 0 = a free port chosen at start
  // At least kMinTokenLength characters; never logged.
  std::string token;
  double update_period_s = 0.5;   // how often connected pages are sent the station's counters
  int thumbnails_per_robot = 24;  // latest keyframes shown per robot
  int threads = 2;                // threads answering requests (open live pages hold none)
  // Bounds that keep clients from taking the station's resources: connections open at once
  // (live pages included; the file descriptors they may hold are at most this many), from one
  // client address, and live pages (event streams) at once; beyond each, new ones get 503.
  int max_connections = 64;
  int max_connections_per_client = 16;
  int max_event_streams = 8;
  // A request's line and headers must arrive whole within this (slow senders are cut off), an
  // idle kept-alive connection is closed after it, and a client must take each answer within it.
  double request_timeout_s = 5.0;

  static constexpr std::size_t kMinTokenLength = 16;
};

// True for 127.0.0.0/8, ::1 and "localhost": addresses only this machine reaches.
bool is_loopback_address(const std::string& address);

}  // namespace keyfleet
