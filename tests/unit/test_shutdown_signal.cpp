// SIGTERM turned into a stop request, also when it reaches a thread that a library started
// before main blocked the signals (OpenBLAS's pthread build starts its pool as it loads): such a
// thread must not end the process.
#include <gtest/gtest.h>
#include <pthread.h>

#include <atomic>
#include <csignal>
#include <thread>

#include "keyfleet/common/shutdown_signal.hpp"

namespace keyfleet {
namespace {

TEST(ShutdownSignal, ASignalToAThreadStartedBeforeTheBlockIsAStopNotAnEnd) {
  // Started before the signals are blocked: its mask leaves SIGTERM open, as a library's
  // thread started when the library loads.
  std::atomic<bool> leave{false};
  std::thread early([&] {
    while (!leave) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  });
  block_termination_signals();
  {
    ShutdownSignal shutdown;
    pthread_kill(early.native_handle(), SIGTERM);
    EXPECT_TRUE(shutdown.stop.wait_for(std::chrono::seconds(10))) << "no stop was requested";
    EXPECT_EQ(shutdown.received(), SIGTERM);
  }
  {
    // A signal to the process is a stop too, whichever thread takes it.
    ShutdownSignal shutdown;
    kill(getpid(), SIGINT);
    EXPECT_TRUE(shutdown.stop.wait_for(std::chrono::seconds(10)));
    EXPECT_EQ(shutdown.received(), SIGINT);
  }
  leave = true;
  early.join();
}

}  // namespace
}  // namespace keyfleet
