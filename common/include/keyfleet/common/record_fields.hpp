#pragma once
// The two samples' field lists (types.hpp) as visits: visit_fields(v, record) calls
// v.field(name, member, since) for every field in order, on a const or a mutable record, the
// way the configs are visited (config_yaml.hpp). The stores, the mission log and the exports are
// visitors; the DDS wire conversion expands the lists directly, the wire types' accessors having
// the fields' names.
#include <type_traits>

#include "keyfleet/common/types.hpp"

namespace keyfleet {

// The schema versions of the agent's outbox and of the station's database whose migration added
// a field's column: 1 for the first layout, 0 where that file does not keep the field.
struct Since {
  int outbox = 0;
  int station = 0;
};

template <class V, class K,
          std::enable_if_t<std::is_same_v<std::remove_const_t<K>, Keyframe>, int> = 0>
void visit_fields(V& v, K& k) {
#define KEYFLEET_VISIT_FIELD(name, outbox, station) v.field(#name, k.name, Since{outbox, station});
  KEYFLEET_KEYFRAME_FIELDS(KEYFLEET_VISIT_FIELD)
#undef KEYFLEET_VISIT_FIELD
}

template <class V, class S,
          std::enable_if_t<std::is_same_v<std::remove_const_t<S>, AgentStats>, int> = 0>
void visit_fields(V& v, S& s) {
#define KEYFLEET_VISIT_FIELD(name, station) v.field(#name, s.name, Since{0, station});
  KEYFLEET_AGENT_STATS_FIELDS(KEYFLEET_VISIT_FIELD)
#undef KEYFLEET_VISIT_FIELD
}

}  // namespace keyfleet
