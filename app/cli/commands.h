#pragma once
// The `handson` commands outside the benchmarks (app/bench/bench.h), one file per family; app/main.cpp
// dispatches to them. Each returns the process exit status (0 ok, 1 failure, 2 usage error) and
// throws UsageError for a bad command line, handson::Error for bad input.
#include "app/cli/args.h"

namespace handson::cli {

// volume_commands.cpp
int cmdInfo(const Words& args);
int cmdPhantom(const Words& args);
int cmdResample(const Words& args);
int cmdDevices(const Words& args);
// render_commands.cpp
int cmdRender(const Words& args);
int cmdPick(const Words& args);
// select_command.cpp, gesture_command.cpp, deform_command.cpp
int cmdSelect(const Words& args);
int cmdGestureSolve(const Words& args);
int cmdDeform(const Words& args);
// session_commands.cpp
int cmdView(const Words& args);
int cmdReplay(const Words& args);
int cmdRetarget(const Words& args);
int cmdCompose(const Words& args);
int cmdStressGestures(const Words& args);
int cmdSoak(const Words& args);
/// No subcommand: the app on the default phantom, or the headless demo when there is no display.
int cmdDefault(const Words& args);

}  // namespace handson::cli
