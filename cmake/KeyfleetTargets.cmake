# Shared helpers for keyfleet's targets: one warning policy, one way to register tests.

function(keyfleet_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic)
  if(KEYFLEET_WARNINGS_AS_ERRORS)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

# keyfleet_add_gtest(NAME SOURCES ... LIBS ... [LABELS ...] [TIMEOUT s])
# Tests labelled "integration" run real DDS processes: they hold a lock so that parallel
# ctest never runs two of them at once (they also use distinct domains and partitions).
function(keyfleet_add_gtest name)
  cmake_parse_arguments(ARG "" "TIMEOUT" "SOURCES;LIBS;LABELS" ${ARGN})
  set(lock "")
  if("integration" IN_LIST ARG_LABELS)
    set(lock RESOURCE_LOCK keyfleet_processes)
  endif()
  add_executable(${name} ${ARG_SOURCES})
  keyfleet_set_warnings(${name})
  # Tests read and write image files with OpenCV's codecs themselves (the libraries load them
  # through the plugin of keyfleet/common/opencv_io.hpp).
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} opencv_imgcodecs GTest::gtest_main)
  include(GoogleTest)
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 120)
  endif()
  gtest_discover_tests(${name}
    DISCOVERY_TIMEOUT 60
    PROPERTIES TIMEOUT ${ARG_TIMEOUT} LABELS "${ARG_LABELS}" ${lock}
               SKIP_REGULAR_EXPRESSION "\\[  SKIPPED \\]"
    ENVIRONMENT "KEYFLEET_DATA=${KEYFLEET_DATA_DIR}")
endfunction()
