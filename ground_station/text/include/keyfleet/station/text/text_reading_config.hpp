#pragma once
// The station's text reading settings (analysis.text in the station's config, `keyfleet ocr`,
// `keyfleet eval`'s text:), one section per engine. Their YAML description:
// text_reading_config_yaml.hpp.
#include <string>
#include <vector>

namespace keyfleet {

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
  // With detector_size "auto": the detector of images that fit a keyframe (640x480), in place of
  // the fetched 640x480 file: a detector tuned to a smaller input (models/ppocr/tune_detector.py),
  // found as every model is (vision::locate_model), its input size from the .json beside it;
  // each such image is letterboxed into that size. "" = the fetched 640x480 file. Refused with a
  // fixed detector_size.
  std::string keyframe_detector = "";
  double binary_threshold = 0.3;  // 0..1: text probability of a text pixel
  double box_threshold = 0.6;     // 0..1: min mean probability inside a kept line box
  double unclip_ratio = 1.5;      // line boxes grown by area * ratio / perimeter px
  // The recogniser's list is mostly Chinese: on Latin-script streets its Chinese classes only
  // ever produce junk, so by default it reads Latin letters, digits and punctuation only,
  // through the converted files whose classifier holds the Latin classes alone
  // (ppocr_rec_latin_w<W>.onnx, ppocr_keys_latin.txt: docs/models.md).
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
  // The detector's and recogniser's wide 1x1 convolutions (64 or more channels in and out) in
  // 8-bit integers (vision::DnnLayers::int8_pointwise) on any AVX2 CPU: a keyframe read in 0.87x
  // the time, ICDAR 2015 test_clean F 50.3 % against 50.7 % in float, 223 of 300 word crops
  // against 226 (docs/results/2026-11-27-int8-products.md). false: float, OpenCV's outputs to
  // float rounding.
  bool int8 = true;
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
  // Where the engine's fetched models are not installed (ppocr's come from the npm registry,
  // which a machine may lack: scripts/fetch_ppocr.sh), the station reads with this engine
  // instead (Debian's Tesseract by default), saying so once at start; empty: it refuses to start.
  // Tools that measure an engine (`keyfleet ocr`, `keyfleet eval`) never fall back.
  std::string fallback_engine = "tesseract";
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

}  // namespace keyfleet
