#pragma once
// `handson bench sim`'s force-against-motion chart (bench_force.cpp).
#include <filesystem>

namespace handson::cli {

/// Writes sim_force.csv (and sim_force.png with gnuplot) into `out`.
void benchForceCurve(const std::filesystem::path& out);

}  // namespace handson::cli
