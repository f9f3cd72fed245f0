#include "keyfleet/common/opencv_io.hpp"

#include <dlfcn.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <mutex>

#include "keyfleet/common/error.hpp"

namespace keyfleet {

namespace fs = std::filesystem;

std::vector<std::string> plugin_places(const Plugin& plugin) {
  std::vector<fs::path> folders;
  if (const char* dir = std::getenv("KEYFLEET_PLUGIN_DIR"); dir && *dir) folders.emplace_back(dir);
  std::error_code error;
  const fs::path self = fs::read_symlink("/proc/self/exe", error);
  if (!error) folders.push_back(self.parent_path().parent_path() / "lib" / "keyfleet");
#ifdef KEYFLEET_BUILD_PLUGIN_DIR
  folders.emplace_back(KEYFLEET_BUILD_PLUGIN_DIR);
#endif
  std::vector<std::string> files;  // each once (the build's folder is often <bin>/../lib too)
  for (const fs::path& folder : folders) {
    const std::string file = (folder.lexically_normal() / plugin.file).string();
    if (std::find(files.begin(), files.end(), file) == files.end()) files.push_back(file);
  }
  return files;
}

const void* load_plugin(const Plugin& plugin, const std::vector<std::string>& files) {
  std::string tried;
  for (const fs::path file : files) {
    std::error_code error;
    if (!fs::is_regular_file(file, error)) {
      tried += "\n  " + file.string() + ": not there";
      continue;
    }
    void* library = dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL);  // the plugin's kept for good
    if (!library) {
      const char* why = dlerror();
      tried += "\n  " + file.string() + ": " + (why ? why : "dlopen failed");
      continue;
    }
    using Entry = const void* (*)();
    const auto entry = reinterpret_cast<Entry>(dlsym(library, plugin.entry));
    if (const void* found = entry ? entry() : nullptr) return found;
    dlclose(library);
    tried += "\n  " + file.string() + ": no " + plugin.entry;
  }
  throw StartupError(std::string("OpenCV's files need ") + plugin.file +
                     " (built beside the programs: scripts/build.sh), found nowhere:" + tried);
}

namespace {

template <class Interface>
const Interface& loaded(const Plugin& plugin) {
  static std::once_flag once;
  static const Interface* found = nullptr;
  std::call_once(once, [&] {
    found = static_cast<const Interface*>(load_plugin(plugin, plugin_places(plugin)));
  });
  return *found;
}

}  // namespace

const ImageFiles& image_files() { return loaded<ImageFiles>(kImagesPlugin); }
const VideoFiles& video_files() { return loaded<VideoFiles>(kVideoPlugin); }

}  // namespace keyfleet
