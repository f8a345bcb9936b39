#pragma once
// Progress reporting for long work (loading, meshing, coarsening). Library code calls the callback
// with a fraction in [0, 1] and a short stage name; the command line draws it on stderr.
#include <functional>
#include <string>

namespace handson {

using ProgressFn = std::function<void(double fraction, const std::string& stage)>;

inline void reportProgress(const ProgressFn& fn, double fraction, const std::string& stage) {
  if (fn) fn(fraction, stage);
}

}  // namespace handson
