#pragma once
// Console helpers of the command line: progress on stderr.
#include "sim/base/progress.h"

namespace handson {

/// Progress on stderr: a self-updating line on a terminal, otherwise one line per 25 % per stage.
ProgressFn consoleProgress();

}  // namespace handson
