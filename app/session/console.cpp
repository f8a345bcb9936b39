#include "console.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <mutex>
#include <string>

namespace handson {

ProgressFn consoleProgress() {
  struct State {
    std::mutex m;
    std::string stage;
    int lastStep = -1;
    bool tty = isatty(STDERR_FILENO) != 0;
  };
  auto st = std::make_shared<State>();
  return [st](double f, const std::string& stage) {
    std::lock_guard<std::mutex> lock(st->m);
    if (!std::isfinite(f)) return;
    const int pct = int(std::lround(std::clamp(f, 0.0, 1.0) * 100.0));
    if (stage != st->stage) {
      if (st->tty && !st->stage.empty()) std::fputc('\n', stderr);
      st->stage = stage;
      st->lastStep = -1;
    }
    if (st->tty) {
      std::fprintf(stderr, "\r%s: %3d%%", stage.c_str(), pct);
      if (pct >= 100) {
        std::fputc('\n', stderr);
        st->stage.clear();
      }
    } else {
      const int step = pct / 25;
      if (step != st->lastStep) {
        std::fprintf(stderr, "%s: %d%%\n", stage.c_str(), pct);
        st->lastStep = step;
      }
    }
    std::fflush(stderr);
  };
}

}  // namespace handson
