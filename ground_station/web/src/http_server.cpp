#include "http_server.hpp"

#include <boost/asio/dispatch.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/thread_pool.hpp>
#include <boost/asio/write.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>

#include <atomic>
#include <cerrno>
#include <future>
#include <mutex>
#include <optional>
#include <set>
#include <thread>

#include "keyfleet/common/error.hpp"
#include "keyfleet/common/thread_name.hpp"

namespace keyfleet::station::web {

namespace net = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using tcp = net::ip::tcp;

namespace {

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

std::map<std::string, std::string> query_params(const std::string& query) {
  std::map<std::string, std::string> params;
  std::size_t start = 0;
  while (start <= query.size()) {
    const std::size_t end = std::min(query.find('&', start), query.size());
    const std::string item = query.substr(start, end - start);
    if (!item.empty()) {
      const std::size_t eq = item.find('=');
      const std::string name = percent_decoded(item.substr(0, eq));
      // The first of repeated names counts, as in most servers.
      params.emplace(name, eq == std::string::npos ? "" : percent_decoded(item.substr(eq + 1)));
    }
    start = end + 1;
  }
  return params;
}

std::string reason_of(int status) {
  return std::string(http::obsolete_reason(static_cast<http::status>(status)));
}

// An answer the server writes itself (refusals), ready to send as bytes.
std::string canned_answer(int status, const std::string& message, const HttpHeaders& extra) {
  const std::string body = "{\"error\":\"" + message + "\"}";
  std::string text =
      "HTTP/1.1 " + std::to_string(status) + " " + reason_of(status) +
      "\r\nContent-Type: application/json\r\nContent-Length: " + std::to_string(body.size()) +
      "\r\nConnection: close\r\n";
  if (status == 503) text += "Retry-After: 1\r\n";
  for (const auto& [name, value] : extra) text += name + ": " + value + "\r\n";
  return text + "\r\n" + body;
}

std::string chunk(const std::string& data) {
  char size[20];
  std::snprintf(size, sizeof size, "%zx\r\n", data.size());
  return size + data + "\r\n";
}

}  // namespace

std::string HttpRequest::param(const std::string& name) const {
  const auto it = params.find(name);
  return it == params.end() ? std::string() : it->second;
}

std::string percent_decoded(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '+') {
      out += ' ';
    } else if (c == '%' && i + 2 < text.size() && hex_value(text[i + 1]) >= 0 &&
               hex_value(text[i + 2]) >= 0) {
      out += static_cast<char>(hex_value(text[i + 1]) * 16 + hex_value(text[i + 2]));
      i += 2;
    } else {
      out += c;
    }
  }
  return out;
}

class Session;

// Everything the I/O thread, the handler threads and the owner share. Connection bookkeeping is
// touched on the I/O thread only; the counters are atomics read from anywhere. The I/O context
// is declared first so that it goes last: the sessions its pending operations still own are
// destroyed with it, and they touch nothing else of the state then.
struct HttpServer::State {
  net::io_context io{1};
  net::executor_work_guard<net::io_context::executor_type> work{io.get_executor()};
  HttpLimits limits;
  HttpServer::Handler handler;
  HttpHeaders every_answer;
  Logger logger;
  tcp::acceptor acceptor{io};
  net::steady_timer accept_pause{io};
  net::thread_pool workers;
  std::thread io_thread;
  std::future<void> io_thread_done;
  std::atomic<bool> stopped{false};

  std::size_t open = 0;                                 // I/O thread only
  std::map<std::string, std::size_t> per_client;        // I/O thread only
  std::set<std::shared_ptr<Session>> streams;           // I/O thread only; holds the open streams
  std::map<Session*, std::weak_ptr<Session>> sessions;  // I/O thread only: to close at stop
  std::atomic<std::size_t> stream_count{0};

  std::atomic<std::uint64_t> connections{0}, refused_busy{0}, refused_streams{0},
      refused_requests{0}, timed_out{0}, descriptor_waits{0};

  State(HttpLimits l, HttpServer::Handler h, HttpHeaders headers, Logger log)
      : limits(l),
        handler(std::move(h)),
        every_answer(std::move(headers)),
        logger(std::move(log)),
        workers(static_cast<std::size_t>(std::max(l.threads, 1))) {}
  ~State() { streams.clear(); }
  void accept();
  void on_accept(tcp::socket socket);
};

// One client connection: reads a request head within the request timeout, refuses what it must,
// asks the handler on a worker thread, writes the answer in time, and either reads the next
// request (keep-alive), becomes an event stream, or closes.
class Session : public std::enable_shared_from_this<Session> {
 public:
  // The state outlives every session that can still run (see State); the bookkeeping is undone
  // in close(), which every session that ends before the server stops goes through.
  Session(HttpServer::State* state, tcp::socket socket, std::string client)
      : state_(state), stream_(std::move(socket)), client_(std::move(client)) {}

  void start() { read_head(); }

  // An answer the server writes itself, then the connection closes.
  void refuse(int status, const std::string& message) {
    auto text = std::make_shared<std::string>(canned_answer(status, message, state_->every_answer));
    stream_.expires_after(state_->limits.request_timeout);
    net::async_write(
        stream_, net::buffer(*text),
        [self = shared_from_this(), text](beast::error_code, std::size_t) { self->close(); });
  }

  void send_event(std::string text) {
    if (closed_) return;
    pending_event_ = std::move(text);
    if (!writing_) write_event();
  }

 private:
  void read_head() {
    parser_.emplace();
    parser_->header_limit(static_cast<std::uint32_t>(state_->limits.max_header_bytes));
    parser_->body_limit(0);
    stream_.expires_after(state_->limits.request_timeout);
    http::async_read_header(
        stream_, buffer_, *parser_,
        [self = shared_from_this()](beast::error_code ec, std::size_t) { self->on_head(ec); });
  }

  void on_head(beast::error_code ec) {
    if (ec == beast::error::timeout) {
      // An idle kept-alive connection closing is normal; a head cut off halfway is not.
      if (buffer_.size() > 0 || requests_ == 0) ++state_->timed_out;
      return close();
    }
    if (ec == http::error::body_limit) {  // a Content-Length over 0: refused unread
      ++state_->refused_requests;
      return refuse(413, "this server accepts no request bodies");
    }
    if (ec == http::error::header_limit) {
      ++state_->refused_requests;
      return refuse(
          431, "request head over " + std::to_string(state_->limits.max_header_bytes) + " bytes");
    }
    if (ec) {
      if (ec != http::error::end_of_stream && ec != net::error::eof &&
          ec != net::error::connection_reset && ec != net::error::operation_aborted)
        ++state_->refused_requests;
      return ec == http::error::end_of_stream || ec == net::error::eof ? close()
                                                                       : refuse(400, "bad request");
    }
    ++requests_;
    const auto& head = parser_->get();
    std::size_t fields = 0;
    for (auto it = head.begin(); it != head.end(); ++it) ++fields;
    if (fields > state_->limits.max_header_fields) {
      ++state_->refused_requests;
      return refuse(
          431, "more than " + std::to_string(state_->limits.max_header_fields) + " header fields");
    }
    // No request is read beyond its head: one that announces a body is refused unread.
    if (head.chunked() ||
        (head.has_content_length() && parser_->content_length().value_or(0) > 0)) {
      ++state_->refused_requests;
      return refuse(413, "this server accepts no request bodies");
    }
    HttpRequest request;
    request.method = std::string(head.method_string());
    const std::string target(head.target());
    const std::size_t q = target.find('?');
    request.path = percent_decoded(target.substr(0, q));
    if (q != std::string::npos) request.params = query_params(target.substr(q + 1));
    request.host = std::string(head[http::field::host]);
    request.authorization = std::string(head[http::field::authorization]);
    request.remote_address = client_;
    keep_alive_ = head.keep_alive();
    version_ = head.version();
    // The handler may block on the database: it runs on a worker, the answer comes back here.
    net::post(state_->workers, [self = shared_from_this(), request = std::move(request)] {
      HttpResponse response;
      try {
        response = self->state_->handler(request);
      } catch (const std::exception& e) {
        response = {500, "application/json", "{\"error\":\"internal error\"}", {}, false};
        self->state_->logger->warn("dashboard: {} {}: {}", request.method, request.path, e.what());
      }
      net::post(self->stream_.get_executor(),
                [self, response = std::move(response)]() mutable { self->answer(response); });
    });
  }

  void answer(HttpResponse& response) {
    if (state_->stopped) return;
    if (response.event_stream) return open_event_stream(response);
    auto res = std::make_shared<http::response<http::string_body>>(
        static_cast<http::status>(response.status), version_);
    res->set(http::field::content_type, response.content_type);
    for (const auto& [name, value] : response.headers) res->set(name, value);
    for (const auto& [name, value] : state_->every_answer) res->set(name, value);
    res->body() = std::move(response.body);
    res->keep_alive(keep_alive_);
    res->prepare_payload();
    stream_.expires_after(state_->limits.request_timeout);
    http::async_write(stream_, *res,
                      [self = shared_from_this(), res](beast::error_code ec, std::size_t) {
                        if (ec) {
                          if (ec == beast::error::timeout) ++self->state_->timed_out;
                          return self->close();
                        }
                        if (!res->keep_alive()) return self->close();
                        self->read_head();
                      });
  }

  void open_event_stream(HttpResponse& response) {
    if (state_->streams.size() >= state_->limits.max_event_streams) {
      ++state_->refused_streams;
      return refuse(503, "too many live pages open: close one, or reload later");
    }
    std::string head =
        "HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\n"
        "Cache-Control: no-cache\r\nTransfer-Encoding: chunked\r\n";
    for (const auto& [name, value] : response.headers) head += name + ": " + value + "\r\n";
    for (const auto& [name, value] : state_->every_answer) head += name + ": " + value + "\r\n";
    state_->streams.insert(shared_from_this());
    state_->stream_count = state_->streams.size();
    is_stream_ = true;
    writing_ = true;
    write_stream_text(head + "\r\n" + chunk(response.body));
    watch_for_close();
  }

  // A page sends nothing after its request: a read that ends tells that it closed, so that its
  // place is free at once rather than at the next write that fails.
  void watch_for_close() {
    stream_.socket().async_read_some(
        net::buffer(discard_), [self = shared_from_this()](beast::error_code ec, std::size_t) {
          if (ec) return self->close();
          self->watch_for_close();
        });
  }

  void write_event() {
    writing_ = true;
    std::string text = std::move(pending_event_);
    pending_event_.clear();
    write_stream_text(chunk(text));
  }

  void write_stream_text(std::string bytes) {
    keepalive_.cancel();
    auto text = std::make_shared<std::string>(std::move(bytes));
    stream_.expires_after(state_->limits.request_timeout);
    net::async_write(stream_, net::buffer(*text),
                     [self = shared_from_this(), text](beast::error_code ec, std::size_t) {
                       self->writing_ = false;
                       if (ec) {
                         if (ec == beast::error::timeout) ++self->state_->timed_out;
                         return self->close();
                       }
                       if (!self->pending_event_.empty()) return self->write_event();
                       self->arm_keepalive();
                     });
  }

  // An idle stream gets a comment line now and then, so that a closed page is noticed and
  // proxies keep the connection.
  void arm_keepalive() {
    keepalive_.expires_after(state_->limits.stream_keepalive);
    keepalive_.async_wait([weak = weak_from_this()](beast::error_code ec) {
      auto self = weak.lock();
      if (ec || !self || self->writing_ || self->closed_) return;
      self->send_event(": idle\n\n");
    });
  }

  void close() {
    if (closed_) return;
    closed_ = true;
    keepalive_.cancel();
    beast::error_code ignored;
    stream_.socket().shutdown(tcp::socket::shutdown_both, ignored);
    stream_.close();
    if (--state_->per_client[client_] == 0) state_->per_client.erase(client_);
    --state_->open;
    state_->sessions.erase(this);
    if (is_stream_) {
      state_->streams.erase(shared_from_this());
      state_->stream_count = state_->streams.size();
    }
  }

 public:
  void close_now() { close(); }

 private:
  HttpServer::State* state_;
  beast::tcp_stream stream_;
  std::string client_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::empty_body>> parser_;
  net::steady_timer keepalive_{stream_.get_executor()};
  std::uint64_t requests_ = 0;
  bool keep_alive_ = false;
  unsigned version_ = 11;
  bool is_stream_ = false;
  bool writing_ = false;
  bool closed_ = false;
  std::string pending_event_;
  char discard_[512];
};

void HttpServer::State::accept() {
  acceptor.async_accept([this](beast::error_code ec, tcp::socket socket) {
    if (stopped || !acceptor.is_open()) return;
    if (ec == net::error::no_descriptors || ec.value() == EMFILE || ec.value() == ENFILE) {
      // Out of file descriptors: wait for some to be freed rather than spin on accept.
      if (descriptor_waits++ == 0)
        logger->warn("dashboard: the process is out of file descriptors; accepting paused");
      accept_pause.expires_after(std::chrono::milliseconds(100));
      accept_pause.async_wait([this](beast::error_code e) {
        if (!e && !stopped) accept();
      });
      return;
    }
    if (!ec) on_accept(std::move(socket));
    accept();
  });
}

void HttpServer::State::on_accept(tcp::socket socket) {
  ++connections;
  beast::error_code ec;
  const auto peer = socket.remote_endpoint(ec);
  if (ec) return;  // the client has gone already
  const std::string client = peer.address().to_string();
  ++open;
  ++per_client[client];
  auto session = std::make_shared<Session>(this, std::move(socket), client);
  sessions.emplace(session.get(), session);
  // Over either bound the connection still counts while its refusal is written (within the
  // request timeout); refusals beyond twice the bound are closed without a word.
  const bool over_total = open > limits.max_connections;
  const bool over_client = per_client[client] > limits.max_connections_per_client;
  if (over_total || over_client) {
    ++refused_busy;
    if (open > 2 * limits.max_connections) return session->close_now();
    return session->refuse(503, over_total ? "the dashboard is busy: too many connections"
                                           : "too many connections from " + client);
  }
  session->start();
}

}  // namespace keyfleet::station::web

namespace keyfleet::station::web {

HttpServer::HttpServer(const std::string& address, int port, HttpLimits limits, Handler handler,
                       HttpHeaders every_answer, Logger logger)
    : state_(std::make_unique<State>(limits, std::move(handler), std::move(every_answer),
                                     std::move(logger))) {
  beast::error_code ec;
  const auto ip = net::ip::make_address(address == "localhost" ? "127.0.0.1" : address, ec);
  if (ec) throw StartupError("dashboard: '" + address + "' is not an IP address");
  const tcp::endpoint endpoint(ip, static_cast<unsigned short>(port));
  auto& acceptor = state_->acceptor;
  acceptor.open(endpoint.protocol(), ec);
  if (!ec) acceptor.set_option(net::socket_base::reuse_address(true), ec);
  if (!ec) acceptor.bind(endpoint, ec);
  if (!ec) acceptor.listen(net::socket_base::max_listen_connections, ec);
  if (ec)
    throw StartupError("dashboard: cannot listen on " + address + ":" + std::to_string(port) +
                       ": " + ec.message());
  port_ = acceptor.local_endpoint().port();
  state_->accept();
  auto finished = std::make_shared<std::promise<void>>();
  state_->io_thread_done = finished->get_future();
  state_->io_thread = std::thread([state = state_.get(), finished] {
    name_this_thread("http");
    state->io.run();
    finished->set_value();
  });
}

HttpServer::~HttpServer() { stop(); }

void HttpServer::broadcast(std::string text) {
  if (state_->stopped) return;
  net::post(state_->io, [state = state_.get(), text = std::move(text)] {
    for (const auto& stream : state->streams) stream->send_event(text);
  });
}

std::size_t HttpServer::open_event_streams() const { return state_->stream_count; }

HttpCounters HttpServer::counters() const {
  return {state_->connections,      state_->refused_busy, state_->refused_streams,
          state_->refused_requests, state_->timed_out,    state_->descriptor_waits};
}

void HttpServer::stop() {
  if (state_->stopped.exchange(true)) return;
  // No client is waited for: the I/O thread closes the listener and every connection, and what
  // was pending on them ends at once; should anything still run after a second, the I/O thread
  // is stopped where it is. Handlers still queued are dropped; a running one (a database read)
  // ends on its own and its answer goes nowhere.
  State* state = state_.get();
  net::post(state->io, [state] {
    beast::error_code ignored;
    state->acceptor.close(ignored);
    state->accept_pause.cancel();
    const auto sessions = state->sessions;  // close() erases from the map
    for (const auto& entry : sessions)
      if (auto session = entry.second.lock()) session->close_now();
  });
  state->work.reset();
  if (state->io_thread.joinable()) {
    if (state->io_thread_done.wait_for(std::chrono::seconds(1)) != std::future_status::ready)
      state->io.stop();
    state->io_thread.join();
  }
  state->workers.stop();
  state->workers.join();
}

}  // namespace keyfleet::station::web
