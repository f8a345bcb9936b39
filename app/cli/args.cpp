#include "args.h"

#include <algorithm>
#include <cmath>
#include <iostream>
#include <sstream>

#include "sim/coarsening.h"
#include "sim/sim_scene.h"

namespace handson::cli {

Args::Args(std::vector<std::string> args, std::vector<std::string> valueOptions, std::vector<std::string> flagOptions) {
  auto has = [](const std::vector<std::string>& v, const std::string& s) { return std::find(v.begin(), v.end(), s) != v.end(); };
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--help" || a == "-h") {
      help_ = true;
      continue;
    }
    if (a.size() > 1 && a[0] == '-' && !(a.size() > 1 && (std::isdigit(static_cast<unsigned char>(a[1])) || a[1] == '.'))) {
      std::string name = a, val;
      bool inlineValue = false;
      if (auto eq = a.find('='); eq != std::string::npos) {
        name = a.substr(0, eq);
        val = a.substr(eq + 1);
        inlineValue = true;
      }
      if (has(valueOptions, name)) {
        if (!inlineValue) {
          if (i + 1 >= args.size()) throw UsageError("option " + name + " needs a value");
          val = args[++i];
        }
        values_.emplace_back(name, val);
      } else if (has(flagOptions, name) && !inlineValue) {
        flags_.push_back(name);
      } else {
        throw UsageError("unknown option " + name);
      }
      continue;
    }
    positional_.push_back(a);
  }
}

bool Args::flag(const std::string& name) const { return std::find(flags_.begin(), flags_.end(), name) != flags_.end(); }

std::vector<std::string> Args::values(const std::string& name) const {
  std::vector<std::string> out;
  for (const auto& [k, v] : values_)
    if (k == name) out.push_back(v);
  return out;
}

std::optional<std::string> Args::value(const std::string& name) const {
  std::optional<std::string> out;
  for (const auto& [k, v] : values_)
    if (k == name) out = v;  // the last one wins
  return out;
}

std::string Args::valueOr(const std::string& name, const std::string& fallback) const {
  auto v = value(name);
  return v ? *v : fallback;
}

double Args::number(const std::string& name, double fallback, double lo, double hi) const {
  auto v = value(name);
  if (!v) return fallback;
  std::size_t used = 0;
  double x = 0;
  try {
    x = std::stod(*v, &used);
  } catch (...) {
    used = 0;
  }
  if (used != v->size() || !std::isfinite(x)) throw UsageError(name + ": '" + *v + "' is not a number");
  if (x < lo || x > hi) {
    std::ostringstream msg;
    msg << name << ": " << x << " is outside [" << lo << ", " << hi << "]";
    throw UsageError(msg.str());
  }
  return x;
}

long Args::integer(const std::string& name, long fallback, long lo, long hi) const {
  auto v = value(name);
  if (!v) return fallback;
  std::size_t used = 0;
  long x = 0;
  try {
    x = std::stol(*v, &used);
  } catch (...) {
    used = 0;
  }
  if (used != v->size()) throw UsageError(name + ": '" + *v + "' is not an integer");
  if (x < lo || x > hi) throw UsageError(name + ": " + std::to_string(x) + " is outside [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return x;
}

std::ostream& usageStream(const Args& args) {
  if (args.help()) return std::cout;
  std::cerr << "error: missing or unexpected arguments\n";
  return std::cerr;
}

std::vector<double> parseNumberList(const std::string& text, const std::string& what) {
  std::vector<double> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    std::size_t used = 0;
    double x = 0;
    try {
      x = std::stod(item, &used);
    } catch (...) {
      used = 0;
    }
    if (used == 0 || used != item.size() || !std::isfinite(x)) throw UsageError(what + ": '" + text + "' is not a list of numbers");
    out.push_back(x);
  }
  if (out.empty()) throw UsageError(what + ": empty list");
  return out;
}

void parseSize(const std::string& text, int& width, int& height) {
  const auto x = text.find('x');
  auto bad = [&] { return UsageError("--size: '" + text + "' is not WxH with 1..16384 each"); };
  if (x == std::string::npos) throw bad();
  try {
    std::size_t u1 = 0, u2 = 0;
    const std::string a = text.substr(0, x), b = text.substr(x + 1);
    width = std::stoi(a, &u1);
    height = std::stoi(b, &u2);
    if (u1 != a.size() || u2 != b.size()) throw bad();
  } catch (const UsageError&) {
    throw;
  } catch (...) {
    throw bad();
  }
  if (width < 1 || height < 1 || width > 16384 || height > 16384) throw bad();
}

CoarseElement coarseElementOption(const Args& args, const char* name) {
  const std::string v = args.valueOr(name, "cell");
  if (v == "cell") return CoarseElement::Cell;
  if (v == "tet") return CoarseElement::Tet;
  throw UsageError(std::string(name) + " must be cell or tet");
}

void coarseModelOptions(const Args& args, const std::string& prefix, SimSettings& settings) {
  settings.element = coarseElementOption(args, (prefix + "coarse-element").c_str());
  settings.coarseSolver = coarseSolverOption(args, (prefix + "coarse-solver").c_str());
  settings.grading.splitWithinCells = args.number(prefix + "graded-split", settings.grading.splitWithinCells, -1.0, 10.0);
  if (settings.grading.graded() && settings.element != CoarseElement::Cell)
    throw UsageError(prefix + "graded-split needs cell elements (" + prefix + "coarse-element cell)");
  if (settings.grading.graded() && settings.coarseSolver != CoarseSolver::Pcg)
    throw UsageError(prefix + "graded-split needs the pcg coarse solver");
  tissueRuleOptions(args, prefix, settings);
  interfaceOption(args, prefix, settings);
}

void tissueRuleOptions(const Args& args, const std::string& prefix, SimSettings& settings) {
  if (const auto v = args.value(prefix + "handle-nodes")) {
    if (*v == "inside") settings.handleNodes = SimSettings::HandleNodes::Inside;
    else if (*v == "tets") settings.handleNodes = SimSettings::HandleNodes::Tets;
    else throw UsageError(prefix + "handle-nodes must be inside or tets");
  }
  if (const auto v = args.value(prefix + "outer-boundary")) {
    if (*v == "exterior") settings.outer = SimSettings::Outer::Exterior;
    else if (*v == "wall") settings.outer = SimSettings::Outer::Wall;
    else throw UsageError(prefix + "outer-boundary must be exterior or wall");
  }
  if (const auto v = args.value(prefix + "bone")) {
    if (*v == "anchored") settings.bone = SimSettings::Bone::Anchored;
    else if (*v == "by-value") settings.bone = SimSettings::Bone::ByValue;
    else throw UsageError(prefix + "bone must be anchored or by-value");
  }
}

FineMaterial fineMaterialOption(const Args& args, bool fineModel) {
  const auto v = args.value("--fine-material");
  if (!v) return FineMaterial::Corotational;
  if (!fineModel) throw UsageError("--fine-material needs the fine model (--model fine)");
  if (*v == "corotational") return FineMaterial::Corotational;
  if (*v == "neo-hookean") return FineMaterial::NeoHookean;
  throw UsageError("--fine-material must be corotational or neo-hookean");
}

void interfaceOption(const Args& args, const std::string& prefix, SimSettings& settings) {
  if (const auto v = args.value(prefix + "interface")) {
    const auto i = parseInterface(*v);
    if (!i) throw UsageError(prefix + "interface must be sliding or glued");
    settings.interface = *i;
  }
}

void regionOption(const Args& args, const char* name, SimSettings& settings) {
  const auto v = args.value(name);
  if (!v) return;
  if (*v == "box") settings.region = SimSettings::Region::Box;
  else if (*v == "handles") settings.region = SimSettings::Region::Handles;
  else throw UsageError(std::string(name) + " must be box or handles");
}

CoarseSolver coarseSolverOption(const Args& args, const char* name) {
  const std::string v = args.valueOr(name, "pcg");
  if (v == "pcg") return CoarseSolver::Pcg;
  if (v == "assembled") return CoarseSolver::Assembled;
  throw UsageError(std::string(name) + " must be pcg or assembled");
}

void fineMeshOptions(const Args& args, const char* name, const char* contrastName, SimSettings& s) {
  const std::string v = args.valueOr(name, "regular");
  if (v == "regular") s.fineMesh = SimSettings::FineMesh::Regular;
  else if (v == "adapted") s.fineMesh = SimSettings::FineMesh::ImageAdapted;
  else throw UsageError(std::string(name) + " must be regular or adapted");
  s.adaptContrast = args.number(contrastName, s.adaptContrast, 1.01, 1e12);
  if (s.fineMesh == SimSettings::FineMesh::ImageAdapted && s.element != CoarseElement::Cell)
    throw UsageError(std::string(name) + " adapted needs cell coarse elements");
}

std::vector<int> integerListOption(const Args& args, const char* name, const char* fallback, int lo, int hi) {
  std::vector<int> out;
  for (double v : parseNumberList(args.valueOr(name, fallback), name)) {
    if (!(v >= lo && v <= hi) || v != std::floor(v)) throw UsageError(std::string(name) + " takes integers " + std::to_string(lo) + ".." + std::to_string(hi));
    out.push_back(int(v));
  }
  return out;
}

bool onOffOption(const Args& args, const std::string& name, bool fallback) {
  const std::string v = args.valueOr(name, fallback ? "on" : "off");
  if (v != "on" && v != "off") throw UsageError(name + " must be on or off");
  return v == "on";
}

std::string exportVolumeExtension(const Args& args) {
  const std::string f = args.valueOr("--export-format", "nifti");
  if (f == "nifti") return ".nii.gz";
  if (f == "nrrd") return ".nrrd";
  if (f == "mha") return ".mha";
  throw UsageError("--export-format must be nifti, nrrd or mha");
}

LoadOptions loadOptions(const Args& args) {
  LoadOptions o;
  o.frame = args.integer("--frame", 0, 0, 1000000000L);
  return o;
}

HandleScene handleSceneOptions(const Args& args, double defaultSpacingMm, const ProgressFn& progress) {
  const std::optional<long> label = args.value("--handle-label") ? std::optional<long>(args.integer("--handle-label", 0, 1, 65535)) : std::nullopt;
  return loadHandleScene(args.positional().empty() ? "" : args.positional()[0], args.valueOr("--handle", ""), label,
                         args.number("--spacing", defaultSpacingMm, 0.5, 20.0), progress);
}

}  // namespace handson::cli
