// Files written whole or not at all, and the space held for a run's reports.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "keyfleet/common/file_output.hpp"
#include "test_support.hpp"

namespace keyfleet {
namespace {

namespace fs = std::filesystem;

std::string read(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(WriteFile, ReplacesTheFileWholeAndLeavesNoTemporary) {
  test::TempDir dir;
  const fs::path path = dir.file("report.json");
  write_file(path, "{\"old\": 1}\n");
  write_file(path, "{}\n");
  EXPECT_EQ(read(path), "{}\n");
  EXPECT_FALSE(fs::exists(path.string() + ".tmp"));
}

TEST(WriteFile, AFailureNamesThePathAndTheReason) {
  test::TempDir dir;
  const fs::path path = fs::path(dir.file("missing_folder")) / "report.json";
  try {
    write_file(path, "x");
    FAIL() << "writing into a missing folder succeeded";
  } catch (const std::runtime_error& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(path.string()), std::string::npos) << message;
    EXPECT_NE(message.find("No such file or directory"), std::string::npos) << message;
  }
}

TEST(DiskReserve, HoldsTheBytesUntilReleased) {
  test::TempDir dir;
  const fs::path path = dir.file("report.reserve");
  {
    DiskReserve reserve(path, 300000);
    EXPECT_EQ(reserve.held_bytes(), 300000u);
    EXPECT_TRUE(reserve.problem().empty());
    EXPECT_EQ(fs::file_size(path), 300000u);
    reserve.release();
    EXPECT_FALSE(fs::exists(path));
    EXPECT_EQ(reserve.held_bytes(), 0u);
  }
  { DiskReserve none(path, 0); }
  EXPECT_FALSE(fs::exists(path));
  { DiskReserve dropped(path, 1000); }
  EXPECT_FALSE(fs::exists(path)) << "the reserve outlived its owner";
}

TEST(DiskReserve, SaysWhyItHoldsNothingWhereItCannotCreateItsFile) {
  test::TempDir dir;
  DiskReserve reserve(fs::path(dir.file("missing_folder")) / "report.reserve", 1000);
  EXPECT_EQ(reserve.held_bytes(), 0u);
  EXPECT_NE(reserve.problem().find("cannot create"), std::string::npos) << reserve.problem();
}

}  // namespace
}  // namespace keyfleet
