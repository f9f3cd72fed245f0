#pragma once
// A small HTTP/1.1 server for the dashboard that a client cannot use to take the station's
// resources (Boost.Beast on one I/O thread): connections bounded in total and per client
// address, the request head bounded in size, field count and time, no request bodies, answers
// that a client must take in time, event streams that hold no thread, and a stop that never
// waits on a client.
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "keyfleet/common/logging.hpp"

namespace keyfleet::station::web {

struct HttpRequest {
  std::string method;
  std::string path;                           // the target before '?', percent-decoded
  std::map<std::string, std::string> params;  // the query's names and values, decoded
  std::string host;                           // the Host header
  std::string authorization;                  // the Authorization header
  std::string remote_address;

  // The parameter's value, or "" when absent.
  std::string param(const std::string& name) const;
  bool has_param(const std::string& name) const { return params.count(name) > 0; }
};

using HttpHeaders = std::vector<std::pair<std::string, std::string>>;

struct HttpResponse {
  int status = 200;
  std::string content_type = "application/json";
  std::string body;
  HttpHeaders headers;
  // The answer opens an event stream (text/event-stream): `body` is its first text and the
  // connection then gets every broadcast() until it closes.
  bool event_stream = false;
};

struct HttpLimits {
  std::size_t max_connections = 64;
  std::size_t max_connections_per_client = 16;
  std::size_t max_event_streams = 8;
  std::chrono::milliseconds request_timeout{5000};    // head, idle keep-alive, each answer
  std::chrono::milliseconds stream_keepalive{15000};  // a comment line on idle event streams
  std::size_t max_header_bytes = 8192;                // request line and fields together
  std::size_t max_header_fields = 64;
  int threads = 2;  // threads running handlers
};

// What the server refused, for the station's log.
struct HttpCounters {
  std::uint64_t connections = 0;       // accepted
  std::uint64_t refused_busy = 0;      // 503: max_connections or the client's share reached
  std::uint64_t refused_streams = 0;   // 503: max_event_streams open
  std::uint64_t refused_requests = 0;  // 400, 413, 431: malformed, with a body, head too big
  std::uint64_t timed_out = 0;         // head not whole in time, or an answer not taken
  std::uint64_t descriptor_waits = 0;  // accept found the process out of file descriptors
};

class HttpServer {
 public:
  using Handler = std::function<HttpResponse(const HttpRequest&)>;

  // Binds `address`:`port` (0 = any free port) and starts serving; `every_answer` headers go on
  // every answer, the server's own refusals included. Throws StartupError when it cannot bind.
  HttpServer(const std::string& address, int port, HttpLimits limits, Handler handler,
             HttpHeaders every_answer, Logger logger);
  ~HttpServer();  // stop()
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  int port() const { return port_; }
  // Sends `text` to every open event stream; a stream still sending an earlier text gets only
  // the newest one after it.
  void broadcast(std::string text);
  std::size_t open_event_streams() const;
  HttpCounters counters() const;
  // Closes the listener and every connection without waiting for any client; idempotent.
  void stop();

  struct State;

 private:
  std::unique_ptr<State> state_;
  int port_ = 0;
};

// "a%20b+c" -> "a b c"; invalid escapes are kept as they are.
std::string percent_decoded(const std::string& text);

}  // namespace keyfleet::station::web
