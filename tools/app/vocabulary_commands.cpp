// `keyfleet vocabulary build|info`: the place-recognition vocabulary, built reproducibly from
// image folders (a generated scenario's frames work as they are).
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include "commands.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/station/places/orb_extractor.hpp"
#include "keyfleet/station/places/orb_vocabulary.hpp"

namespace keyfleet::commands {
namespace {

namespace fs = std::filesystem;

struct BuildOptions {
  std::vector<std::string> image_dirs;
  std::string out;
  station::VocabularyParams vocabulary;
  station::OrbParams orb;
  std::size_t max_images = 0;
};

bool is_image(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return ext == ".jpg" || ext == ".jpeg" || ext == ".png" || ext == ".bmp" || ext == ".pgm" ||
         ext == ".ppm";
}

// Every image under the folders, sorted by path, then evenly thinned to at most max_images:
// the same folders always give the same list.
std::vector<fs::path> list_images(const std::vector<std::string>& dirs, std::size_t max_images) {
  std::vector<fs::path> images;
  for (const auto& dir : dirs) {
    if (!fs::is_directory(dir)) throw StartupError("vocabulary build: " + dir + " is not a folder");
    for (const auto& entry : fs::recursive_directory_iterator(dir))
      if (entry.is_regular_file() && is_image(entry.path())) images.push_back(entry.path());
  }
  std::sort(images.begin(), images.end());
  images.erase(std::unique(images.begin(), images.end()), images.end());
  if (max_images == 0 || images.size() <= max_images) return images;
  std::vector<fs::path> kept;
  for (std::size_t i = 0; i < max_images; ++i)
    kept.push_back(images[i * images.size() / max_images]);
  return kept;
}

void run_build(const BuildOptions& o) {
  const auto start = std::chrono::steady_clock::now();
  const auto images = list_images(o.image_dirs, o.max_images);
  if (images.empty()) throw StartupError("vocabulary build: no images found in the given folders");
  std::printf("%zu images; ORB %d features%s\n", images.size(), o.orb.features,
              o.orb.min_width > 0
                  ? (", upscaled to width " + std::to_string(o.orb.min_width)).c_str()
                  : "");
  std::vector<cv::Mat> descriptors(images.size());
  std::vector<char> unreadable(images.size(), 0);
  cv::parallel_for_(cv::Range(0, int(images.size())), [&](const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i) {
      const cv::Mat image = cv::imread(images[std::size_t(i)].string(), cv::IMREAD_GRAYSCALE);
      if (image.empty()) {
        unreadable[std::size_t(i)] = 1;
        continue;
      }
      descriptors[std::size_t(i)] = station::extract_orb(image, o.orb).descriptors;
    }
  });
  std::size_t total = 0;
  for (std::size_t i = 0; i < images.size(); ++i) {
    if (unreadable[i]) std::fprintf(stderr, "warning: cannot read %s\n", images[i].c_str());
    total += std::size_t(descriptors[i].rows);
  }
  const double extract_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("%zu descriptors (%.0f per image) in %.1f s\n", total,
              double(total) / double(images.size()), extract_s);

  const auto vocabulary = station::OrbVocabulary::build(descriptors, o.vocabulary);
  vocabulary.save(o.out);
  const double total_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("%zu words, %zu nodes (k=%d, L=%d, seed %u) in %.1f s (clustering %.1f s)\n",
              vocabulary.word_count(), vocabulary.node_count(), o.vocabulary.branching,
              o.vocabulary.depth, o.vocabulary.seed, total_s, total_s - extract_s);
  std::printf("written %s (%.2f MB)\n", o.out.c_str(), double(fs::file_size(o.out)) / 1e6);
}

void run_info(const std::string& path) {
  const auto v = station::OrbVocabulary::load(path);
  const auto& p = v.params();
  std::printf("%s: %.2f MB\n", path.c_str(), double(fs::file_size(path)) / 1e6);
  std::printf("branching %d, depth %d, k-means iterations %d, seed %u\n", p.branching, p.depth,
              p.kmeans_iterations, p.seed);
  std::printf("%zu nodes, %zu words, trained on %llu images\n", v.node_count(), v.word_count(),
              static_cast<unsigned long long>(v.training_images()));
  std::map<unsigned, std::size_t> words_at_level;
  float lo = 1e30f, hi = 0;
  for (const auto& n : v.nodes())
    if (n.child_count == 0) {
      ++words_at_level[n.level];
      lo = std::min(lo, n.idf);
      hi = std::max(hi, n.idf);
    }
  for (const auto& [level, count] : words_at_level)
    std::printf("  words at level %u: %zu\n", level, count);
  std::printf("IDF weights in [%.3f, %.3f]\n", double(lo), double(hi));
}

}  // namespace

void add_vocabulary_commands(CLI::App& app) {
  auto* vocabulary = app.add_subcommand("vocabulary", "the ORB bag-of-words place vocabulary");
  vocabulary->require_subcommand(1);

  auto options = std::make_shared<BuildOptions>();
  auto* build = vocabulary->add_subcommand(
      "build", "cluster the ORB descriptors of image folders into a vocabulary file");
  build->add_option("--images", options->image_dirs, "image folders, walked recursively")
      ->required()
      ->check(CLI::ExistingDirectory);
  build->add_option("--out", options->out, "vocabulary file to write")->required();
  build->add_option("--branching", options->vocabulary.branching, "k: children per node")
      ->check(CLI::Range(2, 64));
  build->add_option("--depth", options->vocabulary.depth, "L: levels (up to k^L words)")
      ->check(CLI::Range(1, 8));
  build->add_option("--iterations", options->vocabulary.kmeans_iterations,
                    "k-means iterations per node");
  build->add_option("--seed", options->vocabulary.seed, "k-means++ seed");
  build->add_option("--max-images", options->max_images,
                    "use at most N images, evenly spread over the sorted list (0 = all)");
  build->add_option("--features", options->orb.features, "ORB features per image")
      ->check(CLI::Range(10, 100000));
  build
      ->add_option("--min-width", options->orb.min_width,
                   "upscale narrower images to this width before ORB (0 = never)")
      ->check(CLI::Range(0, 8192));
  build->callback([options] { run_reporting([&] { run_build(*options); }); });

  auto file = std::make_shared<std::string>();
  auto* info = vocabulary->add_subcommand("info", "describe a vocabulary file");
  info->add_option("file", *file, "vocabulary file")->required()->check(CLI::ExistingFile);
  info->callback([file] { run_reporting([&] { run_info(*file); }); });
}

}  // namespace keyfleet::commands
