#pragma once

namespace keyfleet {

// Keeps large image buffers in the heap instead of returning them to the kernel after each
// frame: with glibc's defaults every full-frame temporary is a fresh mmap and page faults
// cost a third of the scenario generator's time. Process-wide: call from main.
void keep_image_buffers_in_heap();

}  // namespace keyfleet
