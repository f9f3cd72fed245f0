#include "keyfleet/common/process_tuning.hpp"

#include <malloc.h>

namespace keyfleet {

void keep_image_buffers_in_heap() {
  mallopt(M_MMAP_THRESHOLD, 64 << 20);
  mallopt(M_TRIM_THRESHOLD, 512 << 20);
}

}  // namespace keyfleet
