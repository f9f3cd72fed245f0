#include "keyfleet/vision/model_files.hpp"

#include <filesystem>

#include "keyfleet/common/error.hpp"

namespace keyfleet::vision {

std::string locate_model(const std::string& configured, const std::string& what) {
  namespace fs = std::filesystem;
  if (fs::is_regular_file(configured)) return configured;
  std::error_code error;
  const fs::path self = fs::read_symlink("/proc/self/exe", error);
  const fs::path shared = self.parent_path().parent_path() / "share" / "keyfleet" / "models";
  if (!error && fs::path(configured).is_relative()) {
    const fs::path installed = shared / configured;
    if (fs::is_regular_file(installed)) return installed.string();
  }
  throw StartupError(what + ": '" + configured + "' not found (as given, or in " + shared.string() +
                     ")");
}

}  // namespace keyfleet::vision
