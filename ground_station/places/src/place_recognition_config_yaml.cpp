// The YAML description of place recognition's settings (place_recognition_config.hpp),
// instantiated for the three visitors, and the retrieval modes' names.
#include "keyfleet/station/places/place_recognition_config_yaml.hpp"

#include "keyfleet/station/geometry/verifier_kind_yaml.hpp"

namespace keyfleet {

template <>
struct EnumNames<PlaceRetrieval> {
  static constexpr std::pair<PlaceRetrieval, const char*> kAll[] = {
      {PlaceRetrieval::kBow, "bow"},
      {PlaceRetrieval::kCnn, "cnn"},
      {PlaceRetrieval::kFusion, "fusion"}};
};

std::optional<PlaceRetrieval> place_retrieval(const std::string& name) {
  return enum_from_name<PlaceRetrieval>(name);
}
std::string place_retrieval_choices() { return enum_choices<PlaceRetrieval>(); }
std::string to_string(PlaceRetrieval retrieval) { return enum_name(retrieval); }

template <class V>
void visit(V& v, PlaceRecognitionConfig& c) {
  v.field("enabled", c.enabled);
  v.field("vocabulary", c.vocabulary);
  v.field("retrieval", c.retrieval);
  v.field("descriptor", c.descriptor);
  v.field("fusion_depth", c.fusion_depth, between(1, 1000));
  v.field("orb_features", c.orb_features, between(100, 20000));
  v.field("candidates", c.candidates, between(1, 100));
  v.field("min_inliers", c.min_inliers, between(4, 100000));
  v.field("min_inlier_ratio", c.min_inlier_ratio, between(0.0, 1.0));
  v.field("verifier", c.verifier);
  v.field("same_robot_exclusion_s", c.same_robot_exclusion_s, between(0.0, 1e6));
}

template void visit(ConfigReader&, PlaceRecognitionConfig&);
template void visit(ConfigWriter&, PlaceRecognitionConfig&);
template void visit(ConfigReference&, PlaceRecognitionConfig&);

}  // namespace keyfleet
