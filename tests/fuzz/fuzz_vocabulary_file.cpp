// The place-recognition vocabulary loader on hostile files. The input is a vocabulary file
// without its last 8 bytes: the checksum over it is appended here, so that the fuzzer reaches
// the header and node checks behind it. Loading returns a vocabulary or throws StartupError;
// a loaded one maps a descriptor to a word it has.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "fuzz_file.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/common/fnv1a.hpp"
#include "keyfleet/station/places/orb_vocabulary.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const keyfleet::fuzz::FuzzFolder folder;
  std::vector<std::uint8_t> file(data, data + size);
  const std::uint64_t checksum = keyfleet::fnv1a64(file);
  for (int i = 0; i < 8; ++i) file.push_back(std::uint8_t(checksum >> (8 * i)));
  const std::string path =
      folder.write("vocabulary.bin", file.data(), file.size()) + "/vocabulary.bin";
  try {
    const auto vocabulary = keyfleet::station::OrbVocabulary::load(path);
    keyfleet::station::OrbVocabulary::Descriptor descriptor{};
    if (size >= descriptor.size()) std::memcpy(descriptor.data(), data, descriptor.size());
    if (vocabulary.word_of(descriptor.data()) >= vocabulary.word_count()) std::abort();
  } catch (const keyfleet::StartupError&) {
  }
  return 0;
}
