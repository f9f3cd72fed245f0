# `cmake --graphviz` options for scripts/dependency_graph.sh: keyfleet's own libraries and
# executables, plus Fast DDS so that the picture shows who links it.
set(GRAPHVIZ_GRAPH_NAME "keyfleet")
set(GRAPHVIZ_EXTERNAL_LIBS TRUE)
set(GRAPHVIZ_GENERATE_PER_TARGET FALSE)
set(GRAPHVIZ_GENERATE_DEPENDERS FALSE)
set(GRAPHVIZ_IGNORE_TARGETS "^test_" "^bench_" "keyfleet_test_support" "GTest" "gtest" "gmock"
    "benchmark" "^opencv_" "^Boost" "^boost" "spdlog" "fmt" "yaml-cpp" "SQLite" "sqlite"
    "Threads" "pthread" "nlohmann" "CLI11" "Eigen" "protobuf" "PkgConfig" "tesseract" "lept"
    "OpenSSL" "foonathan" "tinyxml" "^dl$" "^rt$" "^-" "^/")
