#pragma once
// A small, strict command-line parser: options are --name VALUE or --name=VALUE, flags are --name,
// everything else is positional. Unknown options and malformed values are usage errors.
#include <cstdint>
#include <optional>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

#include "app/io/volume_io.h"

namespace handson {
enum class CoarseElement;
enum class CoarseSolver;
struct SimSettings;
enum class FineMaterial : std::uint8_t;
}

namespace handson::cli {

/// A command's words after its name.
using Words = std::vector<std::string>;

/// Thrown for bad command lines (exit status 2, with the command's usage hint).
class UsageError : public std::runtime_error {
 public:
  explicit UsageError(const std::string& what) : std::runtime_error(what) {}
};

class Args {
 public:
  /// args: the words after the subcommand. valueOptions: options that take a value; flagOptions: those that do not.
  Args(std::vector<std::string> args, std::vector<std::string> valueOptions, std::vector<std::string> flagOptions);

  bool flag(const std::string& name) const;
  std::optional<std::string> value(const std::string& name) const;
  std::string valueOr(const std::string& name, const std::string& fallback) const;
  /// Every value given to a repeatable option, in order.
  std::vector<std::string> values(const std::string& name) const;
  const std::vector<std::string>& positional() const { return positional_; }
  bool help() const { return help_; }

  double number(const std::string& name, double fallback, double lo, double hi) const;
  long integer(const std::string& name, long fallback, long lo, long hi) const;

 private:
  std::vector<std::pair<std::string, std::string>> values_;
  std::vector<std::string> flags_;
  std::vector<std::string> positional_;
  bool help_ = false;
};

/// Where a command's usage text goes: stdout for --help, else stderr after "error: wrong arguments".
std::ostream& usageStream(const Args& args);

/// Parses "a,b,c" into numbers (each finite); throws UsageError naming `what`.
std::vector<double> parseNumberList(const std::string& text, const std::string& what);
/// Parses "WxH" (1..16384 each).
void parseSize(const std::string& text, int& width, int& height);
/// The coarse model's element kind from option `name` ("cell" or "tet"; absent: cell).
CoarseElement coarseElementOption(const Args& args, const char* name);
/// The simulation's options `prefix` + "coarse-element", "coarse-solver", "graded-split" and the
/// tissue rules' (tissueRuleOptions, interfaceOption) (prefix "--" or "--sim-") into `settings`.
void coarseModelOptions(const Args& args, const std::string& prefix, SimSettings& settings);
/// The tissue rules (docs/tissue-physics.md): `prefix` + "handle-nodes" (inside|tets), "bone"
/// (anchored|by-value) and "outer-boundary" (exterior|wall) into `settings` (absent: kept).
void tissueRuleOptions(const Args& args, const std::string& prefix, SimSettings& settings);
/// "--fine-material" (corotational|neo-hookean; absent: corotational); only with `fineModel`.
FineMaterial fineMaterialOption(const Args& args, bool fineModel);
/// `prefix` + "interface" (sliding|glued) into `settings` (absent: kept).
void interfaceOption(const Args& args, const std::string& prefix, SimSettings& settings);
/// The simulated region's shape from option `name` ("box" or "handles") into `settings` (absent: kept).
void regionOption(const Args& args, const char* name, SimSettings& settings);
/// pcg (default) or assembled (the baseline coarse solve; sim/coarsening.h).
CoarseSolver coarseSolverOption(const Args& args, const char* name);
/// The fine mesh kind from option `name` ("regular" or "adapted"; absent: regular) into `settings`,
/// with `contrastName` the stiffness jump that adds points to an adapted mesh.
void fineMeshOptions(const Args& args, const char* name, const char* contrastName, SimSettings& settings);
/// Option `name` as a comma list of integers in [lo, hi] (`fallback` when absent).
std::vector<int> integerListOption(const Args& args, const char* name, const char* fallback, int lo, int hi);
/// The simulation benchmarks' scene: PATH --handle MASK [--handle-label N], or without PATH the
/// built-in phantom at --spacing (default `defaultSpacingMm`) with its right kidney as the handle.
HandleScene handleSceneOptions(const Args& args, double defaultSpacingMm, const ProgressFn& progress);
/// `--export-format nifti|nrrd|mha` (default nifti): the exported volumes' extension (".nii.gz",
/// ".nrrd", ".mha"). Throws UsageError otherwise.
std::string exportVolumeExtension(const Args& args);
/// An `on|off` option (`name` absent: `fallback`). Throws UsageError for any other value.
bool onOffOption(const Args& args, const std::string& name, bool fallback);
/// `--frame N`: which volume of a 4D NIfTI image to load (default 0).
LoadOptions loadOptions(const Args& args);
/// The help line for it.
inline constexpr const char* kFrameHelp = "  --frame N                the volume of a 4D NIfTI image to load (default 0)\n";

}  // namespace handson::cli
