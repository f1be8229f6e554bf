// SIGINT / SIGTERM end a run cleanly (issue 24): the handler only records the signal; the
// run loop looks after each step, stops, and writes metrics.csv and summary.json with the
// status "interrupted by SIGINT|SIGTERM ..."; `iqmpm run` then exits 128 + the signal
// (130, 143). A second signal takes the default action (the handler is one-shot), so a
// run that does not stop can still be killed.
#pragma once

#include <csignal>

namespace iqmpm {

inline volatile std::sig_atomic_t& received_signal() {
  static volatile std::sig_atomic_t signal = 0;
  return signal;
}

inline void catch_interrupts() {
  struct sigaction action {};
  action.sa_handler = [](int signal) { received_signal() = signal; };
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESETHAND;
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

inline const char* signal_name(int signal) { return signal == SIGINT ? "SIGINT" : signal == SIGTERM ? "SIGTERM" : "a signal"; }

}  // namespace iqmpm
