#pragma once
// The `handson` command line: subcommands, each in its own file.
#include <string>
#include <vector>

namespace handson::cli {

using Words = std::vector<std::string>;

/// Runs the command line; returns the process exit status (0 ok, 1 failure, 2 usage error).
int run(int argc, char** argv);

int cmdInfo(const Words& args);
int cmdPhantom(const Words& args);
int cmdResample(const Words& args);
int cmdDevices(const Words& args);
int cmdRender(const Words& args);
int cmdPick(const Words& args);
int cmdBench(const Words& args);
int cmdSelect(const Words& args);
int cmdGestureSolve(const Words& args);
int cmdBenchSelection(const Words& args);
int cmdBenchGesture(const Words& args);
int cmdBenchSim(const Words& args);
int cmdBenchDeform(const Words& args);
int cmdBenchMesh(const Words& args);
int cmdBenchStability(const Words& args);
int cmdBenchSuite(const Words& args);
int cmdView(const Words& args);
int cmdReplay(const Words& args);
int cmdRetarget(const Words& args);
int cmdCompose(const Words& args);
int cmdStressGestures(const Words& args);
int cmdSoak(const Words& args);
int cmdDeform(const Words& args);
/// No subcommand: the app on the default phantom, or the headless demo when there is no display.
int cmdDefault(const Words& args);

}  // namespace handson::cli
