// Ctrl-C handling (libhaha/core/interrupt.h): SIGINT and SIGTERM, once the handler is
// installed, only set the flag (the process lives on); check_interrupted() throws the
// one-line "interrupted" error until the flag is cleared.
#include <gtest/gtest.h>

#include <signal.h>

#include <string>

#include "core/error.h"
#include "core/interrupt.h"

namespace haha {
namespace {

TEST(Interrupt, RequestThrowsUntilCleared) {
  clear_interrupt();
  EXPECT_FALSE(interrupted());
  EXPECT_NO_THROW(check_interrupted());
  request_interrupt();
  EXPECT_TRUE(interrupted());
  for (int i = 0; i < 2; ++i) {  // stays set: every loop that checks stops
    try {
      check_interrupted();
      ADD_FAILURE() << "no error";
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()), "interrupted");
    }
  }
  clear_interrupt();
  EXPECT_NO_THROW(check_interrupted());
}

TEST(Interrupt, SignalsSetTheFlagInsteadOfEndingTheProcess) {
  install_interrupt_handler();
  install_interrupt_handler();  // idempotent
  for (int sig : {SIGINT, SIGTERM}) {
    clear_interrupt();
    ASSERT_EQ(::raise(sig), 0);
    EXPECT_TRUE(interrupted()) << "signal " << sig;
    EXPECT_THROW(check_interrupted(), Error);
  }
  clear_interrupt();
  signal(SIGINT, SIG_DFL);
  signal(SIGTERM, SIG_DFL);
}

}  // namespace
}  // namespace haha
