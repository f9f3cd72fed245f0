#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "keyfleet/common/error.hpp"
#include "keyfleet/common/fnv1a.hpp"
#include "keyfleet/station/places/orb_vocabulary.hpp"
#include "vocabulary_checks.hpp"

// The vocabulary file: magic, version, parameters, training image count, then the nodes in
// breadth-first order (parent, centroid, IDF), then an FNV-1a checksum of all that.
namespace keyfleet::station {
namespace {

constexpr char kMagic[8] = {'K', 'F', 'O', 'R', 'B', 'V', 'O', 'C'};
constexpr std::uint32_t kVersion = 1;
constexpr std::size_t kHeaderBytes = 8 + 4 * 6 + 8 + 4;  // magic, version..bytes, images, nodes
constexpr std::size_t kNodeBytes = 4 + OrbVocabulary::kDescriptorBytes + 4;
constexpr std::size_t kChecksumBytes = 8;

// Little-endian writers and readers, so that the file is the same on every host.
void put32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(std::uint8_t(v >> (8 * i)));
}
void put64(std::vector<std::uint8_t>& out, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) out.push_back(std::uint8_t(v >> (8 * i)));
}
std::uint32_t get32(const std::uint8_t* p) {
  std::uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= std::uint32_t(p[i]) << (8 * i);
  return v;
}
std::uint64_t get64(const std::uint8_t* p) {
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= std::uint64_t(p[i]) << (8 * i);
  return v;
}

}  // namespace

void OrbVocabulary::save(const std::string& path) const {
  std::vector<std::uint8_t> out(std::begin(kMagic), std::end(kMagic));
  put32(out, kVersion);
  put32(out, std::uint32_t(params_.branching));
  put32(out, std::uint32_t(params_.depth));
  put32(out, std::uint32_t(params_.kmeans_iterations));
  put32(out, params_.seed);
  put32(out, kDescriptorBytes);
  put64(out, training_images_);
  put32(out, std::uint32_t(nodes_.size()));
  for (const Node& n : nodes_) {
    put32(out, n.parent);
    out.insert(out.end(), n.centroid.begin(), n.centroid.end());
    std::uint32_t bits;
    std::memcpy(&bits, &n.idf, 4);
    put32(out, bits);
  }
  put64(out, fnv1a64(out));
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  file.write(reinterpret_cast<const char*>(out.data()), std::streamsize(out.size()));
  file.close();
  if (!file) throw StartupError("vocabulary " + path + ": cannot write the file");
}

OrbVocabulary OrbVocabulary::load(const std::string& path) {
  auto fail = [&](const std::string& what) -> void {
    throw StartupError("vocabulary " + path + ": " + what);
  };
  std::ifstream file(path, std::ios::binary);
  if (!file) fail("cannot open the file");
  const std::vector<std::uint8_t> in((std::istreambuf_iterator<char>(file)),
                                     std::istreambuf_iterator<char>());
  if (in.size() < sizeof(kMagic) || std::memcmp(in.data(), kMagic, sizeof(kMagic)) != 0)
    fail("bad magic (not a keyfleet ORB vocabulary file)");
  if (in.size() < kHeaderBytes) fail("truncated header (" + std::to_string(in.size()) + " bytes)");
  const std::uint8_t* p = in.data() + sizeof(kMagic);
  const std::uint32_t version = get32(p);
  if (version != kVersion)
    fail("unsupported version " + std::to_string(version) + " (this build reads " +
         std::to_string(kVersion) + ")");
  OrbVocabulary v;
  v.params_.branching = int(get32(p + 4));
  v.params_.depth = int(get32(p + 8));
  v.params_.kmeans_iterations = int(get32(p + 12));
  v.params_.seed = get32(p + 16);
  if (get32(p + 20) != kDescriptorBytes) fail("descriptor size is not 32 bytes");
  v.training_images_ = get64(p + 24);
  const std::uint64_t count = get32(p + 32);
  const std::uint64_t expected = kHeaderBytes + count * kNodeBytes + kChecksumBytes;
  if (in.size() < expected)
    fail("truncated (" + std::to_string(in.size()) + " bytes, " + std::to_string(count) +
         " nodes need " + std::to_string(expected) + ")");
  if (in.size() > expected)
    fail(std::to_string(in.size() - expected) + " unexpected bytes after the nodes");
  if (get64(in.data() + expected - kChecksumBytes) !=
      fnv1a64(in.data(), std::size_t(expected - kChecksumBytes)))
    fail("checksum mismatch (corrupt file)");
  try {
    detail::check_vocabulary_params(v.params_, "header");
  } catch (const StartupError& e) {
    fail(e.what());
  }
  if (count == 0) fail("no nodes");

  // Breadth-first order is what makes the tree valid: parents come before their children,
  // siblings are contiguous, levels stay within the depth and fan-out within the branching.
  v.nodes_.resize(count);
  const std::uint8_t* node = in.data() + kHeaderBytes;
  for (std::size_t i = 0; i < count; ++i, node += kNodeBytes) {
    Node& n = v.nodes_[i];
    n.parent = get32(node);
    std::memcpy(n.centroid.data(), node + 4, kDescriptorBytes);
    const std::uint32_t bits = get32(node + 4 + kDescriptorBytes);
    std::memcpy(&n.idf, &bits, 4);
    if (i == 0) {
      if (n.parent != 0) fail("root node has a parent");
      continue;
    }
    if (n.parent >= i || n.parent < v.nodes_[i - 1].parent)
      fail("node " + std::to_string(i) + " breaks the breadth-first order");
    Node& parent = v.nodes_[n.parent];
    if (parent.child_count == 0) parent.first_child = NodeId(i);
    ++parent.child_count;
    n.level = parent.level + 1;
    if (int(n.level) > v.params_.depth) fail("node " + std::to_string(i) + " deeper than depth");
    if (int(parent.child_count) > v.params_.branching)
      fail("node " + std::to_string(n.parent) + " has more children than the branching");
    if (!std::isfinite(n.idf) || n.idf < 0) fail("node " + std::to_string(i) + " bad weight");
  }
  v.index_words();
  return v;
}

}  // namespace keyfleet::station
