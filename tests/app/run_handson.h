#pragma once
// Runs the handson executable (HANDSON_EXE, defined by tests/CMakeLists.txt) as a user would: the one
// helper every app test that starts the binary uses.
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace handson::test {

struct HandsonRun {
  int status = -1;     ///< exit status; -1 when it did not start or a signal ended it (a crash)
  int signal = 0;      ///< the signal that ended it, if one did
  std::string output;  ///< stdout and stderr, merged
  bool has(const std::string& s) const { return output.find(s) != std::string::npos; }
};

/// `args` after the executable (a shell command line), `env` ("NAME=value ...") before it; stopped
/// after `timeoutSeconds` (timeout(1): status 124).
inline HandsonRun runHandson(const std::string& args, int timeoutSeconds = 120, const std::string& env = "") {
  HandsonRun r;
  const std::string cmd = (env.empty() ? std::string() : "env " + env + " ") + "timeout " + std::to_string(timeoutSeconds) + " " + HANDSON_EXE + " " +
                          args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf;
  while (fgets(buf.data(), int(buf.size()), p)) r.output += buf.data();
  const int st = pclose(p);
  if (WIFEXITED(st)) r.status = WEXITSTATUS(st);
  else if (WIFSIGNALED(st)) r.signal = WTERMSIG(st);
  return r;
}

}  // namespace handson::test
