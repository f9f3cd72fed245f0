// The YAML description of the text reader's settings (text_reading_config.hpp), instantiated
// for the three visitors. The engines' sections keep the flat keys they always had.
#include "keyfleet/station/text/text_reading_config_yaml.hpp"

#include <algorithm>
#include <regex>

#include "keyfleet/station/text/text_reader.hpp"

namespace keyfleet {

// "WxH", both sides positive multiples of 32 up to 4096 (the converted detectors' input sizes).
static Check<std::string> detector_size_check() {
  return Check<std::string>(
      [](const std::string& v) {
        std::smatch m;
        const std::string rule = "must be auto or WxH, sides multiples of 32 from 32 to 4096";
        if (v == "auto") return std::string();
        if (!std::regex_match(v, m, std::regex("([0-9]{1,4})x([0-9]{1,4})"))) return rule;
        for (int i = 1; i <= 2; ++i) {
          const int side = std::stoi(m[i].str());
          if (side < 32 || side > 4096 || side % 32 != 0) return rule;
        }
        return std::string();
      },
      "auto or WxH, sides multiples of 32 from 32 to 4096");
}

// An engine to read with where the configured one's models are missing (the factory's list),
// or empty (refuse).
static Check<std::string> fallback_engine_check() {
  std::string engines;
  for (const auto& name : station::text_reader_engines()) engines += ", " + name;
  return Check<std::string>(
      [engines](const std::string& v) {
        const auto known = station::text_reader_engines();
        if (v.empty() || std::find(known.begin(), known.end(), v) != known.end())
          return std::string();
        return "must be empty (refuse to start) or one of the engines" + engines.substr(1);
      },
      "empty (refuse to start) or an engine:" + engines.substr(1));
}

template <class V>
void visit(V& v, TextReadingConfig& c) {
  v.field("enabled", c.enabled);
  v.field("engine", c.engine);
  v.field("fallback_engine", c.fallback_engine, fallback_engine_check());
  v.field("tessdata_dir", c.tesseract.tessdata_dir);
  v.field("language", c.tesseract.language);
  v.field("thresholding_method", c.tesseract.thresholding_method, between(0, 2));
  v.field("min_confidence", c.min_confidence, between(0.0, 1.0));
  v.field("min_word_length", c.min_word_length, between(1, 64));
  v.field("min_word_height", c.min_word_height, between(0, 8192));
  v.field("min_long_side", c.min_long_side, between(0, 8192));
  v.field("max_long_side", c.max_long_side, between(0, 16384));
  v.field("segmenter_model", c.mininet.segmenter_model);
  v.field("segmenter_widths", c.mininet.segmenter_widths);
  v.field("threads", c.threads, between(0, 64));
  v.field("region_padding", c.mininet.region_padding, between(0.0, 4.0));
  v.field("region_line_height", c.tesseract.line_height, between(8, 1024));
  v.field("max_regions", c.max_regions, between(1, 10000));
  v.field("cut_word_margin", c.ppocr.cut_word_margin, between(-1, 1000));
  v.field("region_hints", c.ppocr.region_hints, one_of({"off", "only", "first"}));
  v.field("region_hint_detector_size", c.ppocr.region_hint_detector_size, detector_size_check());
  v.field("region_hint_padding", c.ppocr.region_hint_padding, between(0.0, 4.0));
  v.field("ppocr_models", c.ppocr.models);
  v.field("ppocr_detector_size", c.ppocr.detector_size, detector_size_check());
  v.field("ppocr_keyframe_detector", c.ppocr.keyframe_detector);
  v.field("ppocr_binary_threshold", c.ppocr.binary_threshold, between(0.0, 1.0));
  v.field("ppocr_box_threshold", c.ppocr.box_threshold, between(0.0, 1.0));
  v.field("ppocr_unclip_ratio", c.ppocr.unclip_ratio, between(0.0, 10.0));
  v.field("ppocr_latin_only", c.ppocr.latin_only);
  v.field("ppocr_space_probability", c.ppocr.space_probability, between(0.0, 1.0));
  v.field("ppocr_int8", c.ppocr.int8);
  v.field("lexicon", c.lexicon);
}

template void visit(ConfigReader&, TextReadingConfig&);
template void visit(ConfigWriter&, TextReadingConfig&);
template void visit(ConfigReference&, TextReadingConfig&);

}  // namespace keyfleet
