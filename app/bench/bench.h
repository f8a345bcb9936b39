#pragma once
// `handson bench`: the raymarch benchmark (bench.cpp), which dispatches its subcommands, each in its
// own file. Exit status and errors as for every command (app/cli/commands.h).
#include "app/cli/args.h"

#include <vector>

namespace handson::cli {

/// The median of the samples (the mean of the middle two for an even count); 0 for none.
double median(std::vector<double> v);

int cmdBench(const Words& args);
int cmdBenchSelection(const Words& args);
int cmdBenchGesture(const Words& args);
int cmdBenchSim(const Words& args);
int cmdBenchDeform(const Words& args);
int cmdBenchMesh(const Words& args);
int cmdBenchStability(const Words& args);
int cmdBenchTissue(const Words& args);
int cmdBenchCut(const Words& args);
int cmdBenchHyperelastic(const Words& args);
int cmdBenchVisibility(const Words& args);
int cmdBenchSuite(const Words& args);

}  // namespace handson::cli
