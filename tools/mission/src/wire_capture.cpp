#include "keyfleet/mission/wire_capture.hpp"

#include <arpa/inet.h>
#include <pcap/pcap.h>
#include <unistd.h>

#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>

#include "keyfleet/common/error.hpp"

namespace keyfleet::mission {
namespace {

constexpr std::uintmax_t kPcapHeaderBytes = 24;

bool on_path(const std::string& program) {
  const char* path = std::getenv("PATH");
  std::istringstream dirs(path ? path : "/usr/sbin:/usr/bin:/sbin:/bin");
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    const auto candidate = std::filesystem::path(dir.empty() ? "." : dir) / program;
    if (::access(candidate.c_str(), X_OK) == 0) return true;
  }
  return false;
}

std::uintmax_t size_or_zero(const std::string& path) {
  std::error_code error;
  const auto size = std::filesystem::file_size(path, error);
  return error ? 0 : size;
}

// tcpdump prints "listening on IFACE" once its filter is set, just before it captures; only
// what it wrote after `from` counts (the log is appended to).
bool says_listening(const std::string& log_path, std::uintmax_t from) {
  std::ifstream in(log_path, std::ios::binary);
  if (!in) return false;
  in.seekg(static_cast<std::streamoff>(from));
  const std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  return text.find("listening on") != std::string::npos;
}

// What tcpdump wrote after `from`, its last lines at most (for error messages).
std::string output_since(const std::string& log_path, std::uintmax_t from) {
  std::ifstream in(log_path, std::ios::binary);
  in.seekg(static_cast<std::streamoff>(from));
  std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  constexpr std::size_t kMostChars = 2000;
  if (text.size() > kMostChars) text.erase(0, text.size() - kMostChars);
  return text.empty() ? "(nothing)\n" : text;
}

}  // namespace

WireCapture::WireCapture(WireCaptureOptions options) : options_(std::move(options)) {
  const std::string what = "wire capture on " + options_.interface;
  if (!on_path("tcpdump"))
    throw StartupError(what + ": tcpdump not found on PATH (Debian package tcpdump)");
  // A file left by an earlier run must not pass for this capture's header.
  std::error_code ignored;
  std::filesystem::remove(options_.pcap_path, ignored);
  const std::uintmax_t log_from = size_or_zero(options_.log_path);

  std::vector<std::string> argv = options_.command_prefix;
  for (const std::string& arg :
       {std::string("tcpdump"), std::string("-i"), options_.interface, std::string("-n"),
        std::string("-s"), std::to_string(options_.snapshot_bytes), std::string("-U"),
        std::string("--immediate-mode"), std::string("-w"), options_.pcap_path, std::string("udp")})
    argv.push_back(arg);
  try {
    tcpdump_ = std::make_unique<ChildProcess>("tcpdump", argv, options_.log_path);
  } catch (const std::runtime_error& e) {
    throw StartupError(what + ": " + e.what());
  }

  const auto deadline = std::chrono::steady_clock::now() + options_.start_timeout;
  while (true) {
    // Waiting on the child also returns at once when it dies (a bad interface, no rights).
    if (const auto status = tcpdump_->wait_for(std::chrono::milliseconds(20))) {
      stopped_ = status;
      throw StartupError(what + ": tcpdump " + status->describe() + " before capturing; it said (" +
                         options_.log_path + "):\n" + output_since(options_.log_path, log_from));
    }
    if (says_listening(options_.log_path, log_from) &&
        size_or_zero(options_.pcap_path) >= kPcapHeaderBytes)
      return;
    if (std::chrono::steady_clock::now() >= deadline) break;
  }
  stop();
  throw StartupError(what + ": tcpdump did not start capturing within " +
                     std::to_string(options_.start_timeout.count()) + " ms; it said (" +
                     options_.log_path + "):\n" + output_since(options_.log_path, log_from));
}

WireCapture::~WireCapture() {
  if (!stopped_ && tcpdump_) stop();
}

ExitStatus WireCapture::stop() {
  if (stopped_) return *stopped_;
  tcpdump_->signal(SIGINT);
  auto status = tcpdump_->wait_for(options_.stop_timeout);
  if (!status) {
    tcpdump_->signal(SIGKILL);
    status = tcpdump_->wait_for(std::chrono::milliseconds(5'000));
  }
  stopped_ = status.value_or(ExitStatus{false, SIGKILL, 0});
  return *stopped_;
}

std::vector<CapturedPacket> read_pcap(const std::string& path,
                                      const std::string& drone_ipv4_address) {
  in_addr drone{};
  if (::inet_pton(AF_INET, drone_ipv4_address.c_str(), &drone) != 1)
    throw StartupError("read_pcap: '" + drone_ipv4_address + "' is not an IPv4 address");
  if (!std::filesystem::exists(path)) throw StartupError("pcap file " + path + " does not exist");

  char error[PCAP_ERRBUF_SIZE] = {};
  std::unique_ptr<pcap_t, decltype(&pcap_close)> pcap(
      pcap_open_offline_with_tstamp_precision(path.c_str(), PCAP_TSTAMP_PRECISION_NANO, error),
      &pcap_close);
  if (!pcap) throw StartupError("cannot read pcap file " + path + ": " + error);
  if (pcap_datalink(pcap.get()) != DLT_EN10MB) {
    const char* name = pcap_datalink_val_to_name(pcap_datalink(pcap.get()));
    throw StartupError("pcap file " + path + " has link type " + (name ? name : "?") +
                       ", not Ethernet (capture on the veth, not on 'any')");
  }

  std::vector<CapturedPacket> packets;
  pcap_pkthdr* header = nullptr;
  const u_char* data = nullptr;
  // 1: a record; PCAP_ERROR_BREAK: the end; PCAP_ERROR: a record cut short, the end too.
  while (pcap_next_ex(pcap.get(), &header, &data) == 1) {
    CapturedPacket p;
    p.time_ns = static_cast<std::int64_t>(header->ts.tv_sec) * 1'000'000'000 +
                static_cast<std::int64_t>(header->ts.tv_usec);  // nanoseconds, as asked
    p.wire_bytes = header->len;
    p.bytes.assign(data, data + header->caplen);
    p.from_drone = p.bytes.size() >= 34 && p.bytes[12] == 0x08 && p.bytes[13] == 0x00 &&
                   std::memcmp(&p.bytes[26], &drone.s_addr, 4) == 0;
    packets.push_back(std::move(p));
  }
  return packets;
}

}  // namespace keyfleet::mission
