#pragma once
// The agent's settings (robot_agent --config, a mission's agent:), as plain structs with their
// defaults and units. Their YAML descriptions: agent_config_yaml.hpp (agent_config_yaml.cpp).
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "keyfleet/common/config.hpp"
#include "keyfleet/vision/semantic_config.hpp"

namespace keyfleet {

struct SourceConfig {
  enum class Kind { kGenerated, kImageFolder, kVideoFile, kScenario };
  Kind kind = Kind::kGenerated;
  std::string path;              // image folder, video file, or scenario folder
  std::string drone;             // kScenario: which drone's frames; empty = the robot id
  double fps = 30.0;             // frame rate of the stream (also the timestamps' rate)
  bool realtime = true;          // pace frames at fps; false = as fast as possible
  std::uint64_t max_frames = 0;  // stop after this many frames; 0 = whole source
                                 // (kGenerated: 0 = fly until stopped)
  int width = 640;               // kGenerated: frame size in pixels
  int height = 480;
  std::uint64_t seed = 1;  // kGenerated: scene and flight seed
};

// Corner tracking of the `klt` trigger (agent/klt_trigger.hpp), in pixels of the frame resized
// by TriggerConfig::image_scale.
struct KltConfig {
  int max_points = 300;    // FAST corners detected on each keyframe
  int cell_px = 20;        // the strongest corners of each cell are kept (spread over the view)
  int fast_threshold = 7;  // weakest FAST corner accepted
  int window_px = 15;      // Lucas-Kanade window side
  int pyramid_levels = 3;  // 1 = no pyramid
  int iterations = 10;     // Lucas-Kanade iterations per level at most
  double max_error = 30;   // mean absolute grey difference of a tracked window, at most (0..255)
  int border_px = 8;       // corners are detected, and count as tracked, this far inside only
  // New keyframe when the tracked corners < ref_ratio * nRef (TriggerConfig::ref_ratio is the
  // ORB trigger's). A KLT corner, tracked from the keyframe's own pixels and never re-detected,
  // outlives an ORB match: 0.95 here gives the ORB trigger's keyframe rate at its 0.9 on
  // generated streets (README, "A cheaper V-SLAM trigger").
  double ref_ratio = 0.95;
};

// The V-SLAM keyframe trigger whose keyframes anchor the selection windows.
struct TriggerConfig {
  enum class Kind {
    kOrbSlam,  // ORB-SLAM2's NeedNewKeyFrame on ORB features matched to the reference keyframe
    kKlt,      // the same decision on FAST corners tracked by pyramidal KLT (cheaper)
    kStride,   // every `stride` frames
    kList,     // the timestamps of an ORB-SLAM KeyFrameTrajectory.txt (TUM format)
  };
  Kind kind = Kind::kKlt;  // as cheap as a third of orbslam, the same keyframes (README)
  int stride = 15;
  std::string list;
  int features = 1000;  // orbslam: ORB features per frame
  int levels = 8;       // orbslam: pyramid levels
  double scale_factor = 1.2;
  double image_scale = 0.5;     // orbslam, klt: frames are resized by this before tracking
  int max_frames = 0;           // ORB-SLAM2 mMaxFrames; 0 = the source's fps
  int mapping_busy_frames = 2;  // local mapping stays busy this long after a keyframe
  double ref_ratio = 0.9;       // new keyframe when inliers < ref_ratio * nRef
  int min_inliers = 15;
  KltConfig klt;
};

struct QualityConfig {
  int size = 112;               // blur and brightness are measured at size x size
  int sharpness_width = 320;    // the sharpness is measured at this width
  double sharpness_gate = 0.5;  // frames below it are not candidates (Ma and Zhao 2017)
  double edge_contrast = 180;   // Kumar sharpness: summed first differences of an edge
  double sharp_ratio = 0.8;     // Kumar sharpness: ratio that makes an edge sharp
};

// Text regions sent with each keyframe as hints for the station's reader: the connected
// components of the segmenter's mask of the sent frame, in the frame's pixels. Only the semantic
// strategies run the segmenter on the frame they choose; with the others no regions are sent.
struct TextRegionsConfig {
  bool enabled = true;
  int max_regions = 32;           // largest kept; 8 bytes each on the wire (32: 260 bytes a sample)
  int min_area_px = 64;           // smaller components (frame pixels) are dropped as noise
  double merge_gap = 1.0;         // boxes on one line closer than this x their height are merged
  double min_line_overlap = 0.5;  // "on one line": vertical overlap / the smaller height
};

struct SelectorConfig {
  enum class Strategy {
    kVslam,     // publish the V-SLAM keyframe itself
    kQuality,   // best quality in the window
    kSemantic,  // best text score over frames spread across the window
    kFull,      // sharpness gate, top third by quality, best text score (Alonso et al. 2019)
  };
  Strategy strategy = Strategy::kFull;
  int density = 1;             // one keyframe per `density` V-SLAM keyframes
  int max_window_frames = 90;  // frames buffered at most (windows are clipped to them)
  // Frames given to the segmenter per window at most (`semantic`, `full`); 0 = a third of the
  // window (Alonso et al.). The segmenter's cost grows with each frame scored.
  int max_scored = 0;
  // Frames read from JPEG files (image folders, scenarios) are decoded at 1/decode_reduce of
  // their size (1, 2, 4 or 8: libjpeg's DCT scaling) for the selection, and decoded again whole
  // only where every pixel is needed: the keyframe sent and the baseline's sampled frames. At
  // 640x480 the trigger and the sharpness work at half size anyway; measured there, 2 saves a
  // sixth of a decode and 1-4 % of the agent (docs/results/2026-11-26-decode-reduce.md). A frame
  // decoded narrower than the quality or semantic stage works at is refused. Cameras, videos and
  // the generated source give whole frames whatever this says.
  int decode_reduce = 1;
  TriggerConfig trigger;
  QualityConfig quality;
  SemanticConfig semantic;
  TextRegionsConfig text_regions;
};

struct CodecConfig {
  int jpeg_quality = 85;  // 1..100
};

struct LedgerConfig {
  // Encode one frame in N as JPEG to estimate what streaming every frame would cost
  // (1 = measure every frame; the report labels extrapolated figures as estimated).
  int baseline_sample_every = 10;
};

// Keyframes stay in the agent's on-disk outbox until the station acknowledges that
// they are stored; unacknowledged ones are sent again. The bounds decide when the agent
// gives up on the oldest (each drop is logged and counted in AgentStats).
struct OutboxConfig {
  std::string path = "outbox.sqlite";  // relative to the run directory
  std::uint64_t max_pending = 1000;    // unacknowledged keyframes kept at most
  // Unacknowledged this long (s) while a station was matched without a break: given up on. The
  // age bound does not run while no station is matched (an outage loses only what max_pending
  // gives up).
  double max_age_s = 3600.0;
  double resend_after_s = 2.0;  // resend when unacknowledged this long (s)
  int resend_batch = 20;        // at most this many retransmissions per resend pass
};

// How the agent fits what it sends to what its link delivers. The agent keeps the wait of its
// backlog (unacknowledged bytes over the delivery rate) under latency_target_s by lowering the
// cost of new keyframes in a stated order: first the JPEG quality (down the jpeg_qualities
// below codec.jpeg_quality), then the resolution (down `scales`), then the density (only one
// selection in 2, 3 .. max_density is sent at once; the others wait in the outbox behind every
// other keyframe, counted as thinned). It raises the cost again one step at a time once the link
// has carried the richer level's load with room to spare for raise_after_s.
struct LinkAdaptationConfig {
  bool enabled = false;
  double latency_target_s = 3.0;                   // the backlog's wait to stay under
  std::vector<int> jpeg_qualities = {70, 55, 40};  // below codec.jpeg_quality, falling
  std::vector<double> scales = {0.75, 0.5};        // of the frame's width and height, falling
  int max_density = 3;                             // 1 = never thin
  // Share of the delivery rate the robot plans to use (the rest absorbs what the estimate
  // misses: retransmissions, stats, a rate that falls).
  double utilisation = 0.8;
  double raise_after_s = 4.0;      // room to spare this long before a richer level
  double estimator_window_s = 10;  // busy seconds of acknowledgements the rate is taken over
  // Scaled rungs keep the frame's size and every pixel of its text regions (padded by
  // text_margin_px), coarsening only the background; frames without text regions go scaled.
  bool text_aware = true;
  int text_margin_px = 4;
};

struct AgentConfig {
  std::string robot_id = "drone_0";  // [A-Za-z0-9_-]{1,32}
  SourceConfig source;
  SelectorConfig selector;
  CodecConfig codec;
  LedgerConfig ledger;
  OutboxConfig outbox;
  LinkAdaptationConfig link_adaptation;
  DdsSettings dds;
  double stats_period_s = 1.0;       // AgentStats publication period
  double wait_for_station_s = 10.0;  // at start, wait this long for a station before streaming
  double drain_timeout_s = 60.0;     // at the end, wait this long for every acknowledgement
  // After draining, stay connected this long with nothing to send (answering the station, and
  // letting an experiment measure what an idle connected robot costs its link).
  double linger_s = 0.0;
  std::string log_level = "info";  // trace, debug, info, warn, error
};

// Loaders throw ConfigError naming the file, the key and what is allowed.
AgentConfig load_agent_config(const std::string& path);
std::string to_yaml(const AgentConfig& config);
// Parses YAML text (for tests and generated configs); `origin` names it in errors.
AgentConfig parse_agent_config(const std::string& text, const std::string& origin);

// The names the YAML files give the choices, for the tools that take them on a command line.
std::optional<SelectorConfig::Strategy> selection_strategy(const std::string& name);
std::string selection_strategy_choices();  // "vslam|quality|semantic|full"
std::string to_string(SelectorConfig::Strategy strategy);
std::optional<TriggerConfig::Kind> trigger_kind(const std::string& name);
std::string trigger_kind_choices();  // "orbslam|klt|stride|list"
std::string to_string(TriggerConfig::Kind kind);

}  // namespace keyfleet
