#pragma once

namespace keyfleet {

// Keeps large image buffers in the heap instead of returning them to the kernel after each
// frame: with glibc's defaults every full-frame temporary is a fresh mmap and page faults
// cost a third of the scenario generator's time. Process-wide: call from main.
void keep_image_buffers_in_heap();

}  // namespace keyfleet

namespace keyfleet {

// Tesseract splits each read over OpenMP threads with explicit num_threads clauses, which
// only OMP_THREAD_LIMIT bounds, and OpenMP reads it once, when the library loads. Processes
// that run one reader per worker thread call this first thing in main: when the variable is
// unset it is set to 1 and the process re-executes itself (the same arguments); on failure
// it carries on as it is. A user's own OMP_THREAD_LIMIT is kept.
void limit_openmp_to_one_thread(char** argv);

}  // namespace keyfleet

namespace keyfleet {

// Run folders hold pictures of where the robots were, credentials and the dashboard's token:
// what the process creates from then on is its owner's alone (umask 077: folders 0700, files
// 0600). Process-wide: call first thing in main.
void keep_created_files_private();

}  // namespace keyfleet

namespace keyfleet {

// The soft open-file limit is often 1,024 beside a far higher hard one: takes what is allowed
// (65,536 where the hard limit is unlimited), so that a station's DDS, databases, reports and
// dashboard connections have room. Process-wide: call from main.
void raise_open_file_limit();

}  // namespace keyfleet
