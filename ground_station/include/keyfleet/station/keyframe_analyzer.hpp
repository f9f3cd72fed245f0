#pragma once
#include "keyfleet/common/image_codec.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/station/analysis_types.hpp"
#include "keyfleet/station/place_recognizer.hpp"
#include "keyfleet/station/station_config.hpp"
#include "keyfleet/vision/place_describer.hpp"

namespace keyfleet::station {

// The station's heavy work on one stored keyframe, as one synchronous step: decode, ORB and the
// holistic descriptor, place recognition against what came before (then joins the index), text
// reading. Either part may be absent (disabled), and the describer where the retrieval is the
// bag of words alone. One analyzer per worker thread: TextReaders and describers keep per-engine
// state; the PlaceRecognizer is shared and thread-safe.
class KeyframeAnalyzer {
 public:
  KeyframeAnalyzer(std::unique_ptr<TextReader> reader, PlaceRecognizer* places,
                   std::unique_ptr<vision::PlaceDescriber> describer, const AnalysisConfig& config,
                   Logger logger);

  AnalysisResult analyse(const AnalysisJob& job);

 private:
  std::unique_ptr<TextReader> reader_;
  PlaceRecognizer* places_;
  std::unique_ptr<vision::PlaceDescriber> describer_;
  AnalysisConfig config_;
  OrbParams orb_;
  Logger logger_;
  JpegCodec codec_{90};
};

}  // namespace keyfleet::station
