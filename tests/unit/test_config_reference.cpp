// docs/configuration.md lists every config key between two markers; that part is generated from
// the config structs' descriptions, so a key added, renamed or given another default or check
// without regenerating the page fails here.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "keyfleet/mission/config_reference.hpp"

namespace {

const char* const kBegin = "<!-- config-reference:begin -->\n";
const char* const kEnd = "<!-- config-reference:end -->";

std::string first_difference(const std::string& want, const std::string& have) {
  std::istringstream a(want), b(have);
  std::string line_a, line_b;
  for (int line = 1;; ++line) {
    const bool more_a = static_cast<bool>(std::getline(a, line_a));
    const bool more_b = static_cast<bool>(std::getline(b, line_b));
    if (!more_a && !more_b) return "no line differs";
    if (line_a != line_b || more_a != more_b)
      return "first difference at line " + std::to_string(line) + " of the generated part:\n" +
             "  generated: " + (more_a ? line_a : "(end)") + "\n" +
             "  the page:  " + (more_b ? line_b : "(end)");
  }
}

TEST(ConfigReference, ListsKeysWithTypeDefaultAndCheck) {
  const std::string reference = keyfleet::config_reference_markdown();
  EXPECT_NE(reference.find("| `dds.link.rate_kbit_s` | number | `0` | 0 to 1e+07 |"),
            std::string::npos)
      << reference;
  EXPECT_NE(reference.find("| `selector.strategy` | choice | `full` | one of vslam, quality, "
                           "semantic, full |"),
            std::string::npos);
  EXPECT_NE(reference.find("| `log_level` | string | `info` | one of debug, error, info, trace, "
                           "warn |"),
            std::string::npos);
  EXPECT_NE(reference.find("| `limits.allowed_robots` | list of strings | `[]` |"),
            std::string::npos);
}

TEST(ConfigReference, DocsPageMatchesTheConfigStructs) {
  const std::string path = std::string(KEYFLEET_SOURCE_DIR) + "/docs/configuration.md";
  std::ifstream in(path);
  ASSERT_TRUE(in) << "cannot read " << path;
  std::ostringstream text;
  text << in.rdbuf();
  const std::string page = text.str();
  const auto begin = page.find(kBegin);
  const auto end = page.find(kEnd);
  ASSERT_TRUE(begin != std::string::npos && end != std::string::npos && begin < end)
      << path << ": the markers " << kBegin << " and " << kEnd << " are missing";
  const std::string on_page =
      page.substr(begin + std::string(kBegin).size(), end - begin - std::string(kBegin).size());
  const std::string generated = keyfleet::config_reference_markdown();
  EXPECT_TRUE(on_page == generated)
      << path << " no longer matches the config structs; regenerate it with\n"
      << "  scripts/docs_config.sh   (build/bin/keyfleet config reference prints the part)\n"
      << first_difference(generated, on_page);
}

}  // namespace
