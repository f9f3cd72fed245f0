#pragma once
// Place recognition's settings (analysis.places in the station's config, `keyfleet places`,
// `keyfleet eval`). Their YAML description: place_recognition_config_yaml.hpp.
#include <optional>
#include <string>

#include "keyfleet/station/geometry/verifier_kind.hpp"

namespace keyfleet {

// Where the candidates verified geometrically come from: the ORB bag of words, the holistic CNN
// descriptor (cosine similarity), or both ranked lists fused by reciprocal rank.
enum class PlaceRetrieval { kBow, kCnn, kFusion };

// Recognising places shared across keyframes and robots (retrieval + geometric verification).
struct PlaceRecognitionConfig {
  bool enabled = true;
  // Vocabulary file from `keyfleet vocabulary build`; a bare name is looked up in
  // <bin>/../share/keyfleet/models/ like the agent's model. Every mode needs it: the direct
  // index matches the candidates' ORB features for verification.
  std::string vocabulary = "orb_vocabulary.bin";
  // cnn by measurement (README "Place recognition: bag of words, CNN descriptor, fusion").
  PlaceRetrieval retrieval = PlaceRetrieval::kCnn;
  // The holistic descriptor's ONNX model (models/placenet), looked up like the vocabulary; used
  // by cnn and fusion.
  std::string descriptor = "placenet.onnx";
  int fusion_depth = 20;  // fusion: how far down each ranked list is read
  int orb_features = 1000;
  int candidates = 4;              // top-k retrieved candidates verified geometrically
  int min_inliers = 30;            // accepted with more inliers than this (Ma and Zhao 2017)
  double min_inlier_ratio = 0.25;  // and an inlier ratio above this
  VerifierKind verifier = VerifierKind::kVfc;
  // Keyframes of the same robot closer in time than this are neighbours, not revisits.
  double same_robot_exclusion_s = 10.0;
};

// The names the YAML files give the retrieval modes, for the tools that take them on a command
// line.
std::optional<PlaceRetrieval> place_retrieval(const std::string& name);
std::string place_retrieval_choices();
std::string to_string(PlaceRetrieval retrieval);

}  // namespace keyfleet
