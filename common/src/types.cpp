#include "keyfleet/common/types.hpp"

namespace keyfleet {

const char* to_string(AckStatus status) {
  switch (status) {
    case AckStatus::kStored: return "stored";
    case AckStatus::kDuplicate: return "duplicate";
    case AckStatus::kRejected: return "rejected";
    case AckStatus::kConflict: return "conflict";
  }
  return "unknown";
}

}  // namespace keyfleet
