// Tests for app/io/isolated_call: a child's result, its handson::Error and other exceptions, and the
// failures that must not reach the caller's process - an abort, a crash, a hang past the time-out.
#include "app/io/isolated_call.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <csignal>
#include <cstdlib>
#include <stdexcept>
#include <string>

namespace handson {
namespace {

std::string messageOf(const std::function<std::string()>& work, double timeoutS = 10.0) {
  try {
    (void)runIsolated(work, timeoutS, "the test call");
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "no error";
  return {};
}

TEST(IsolatedCall, ReturnsTheChildsBytes) {
  const std::string big(3'000'000, 'x');  // more than a pipe holds at once
  EXPECT_EQ(runIsolated([] { return std::string("a\0b", 3); }, 10.0, "t"), std::string("a\0b", 3));
  EXPECT_EQ(runIsolated([&] { return big; }, 10.0, "t"), big);
  EXPECT_EQ(runIsolated([] { return std::string(); }, 10.0, "t"), "");
}

TEST(IsolatedCall, ErrorsComeBackWithTheirMessage) {
  EXPECT_EQ(messageOf([]() -> std::string { throw Error("bad header: NDims"); }), "bad header: NDims");
  EXPECT_EQ(messageOf([]() -> std::string { throw std::runtime_error("boom"); }), "the test call failed: boom");
}

TEST(IsolatedCall, AbortsCrashesAndHangsStayInTheChild) {
  const std::string aborted = messageOf([]() -> std::string { std::abort(); });
  EXPECT_NE(aborted.find("SIGABRT"), std::string::npos) << aborted;
  EXPECT_EQ(aborted.rfind("the test call", 0), 0u) << aborted;
  const std::string killed = messageOf([]() -> std::string {
    ::raise(SIGKILL);
    return {};
  });
  EXPECT_NE(killed.find("SIGKILL"), std::string::npos) << killed;
  const std::string exited = messageOf([]() -> std::string { std::_Exit(0); });
  EXPECT_NE(exited.find("without a result"), std::string::npos) << exited;
  const std::string hung = messageOf([]() -> std::string {
    for (;;) ::pause();
  }, 0.5);
  EXPECT_NE(hung.find("did not finish"), std::string::npos) << hung;
  // The caller goes on.
  EXPECT_EQ(runIsolated([] { return std::string("after"); }, 10.0, "t"), "after");
}

}  // namespace
}  // namespace handson
