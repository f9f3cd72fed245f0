// The YAML description of the text segmenter's settings (semantic_config.hpp), instantiated for
// the three visitors.
#include "keyfleet/vision/semantic_config_yaml.hpp"

namespace keyfleet {

template <class V>
void visit(V& v, SemanticConfig& c) {
  v.field("model", c.model);
  v.field("border", c.border, between(0.0, 0.45));
  v.field("threads", c.threads, between(0, 64));
  v.field("bfloat16", c.bfloat16);
  v.field("int8", c.int8);
}

template void visit(ConfigReader&, SemanticConfig&);
template void visit(ConfigWriter&, SemanticConfig&);
template void visit(ConfigReference&, SemanticConfig&);

}  // namespace keyfleet
