#pragma once
// The protections of keyfleet's DDS-Security governance, described once: `keyfleet security
// init` writes them into the signed governance document, and the DDS adapter sizes its RTPS
// messages by them (Fast DDS adds each protection's headers to every message it applies to).
namespace keyfleet {

struct GovernanceProtection {
  // Whole RTPS messages signed (SRTPS): about 72 bytes more per message.
  bool rtps = false;
  // Each submessage signed, heartbeats and acknowledgements included: about 48 bytes per
  // submessage, which doubles a heartbeat. Not bought: a forged heartbeat, acknack or gap can
  // at most delay a keyframe, since only the station's acknowledgement sample (a protected
  // topic) empties the robot's outbox.
  bool metadata = false;
  // Each sample (or fragment) encrypted and authenticated with AES-GCM: about 47 bytes.
  bool payload = true;
  // Discovery and liveliness through the secure builtin endpoints (encrypted SEDP). Not bought:
  // each robot's identity certificate crosses the link in clear in the authentication
  // handshake, and topic names say no more than it. Measured against it: on 100 kbit/s links
  // with 4 drones the station's secure discovery readers, lacking a drone's keys, re-sent their
  // acknowledgements about 60 times a second each way, which filled the link and starved the
  // key exchange that would have ended it (nothing stored in 200 s). Authentication, join and
  // topic access control and payload encryption are unaffected.
  bool discovery = false;
  bool liveliness = false;
};

// What `keyfleet security init` writes and a secured participant expects.
inline constexpr GovernanceProtection kFleetGovernance{};

}  // namespace keyfleet
