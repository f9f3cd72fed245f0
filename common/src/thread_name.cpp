#include "keyfleet/common/thread_name.hpp"

#include <pthread.h>

namespace keyfleet {

void name_this_thread(const std::string& role) {
  constexpr std::size_t kLongest = 15;  // the kernel's 16 bytes, the terminating zero included
  const std::string name = ("kf-" + role).substr(0, kLongest);
  pthread_setname_np(pthread_self(), name.c_str());
}

std::string this_thread_name() {
  char name[16] = {};
  if (pthread_getname_np(pthread_self(), name, sizeof name) != 0) return {};
  return name;
}

}  // namespace keyfleet
