#pragma once
// Every user-facing setting, as plain structs with their defaults and units.
// The YAML mapping of all of them lives in one place: config_yaml.cpp.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace keyfleet {

// How a process joins the DDS network (see DESIGN.md §3 for why these defaults).
struct DdsSettings {
  enum class Transport {
    kLocalhost,  // SHM + UDPv4 on 127.0.0.1 only, no multicast: one-machine missions and tests
    kNetwork,    // Fast DDS's built-in transports on all interfaces, plus initial_peers
  };
  int domain_id = 0;                   // 0..232; overridden by --domain / KEYFLEET_DOMAIN
  std::string partition = "keyfleet";  // overridden by --partition / KEYFLEET_PARTITION
  Transport transport = Transport::kLocalhost;
  std::vector<std::string> initial_peers;  // kNetwork: IPv4 addresses of other hosts
  // kNetwork: also shared memory with peers Fast DDS takes for the same host. false = UDPv4
  // only, on the non-loopback interfaces, so that processes in separate network namespaces
  // really use their links.
  bool shared_memory = true;
  double lease_duration_s = 4.0;           // a silent peer is dropped after this long
  double announcement_period_s = 1.0;      // participant announcements
  int keyframe_history_depth = 5;          // KEEP_LAST depth of the keyframe writer
  double heartbeat_period_s = 0.1;         // reliable writer heartbeat
  // Keyframe writer's byte-rate cap (asynchronous publish through a FIFO flow controller,
  // 10 ms periods); 0 = unlimited. When capped, a full writer refuses a keyframe at once
  // and the outbox sends it again later.
  std::uint64_t max_bytes_per_s = 0;
};

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

// The V-SLAM keyframe trigger whose keyframes anchor the selection windows.
struct TriggerConfig {
  enum class Kind {
    kOrbSlam,  // ORB-SLAM2's NeedNewKeyFrame on tracked ORB features
    kStride,   // every `stride` frames
    kList,     // the timestamps of an ORB-SLAM KeyFrameTrajectory.txt (TUM format)
  };
  Kind kind = Kind::kOrbSlam;
  int stride = 15;
  std::string list;
  int features = 1000;  // ORB features per frame
  int levels = 8;
  double scale_factor = 1.2;
  double image_scale = 0.5;     // frames are resized by this before extraction
  int max_frames = 0;           // ORB-SLAM2 mMaxFrames; 0 = the source's fps
  int mapping_busy_frames = 2;  // local mapping stays busy this long after a keyframe
  double ref_ratio = 0.9;       // new keyframe when inliers < ref_ratio * nRef
  int min_inliers = 15;
};

struct QualityConfig {
  int size = 112;               // blur and brightness are measured at size x size
  int sharpness_width = 320;    // the sharpness is measured at this width
  double sharpness_gate = 0.5;  // frames below it are not candidates (second seed)
  double edge_contrast = 180;   // Kumar sharpness: summed first differences of an edge
  double sharp_ratio = 0.8;     // Kumar sharpness: ratio that makes an edge sharp
};

struct SemanticConfig {
  // ONNX text segmenter with its .json beside it; a bare name is also looked for in
  // <bin>/../share/keyfleet/models/ (where the build puts the shipped MiniNet).
  std::string model = "mininet_text.onnx";
  double border = 0.1;  // border band, as a fraction of the mask's smaller side
  int threads = 1;      // OpenCV DNN threads
};

struct SelectorConfig {
  enum class Strategy {
    kVslam,     // publish the V-SLAM keyframe itself
    kQuality,   // best quality in the window
    kSemantic,  // best text score over frames spread across the window
    kFull,      // sharpness gate, top third by quality, best text score (first seed)
  };
  Strategy strategy = Strategy::kFull;
  int density = 1;             // one keyframe per `density` V-SLAM keyframes
  int max_window_frames = 90;  // frames buffered at most (windows are clipped to them)
  TriggerConfig trigger;
  QualityConfig quality;
  SemanticConfig semantic;
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
  double max_age_s = 3600.0;           // oldest unacknowledged keyframe kept at most this long (s)
  double resend_after_s = 2.0;         // resend when unacknowledged this long (s)
  int resend_batch = 20;               // at most this many retransmissions per resend pass
};

struct AgentConfig {
  std::string robot_id = "drone_0";  // [A-Za-z0-9_-]{1,32}
  SourceConfig source;
  SelectorConfig selector;
  CodecConfig codec;
  LedgerConfig ledger;
  OutboxConfig outbox;
  DdsSettings dds;
  double stats_period_s = 1.0;       // AgentStats publication period
  double wait_for_station_s = 10.0;  // at start, wait this long for a station before streaming
  double drain_timeout_s = 60.0;     // at the end, wait this long for every acknowledgement
  std::string log_level = "info";    // trace, debug, info, warn, error
};

struct StationLimits {
  std::uint64_t max_image_bytes = 8ULL << 20;  // larger samples are rejected
  std::uint32_t max_width = 8192;              // claimed or decoded dimensions above these
  std::uint32_t max_height = 8192;             //   are rejected before decoding
};

// Reading the words in received keyframes (the station's TextReader).
struct TextReadingConfig {
  bool enabled = true;
  std::string engine = "tesseract";  // see `keyfleet ocr eval` for the engines and their figures
  std::string tessdata_dir;          // empty = Debian's tesseract-ocr-eng data
  std::string language = "eng";
  double min_confidence = 0.7;  // 0..1; words below are not stored
  int min_word_length = 3;      // characters; shorter readings are mostly texture noise
  // Smaller keyframes are upscaled to this longer side before reading (px, 0 = never).
  // On 640x480 street keyframes 1280 cost 5.7x the CPU (334 vs 59 ms a read) and read no
  // more sign words (23 vs 21 of the demo's 74 keyframes): see bench_station.
  int min_long_side = 0;
};

// Recognising places shared across keyframes and robots (ORB bag of words + verification).
struct PlaceRecognitionConfig {
  bool enabled = true;
  // Vocabulary file from `keyfleet vocabulary build`; a bare name is looked up in
  // <bin>/../share/keyfleet/models/ like the agent's model.
  std::string vocabulary = "orb_vocabulary.bin";
  int orb_features = 1000;
  int candidates = 4;             // top-k bag-of-words candidates verified geometrically
  int min_inliers = 30;           // accepted with more inliers than this (second seed)
  double min_inlier_ratio = 0.25; // and an inlier ratio above this
  std::string verifier = "vfc";   // vfc | ransac_homography | ransac_fundamental
  // Keyframes of the same robot closer in time than this are neighbours, not revisits.
  double same_robot_exclusion_s = 10.0;
};

// The station's heavier work, behind the DDS reader: a bounded queue and worker threads.
struct AnalysisConfig {
  int workers = 1;
  // Keyframes waiting for analysis; beyond it the oldest waiting one is deferred (its heavy
  // steps run later, when the queue is empty). A stored keyframe is never dropped.
  int queue_capacity = 32;
  // At shutdown the station finishes queued analysis for at most this long; what is left
  // stays unanalysed in the database and is analysed when the station next starts.
  double drain_timeout_s = 40.0;
  TextReadingConfig text;
  PlaceRecognitionConfig places;
};

struct StationConfig {
  DdsSettings dds;
  StationLimits limits;
  AnalysisConfig analysis;
  std::string database = "station.sqlite";  // relative to the run directory
  std::string mission_log = "mission_log.pb";
  double report_period_s = 5.0;  // live bandwidth line in the log
  std::string log_level = "info";
};

// The scenario generator (`keyfleet scenario generate`): a street with shop signs, drones
// flying along it on two 'days', camera effects with known parameters. Lengths in metres,
// angles in degrees, times in seconds.
struct StreetConfig {
  double length_m = 160.0;
  double width_m = 16.0;  // facade to facade
  double facade_height_m = 12.0;
  double building_min_width_m = 6.0;
  double building_max_width_m = 14.0;
  double sign_probability = 0.85;       // chance that a building carries a shop sign
  double extra_sign_probability = 0.4;  // chance of a second, smaller sign
  double place_length_m = 5.0;          // place ids bin the street in segments this long
  double pole_spacing_m = 14.0;         // lamp posts along the kerbs (occluders); 0 = none
  double tree_spacing_m = 22.0;         // trees along the kerbs (occluders); 0 = none
};

struct TextureConfig {
  std::vector<std::string> photo_folders;           // real photos for facades (must exist)
  std::vector<std::string> optional_photo_folders;  // used when present, else skipped
  // Paths in a scenario file are relative to that file. Without photos, facades are procedural.
  int max_photos = 60;             // at most this many photos are loaded
  double photo_probability = 0.5;  // chance that a facade uses a photo when available
  std::vector<std::string> font_folders = {"/usr/share/fonts/truetype",
                                           "/usr/share/fonts/opentype"};
  std::string word_list;  // one word a line; empty = the built-in shop words
};

struct DroneFlightConfig {
  int count = 3;
  int days = 2;  // drone i flies on day i % days
  double speed_mps = 2.0;
  double speed_jitter_mps = 0.3;  // per drone
  double start_m = 8.0;           // where along the street the flights begin
  double altitude_m = 5.0;
  double altitude_jitter_m = 1.0;  // per drone and day
  double lateral_offset_m = -1.0;  // from the street centre, + toward the left facade
  double lateral_jitter_m = 1.5;
  double view_yaw_deg = 55.0;         // camera yaw from the flight direction, toward the left
  double pitch_deg = 8.0;             // camera pitch, + up
  double heading_jitter_deg = 4.0;    // slow yaw wander
  double shake_deg = 0.25;            // continuous high-frequency shake
  double shake_burst_rate_hz = 0.08;  // random bursts of strong shake
  double shake_burst_deg = 2.0;
  double shake_burst_s = 0.6;
};

struct CameraEffectsConfig {
  double horizontal_fov_deg = 70.0;
  double shutter_fraction = 0.5;         // exposure time / frame period (sets motion blur)
  double noise_sigma = 2.0;              // read noise, grey levels
  double shot_noise = 0.4;               // photon noise scale: sigma = shot_noise * sqrt(level)
  double vignetting = 0.25;              // brightness loss at the corners
  double auto_exposure_lag_s = 0.6;      // time constant of the auto-exposure
  double exposure_event_rate_hz = 0.06;  // random over/under-exposure events
  double exposure_event_s = 0.5;
  double over_exposure_gain = 2.4;
  double under_exposure_gain = 0.35;
  bool greyscale = false;
  int jpeg_artifact_quality = 0;  // re-encode at this JPEG quality before saving; 0 = off
};

struct ScenarioConfig {
  std::string name = "street";
  std::uint64_t seed = 1;
  std::uint64_t frames_per_drone = 600;
  double fps = 30.0;
  int width = 640;
  int height = 480;
  std::string image_format = "jpg";  // jpg | png
  int image_quality = 92;            // jpg quality of the saved frames
  StreetConfig street;
  TextureConfig textures;
  DroneFlightConfig drones;
  CameraEffectsConfig camera;
};

struct MissionConfig {
  std::string name = "mission";
  int drones = 3;
  std::string robot_id_prefix = "drone_";  // drone i is <prefix><i>
  std::string run_root = "runs";           // each run gets <run_root>/<name>-<timestamp>/
  std::optional<int> domain_id;            // default: derived from the process id
  double agent_timeout_s = 900.0;          // an agent still running after this fails the mission
  double station_drain_timeout_s = 60.0;   // after SIGTERM, the station must exit within this
  // Replay a generated scenario: `scenario` names a scenario YAML (relative to the mission
  // file) generated into the run folder; `scenario_dir` names one generated before. Either
  // sets the drones (one agent per scenario drone, source kind scenario).
  std::string scenario;
  std::string scenario_dir;
  AgentConfig agent;  // template for every drone; seed += drone index
  StationConfig station;
};

// `keyfleet eval` (configs/eval.yaml): the first seed's Fig. 6 on a generated scenario.
struct EvalConfig {
  ScenarioConfig scenario;   // generated into <out>/scenario unless scenario_dir is set
  std::string scenario_dir;  // a scenario generated before (relative to the file)
  std::vector<std::string> strategies = {"vslam", "quality", "semantic", "full"};
  // Fractions of the V-SLAM keyframes kept, spread evenly (the same for every strategy).
  std::vector<double> densities = {1.0, 0.75, 0.5, 0.35, 0.2, 0.1};
  std::vector<std::string> drones;  // empty = every drone of the scenario
  SelectorConfig selector;          // the agent's selection; strategy and density set per point
  CodecConfig codec;                // the agent's JPEG quality (bytes sent)
  std::string vocabulary = "orb_vocabulary.bin";  // place recognition (a bare name: shipped)
  int orb_features = 1000;
  int query_every = 10;            // place queries: every n-th frame of the query drone
  double place_tolerance_m = 5.0;  // a retrieved keyframe is right within this street distance
  int ocr_threads = 2;             // text readers at once (one Tesseract each)
};

// One link of the bandwidth experiment, per drone (not shared between drones).
struct LinkProfileConfig {
  std::string name = "unlimited";  // [A-Za-z0-9_.-]
  double rate_kbit_s = 0;          // 0 = unlimited
  double delay_ms = 0;             // netns links only, and only where the kernel has netem
  double loss_percent = 0;         // netns links only, and only where the kernel has netem
};

// `keyfleet experiment bandwidth`: one mission per drone count x link kind x profile.
struct BandwidthExperimentConfig {
  std::string name = "bandwidth";
  std::string run_root = "runs";  // the experiment's folder: <run_root>/<name>-<time>-<pid>/
  std::vector<int> drones = {2, 4, 8};
  std::vector<LinkProfileConfig> profiles = {LinkProfileConfig{}};
  // flow_control: each agent's DDS flow controller at the profile's rate (localhost transport).
  // netns (root only, else skipped with the reason): each drone in its own network namespace,
  // a veth link to the station's namespace shaped by tbf (+ netem where the kernel has it).
  std::vector<std::string> links = {"flow_control", "netns"};
  // netns: the agents' DDS cap as a fraction of the link rate, so that RTPS, UDP and IP
  // headers fit under it; at 0.9 a 500 kbit/s tbf link overflowed and most bytes on the wire
  // were repairs (0 = no DDS cap, the link alone limits).
  double netns_dds_cap_fraction = 0.7;
  double bin_s = 1.0;                     // bandwidth-over-time bins (s)
  std::string python = "/usr/bin/python3";  // runs tools/report/bandwidth_report.py (matplotlib)
  MissionConfig mission;  // agent and station templates; name and drones are set per mission
};

// Loaders throw ConfigError naming the file, the key and what is allowed.
AgentConfig load_agent_config(const std::string& path);
StationConfig load_station_config(const std::string& path);
MissionConfig load_mission_config(const std::string& path);
ScenarioConfig load_scenario_config(const std::string& path);
BandwidthExperimentConfig load_bandwidth_experiment_config(const std::string& path);
EvalConfig load_eval_config(const std::string& path);

std::string to_yaml(const AgentConfig& config);
std::string to_yaml(const StationConfig& config);
std::string to_yaml(const MissionConfig& config);
std::string to_yaml(const ScenarioConfig& config);
std::string to_yaml(const BandwidthExperimentConfig& config);
std::string to_yaml(const EvalConfig& config);

// Parses YAML text (for tests and generated configs); `origin` names it in errors.
AgentConfig parse_agent_config(const std::string& text, const std::string& origin);
StationConfig parse_station_config(const std::string& text, const std::string& origin);
MissionConfig parse_mission_config(const std::string& text, const std::string& origin);
ScenarioConfig parse_scenario_config(const std::string& text, const std::string& origin);
BandwidthExperimentConfig parse_bandwidth_experiment_config(const std::string& text,
                                                            const std::string& origin);
EvalConfig parse_eval_config(const std::string& text, const std::string& origin);

bool is_valid_robot_id(const std::string& robot_id);

}  // namespace keyfleet
