#include "keyfleet/scenario/texture_library.hpp"
#include "keyfleet/scenario/scenario_config.hpp"

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "keyfleet/common/error.hpp"

namespace keyfleet::scenario {
namespace {

namespace fs = std::filesystem;

constexpr std::size_t kMaxFonts = 24;
constexpr int kMinPhotoWidth = 320;  // smaller images are crops, not facades

const std::vector<std::string> kShopWords = {
    "HOTEL",    "PHARMACY", "BAKERY",  "CAFE",     "BOOKS",     "MARKET",   "BANK",    "PIZZA",
    "FLOWERS",  "SHOES",    "MUSEUM",  "TAXI",     "GARAGE",    "CINEMA",   "TOYS",    "DELI",
    "BAR",      "SUSHI",    "OPTICS",  "DENTIST",  "FASHION",   "JEWELRY",  "BUTCHER", "GROCERY",
    "LAUNDRY",  "BARBER",   "TAILOR",  "KEBAB",    "NOODLES",   "BISTRO",   "PUB",     "TEA",
    "SPORTS",   "MUSIC",    "GIFTS",   "TICKETS",  "POST",      "LIBRARY",  "CLINIC",  "HOSTEL",
    "SALON",    "BURGER",   "RAMEN",   "TACOS",    "WINE",      "CHEESE",   "COFFEE",  "DONUTS",
    "CAMERA",   "MOBILE",   "REPAIR",  "PRINT",    "OUTLET",    "BOUTIQUE", "GALLERY", "THEATRE",
    "PARKING",  "EXIT",     "OPEN",    "SALE",     "ICE CREAM", "FRUIT",    "FISH",    "BEAUTY",
    "HARDWARE", "KIOSK",    "LOTTERY", "ANTIQUES", "BICYCLES",  "PHOTO",    "TRAVEL",  "INSURANCE"};

// Fonts without ordinary letters: symbol sets, and the TeX math fonts that fonts-lyx (pulled
// in by python3-matplotlib) installs beside the text fonts.
bool is_symbol_font(const fs::path& file) {
  const std::string name = file.filename().string();
  for (const char* symbolic : {"Symbol", "D050000L", "Dingbat", "dingbat"})
    if (name.find(symbolic) != std::string::npos) return true;
  return file.parent_path().filename() == "lyx";
}

std::vector<fs::path> sorted_files(const std::string& folder, const std::set<std::string>& exts,
                                   bool recursive) {
  std::vector<fs::path> files;
  std::error_code error;
  auto consider = [&](const fs::directory_entry& entry) {
    std::string ext = entry.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    if (entry.is_regular_file() && exts.count(ext)) files.push_back(entry.path());
  };
  if (recursive) {
    for (fs::recursive_directory_iterator it(folder, error), end; !error && it != end;
         it.increment(error))
      consider(*it);
  } else {
    for (fs::directory_iterator it(folder, error), end; !error && it != end; it.increment(error))
      consider(*it);
  }
  std::sort(files.begin(), files.end());
  return files;
}

// ICDAR keeps ground truth in gt/gt_<image stem>.txt beside or above the image folder.
std::string ground_truth_for(const fs::path& image) {
  const std::string name = "gt_" + image.stem().string() + ".txt";
  for (const fs::path& candidate :
       {image.parent_path() / "gt" / name, image.parent_path().parent_path() / "gt" / name})
    if (fs::exists(candidate)) return candidate.string();
  return {};
}

}  // namespace

std::vector<PhotoWord> read_icdar_ground_truth(const std::string& path) {
  std::ifstream in(path);
  std::vector<PhotoWord> words;
  std::string line;
  while (std::getline(in, line)) {
    if (line.size() >= 3 && static_cast<unsigned char>(line[0]) == 0xEF) line = line.substr(3);
    while (!line.empty() && (line.back() == '\r' || line.back() == '\n')) line.pop_back();
    std::stringstream fields(line);
    std::vector<std::string> parts;
    std::string part;
    while (std::getline(fields, part, ',')) parts.push_back(part);
    if (parts.size() < 9) continue;
    PhotoWord word;
    try {
      for (int i = 0; i < 4; ++i)
        word.quad.emplace_back(std::stof(parts[2 * i]), std::stof(parts[2 * i + 1]));
    } catch (const std::exception&) {
      continue;
    }
    std::string text = parts[8];
    for (std::size_t i = 9; i < parts.size(); ++i) text += "," + parts[i];  // commas in words
    word.legible = text != "###";
    word.text = text;
    words.push_back(word);
  }
  return words;
}

TextureLibrary::TextureLibrary(const TextureConfig& config) {
  std::vector<std::string> folders = config.photo_folders;
  for (const auto& folder : config.optional_photo_folders)
    if (fs::is_directory(folder)) folders.push_back(folder);
  for (const auto& folder : folders) {
    for (const auto& file : sorted_files(folder, {".jpg", ".jpeg", ".png"}, false)) {
      if (static_cast<int>(photos_.size()) >= config.max_photos) break;
      if (file.stem().string().find("_mask") != std::string::npos) continue;
      cv::Mat image = cv::imread(file.string(), cv::IMREAD_COLOR);
      if (image.empty() || image.cols < kMinPhotoWidth) continue;
      Photo photo{file.string(), image, {}, false};
      if (const std::string gt = ground_truth_for(file); !gt.empty()) {
        photo.words = read_icdar_ground_truth(gt);
        photo.annotated = true;
      }
      photos_.push_back(std::move(photo));
    }
  }
  if (!config.photo_folders.empty() && photos_.empty())
    throw StartupError("textures.photo_folders: no usable photos (jpg/png, at least " +
                       std::to_string(kMinPhotoWidth) + " px wide) in the configured folders");

  // Spread the choice over every family found rather than the first few of one.
  std::vector<fs::path> candidates;
  for (const auto& folder : config.font_folders)
    for (const auto& file : sorted_files(folder, {".ttf", ".otf"}, true))
      if (!is_symbol_font(file)) candidates.push_back(file);
  const std::size_t step = std::max<std::size_t>(1, candidates.size() / kMaxFonts);
  for (std::size_t i = 0; i < candidates.size() && fonts_.size() < kMaxFonts; i += step) {
    auto font = cv::freetype::createFreeType2();
    try {
      font->loadFontData(candidates[i].string(), 0);
    } catch (const cv::Exception&) {
      continue;
    }
    fonts_.push_back(font);
  }
  if (fonts_.empty())
    throw StartupError(
        "textures.font_folders: no TrueType/OpenType fonts found (install fonts-dejavu-core, "
        "or name a folder with .ttf files)");

  if (config.word_list.empty()) {
    words_ = kShopWords;
  } else {
    std::ifstream in(config.word_list);
    for (std::string word; std::getline(in, word);)
      if (!word.empty() && word.size() <= 24) words_.push_back(word);
    if (words_.empty())
      throw StartupError("textures.word_list: '" + config.word_list + "' holds no words");
  }
}

}  // namespace keyfleet::scenario
