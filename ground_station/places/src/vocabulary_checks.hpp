#pragma once
#include <string>

#include "keyfleet/station/places/orb_vocabulary.hpp"

namespace keyfleet::station::detail {

// Throws StartupError "<where>: <what is wrong>" for parameters no tree should have (the
// builder's input and a file's header are held to the same limits).
void check_vocabulary_params(const VocabularyParams& p, const std::string& where);

}  // namespace keyfleet::station::detail
