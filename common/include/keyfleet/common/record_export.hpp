#pragma once
// A sample as JSON (one object, fields in order) and as CSV (a header and one row a sample),
// from its field list (record_fields.hpp). The image is written as its size ("image_bytes"),
// never its bytes, and read back as nothing; camera_pose is an object (null without a pose),
// text_regions and stages arrays; in CSV the pose is seven columns camera_pose_tx..camera_pose_qw
// (empty without a pose) and arrays are JSON text in one cell.
#include <string>

#include "keyfleet/common/types.hpp"

namespace keyfleet {

std::string to_json(const Keyframe& keyframe);
std::string to_json(const AgentStats& stats);
// Throws std::invalid_argument when the text is not such an object.
void from_json(const std::string& text, Keyframe& keyframe);
void from_json(const std::string& text, AgentStats& stats);

template <class R>
std::string csv_header();  // the names, comma separated, no newline
std::string csv_row(const Keyframe& keyframe);
std::string csv_row(const AgentStats& stats);
// Reads a row under csv_header<R>(); throws std::invalid_argument on a malformed row.
void from_csv_row(const std::string& row, Keyframe& keyframe);
void from_csv_row(const std::string& row, AgentStats& stats);

extern template std::string csv_header<Keyframe>();
extern template std::string csv_header<AgentStats>();

}  // namespace keyfleet
