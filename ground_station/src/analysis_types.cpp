#include "keyfleet/station/analysis_types.hpp"

namespace keyfleet::station {

std::string to_string(const KeyframeKey& key) {
  return key.robot_id + "#" + std::to_string(key.sequence);
}

AnalysisJob job_for(const Keyframe& k, cv::Mat decoded) {
  return AnalysisJob{{k.robot_id, k.sequence_number},
                     k.capture_time_ns,
                     k.camera_pose,
                     k.image,
                     k.text_regions,
                     std::move(decoded)};
}

const char* to_string(AnalysisStatus status) {
  switch (status) {
    case AnalysisStatus::kDone: return "done";
    case AnalysisStatus::kDeferred: return "deferred";
    case AnalysisStatus::kFailed: return "failed";
  }
  return "unknown";
}

}  // namespace keyfleet::station
