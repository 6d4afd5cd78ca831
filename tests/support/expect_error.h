// The one error-checking helper of the tests: runs f and expects a haha::Error whose
// message is one line containing every needle (files, keys, the problem).
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "core/error.h"

namespace haha::test {

template <class F>
void expect_error(F&& f, const std::vector<std::string>& needles) {
  try {
    std::forward<F>(f)();
    ADD_FAILURE() << "no error thrown (expected one mentioning " << (needles.empty() ? "" : needles[0]) << ")";
  } catch (const Error& e) {
    const std::string msg = e.what();
    for (const auto& n : needles) EXPECT_NE(msg.find(n), std::string::npos) << "message: " << msg << "\nmissing: " << n;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << "error must be one line: " << msg;
  }
}

// As above, and the message starts with "<where>: " (the file or option it is about).
template <class F>
void expect_error_at(const std::string& where, F&& f, const std::vector<std::string>& needles) {
  std::string msg;
  expect_error(
      [&] {
        try {
          std::forward<F>(f)();
        } catch (const Error& e) {
          msg = e.what();
          throw;
        }
      },
      needles);
  if (!msg.empty()) {
    EXPECT_EQ(msg.rfind(where + ": ", 0), 0u) << "message should start with '" << where << ": ': " << msg;
  }
}

// The needles as separate arguments (strings; empty ones are not checked).
template <class F, class... S>
void expect_error(F&& f, const S&... needles) {
  std::vector<std::string> list;
  for (const std::string& n : {std::string(needles)...})
    if (!n.empty()) list.push_back(n);
  expect_error(std::forward<F>(f), list);
}

}  // namespace haha::test
