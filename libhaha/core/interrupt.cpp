#include "core/interrupt.h"

#include <signal.h>

#include <atomic>

#include "core/error.h"

namespace haha {

namespace {

std::atomic<bool> g_interrupted{false};
static_assert(std::atomic<bool>::is_always_lock_free, "the signal handler needs a lock-free flag");

extern "C" void on_interrupt_signal(int) { g_interrupted.store(true, std::memory_order_relaxed); }

}  // namespace

void install_interrupt_handler() {
  struct sigaction sa {};
  sa.sa_handler = on_interrupt_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;  // reads and waits resume; the loops look at the flag
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

void request_interrupt() { g_interrupted.store(true); }
void clear_interrupt() { g_interrupted.store(false); }
bool interrupted() { return g_interrupted.load(); }

void check_interrupted() {
  if (interrupted()) throw Error("interrupted");
}

}  // namespace haha
