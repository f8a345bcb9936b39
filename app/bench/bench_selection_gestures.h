#pragma once
// `handson bench selection --protocol gestures` (bench_selection_gestures.cpp).
#include <filesystem>
#include <string>

#include "app/tools/selection_gestures.h"

namespace handson::cli {

/// Runs the simulated user's gestures on the labelled organs of the CTs under `dataDir`
/// (ircadb1.1, totalseg-small; a missing one is skipped) and writes selection_gestures.csv, .md and
/// .png to `out`. `gestures`: the first pinch and up to gestures - 1 corrections.
/// `protocol` holds the app's rules to measure.
int benchSelectionGestures(const std::string& dataDir, const std::filesystem::path& out, const GestureProtocol& protocol);

}  // namespace handson::cli
