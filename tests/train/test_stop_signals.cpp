// The CLI's stop handler (examples/maskadapt/stop_signals.hpp): SIGTERM twice at once is one stop
// request (`timeout` signals the command and then its process group; a busy machine runs the
// handler between the two), and a second request a second or more after the first ends the
// process at once. Each case runs in a forked child (death tests), so the flag starts clear.
#include "../../examples/maskadapt/stop_signals.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <thread>

using maskadapt::cli::request_training_stop;

TEST(StopSignals, TwoSignalsAtOnceAreOneRequestToStop) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        request_training_stop(SIGTERM);
        request_training_stop(SIGTERM);
        std::exit(maskadapt::train::stop_requested() ? 3 : 4);
      },
      ::testing::ExitedWithCode(3), "");
}

TEST(StopSignals, ASecondRequestASecondLaterEndsTheProcess) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        request_training_stop(SIGTERM);
        std::this_thread::sleep_for(std::chrono::milliseconds(1100));
        request_training_stop(SIGTERM);
        std::exit(0);
      },
      ::testing::KilledBySignal(SIGTERM), "");
}
