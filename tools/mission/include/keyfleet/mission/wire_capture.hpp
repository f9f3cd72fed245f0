#pragma once
// A drone's link as captured: tcpdump running inside a network namespace writes the UDP
// frames' first 256 bytes to a pcap file, which read_pcap turns into packets for
// rtps_accounting.hpp. Needs tcpdump (Debian package tcpdump) and the right to capture (root).
#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "keyfleet/mission/child_process.hpp"
#include "keyfleet/mission/rtps_accounting.hpp"

namespace keyfleet::mission {

struct WireCaptureOptions {
  // Runs tcpdump through this, e.g. {"ip", "netns", "exec", "kfd0"}; empty: this namespace.
  std::vector<std::string> command_prefix;
  std::string interface;  // the drone end of the veth
  std::string pcap_path;
  std::string log_path;  // tcpdump's own output
  // Headers only: Ethernet, IPv4, UDP, RTPS and the first submessages fit in 256 bytes.
  int snapshot_bytes = 256;
  std::chrono::milliseconds start_timeout{10'000};  // until tcpdump says it is listening
  std::chrono::milliseconds stop_timeout{5'000};    // after SIGINT, before SIGKILL
};

// `tcpdump -i IFACE -n -s 256 -U --immediate-mode -w FILE udp`, running from construction to
// stop(). Immediate mode: the kernel hands packets over as they come, not in blocks up to a
// second late, so the file (flushed per packet) stays current. tcpdump does not drain what the
// kernel still holds when SIGINT comes, so the packets of the last moment before stop() may be
// missing: stop after the traffic to be measured (a quiet time, or once the file shows it).
class WireCapture {
 public:
  // Returns once tcpdump is capturing (it has written the pcap header and said "listening
  // on"); throws StartupError naming the reason and tcpdump's output when it is missing,
  // exits or does not start capturing within start_timeout.
  explicit WireCapture(WireCaptureOptions options);
  ~WireCapture();  // stops a capture still running
  WireCapture(const WireCapture&) = delete;
  WireCapture& operator=(const WireCapture&) = delete;

  // SIGINT so that tcpdump flushes the file, SIGKILL after stop_timeout; then the file is
  // complete. Idempotent: later calls return the first status.
  ExitStatus stop();
  const std::string& pcap_path() const { return options_.pcap_path; }

 private:
  WireCaptureOptions options_;
  std::unique_ptr<ChildProcess> tcpdump_;
  std::optional<ExitStatus> stopped_;
};

// The frames of a pcap file (Ethernet link type). from_drone: IPv4 source address equals
// drone_ipv4_address (dotted quad); frames that are not IPv4 count as station -> drone.
// Throws StartupError naming the file when it is missing, not a pcap file, or not Ethernet,
// and for an invalid address. A file cut short (tcpdump killed) yields the whole records.
std::vector<CapturedPacket> read_pcap(const std::string& path,
                                      const std::string& drone_ipv4_address);

}  // namespace keyfleet::mission
