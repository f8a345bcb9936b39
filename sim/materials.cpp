#include "materials.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include "sim/base/error.h"

namespace handson {

namespace {

std::string trim(const std::string& s) {
  const auto a = s.find_first_not_of(" \t\r");
  if (a == std::string::npos) return {};
  const auto b = s.find_last_not_of(" \t\r");
  return s.substr(a, b - a + 1);
}

std::vector<std::string> splitCsv(const std::string& line) {
  std::vector<std::string> out;
  std::string cell;
  std::istringstream in(line);
  while (std::getline(in, cell, ',')) out.push_back(trim(cell));
  if (!line.empty() && line.back() == ',') out.emplace_back();
  return out;
}

bool parseNumber(const std::string& s, double& v) {
  if (s == "-inf") {
    v = -std::numeric_limits<double>::infinity();
    return true;
  }
  if (s == "inf" || s == "+inf") {
    v = std::numeric_limits<double>::infinity();
    return true;
  }
  if (s.empty()) return false;
  char* end = nullptr;
  v = std::strtod(s.c_str(), &end);
  return end == s.c_str() + s.size() && std::isfinite(v);
}

}  // namespace

MaterialTable MaterialTable::ctDefault() {
  // Keep in step with assets/materials/ct-default.csv (a test compares them).
  return parse(R"(units,hu
name,lower,upper,youngs_kpa,poisson,strain_limit,skeleton
air,-inf,-500,1,0.3,inf,no
lung-or-gas-boundary,-500,-150,3,0.4,inf,no
fat,-150,-50,3,0.45,0.3,no
fluid-and-soft-tissue,-50,45,6,0.45,0.22,no
organ-and-blood,45,100,8,0.45,0.22,no
enhanced-organ-and-blood,100,150,15,0.45,0.22,no
spongy-bone,150,700,300000,0.3,0.0078,joined
compact-bone,700,inf,15000000,0.3,0.027,yes
)",
               "built-in CT material table");
}

MaterialTable MaterialTable::parse(const std::string& text, const std::string& source) {
  MaterialTable t;
  std::istringstream in(text);
  std::string line;
  int lineNo = 0;
  bool haveUnits = false, haveHeader = false;
  std::size_t columns = 0;
  auto fail = [&](const std::string& why) { throw Error(source + ":" + std::to_string(lineNo) + ": " + why); };
  while (std::getline(in, line)) {
    ++lineNo;
    line = trim(line);
    if (line.empty() || line[0] == '#') continue;
    const auto cells = splitCsv(line);
    if (!haveUnits) {
      if (cells.size() != 2 || cells[0] != "units") fail("expected \"units,hu\" or \"units,percentile\" first");
      if (cells[1] == "hu") t.units_ = MaterialUnits::Hounsfield;
      else if (cells[1] == "percentile") t.units_ = MaterialUnits::Percentile;
      else fail("unknown units \"" + cells[1] + "\" (hu or percentile)");
      haveUnits = true;
      continue;
    }
    if (!haveHeader) {
      const std::vector<std::string> base{"name", "lower", "upper", "youngs_kpa", "poisson"};
      std::vector<std::string> withLimit = base;
      withLimit.push_back("strain_limit");
      std::vector<std::string> withSkeleton = withLimit;
      withSkeleton.push_back("skeleton");
      if (cells != base && cells != withLimit && cells != withSkeleton)
        fail("expected the header \"name,lower,upper,youngs_kpa,poisson\", optionally followed by \",strain_limit\" and \",skeleton\"");
      columns = cells.size();
      haveHeader = true;
      continue;
    }
    if (cells.size() != columns) fail("expected " + std::to_string(columns) + " columns, found " + std::to_string(cells.size()));
    MaterialBand b;
    b.name = cells[0];
    double kpa = 0.0;
    if (b.name.empty()) fail("empty band name");
    if (!parseNumber(cells[1], b.lower) && cells[1] != "-inf") fail("bad lower bound \"" + cells[1] + "\"");
    if (!parseNumber(cells[2], b.upper)) fail("bad upper bound \"" + cells[2] + "\"");
    if (!(b.lower < b.upper)) fail("band \"" + b.name + "\" has lower >= upper");
    if (!parseNumber(cells[3], kpa) || kpa <= 0.0 || kpa > 1e9) fail("Young's modulus must be in (0, 1e9] kPa, not \"" + cells[3] + "\"");
    if (!parseNumber(cells[4], b.poisson) || b.poisson < 0.0 || b.poisson >= 0.5) fail("Poisson ratio must be in [0, 0.5), not \"" + cells[4] + "\"");
    b.youngs = kpa * 1e3;
    if (columns >= 6 && (!parseNumber(cells[5], b.strainLimit) || !(b.strainLimit > 0.0)))
      fail("strain limit must be a positive fraction (0.3 for 30 %) or \"inf\" (none), not \"" + cells[5] + "\"");
    if (columns >= 7) {
      if (cells[6] == "no") b.skeleton = SkeletonRole::No;
      else if (cells[6] == "yes") b.skeleton = SkeletonRole::Yes;
      else if (cells[6] == "joined") b.skeleton = SkeletonRole::Joined;
      else fail("skeleton must be no, yes or joined, not \"" + cells[6] + "\"");
    }
    if (b.poisson > kMaxPoisson) {
      b.poisson = kMaxPoisson;
      t.capped_.push_back(b.name);
    }
    if (!t.bands_.empty() && b.lower < t.bands_.back().upper) fail("band \"" + b.name + "\" overlaps or precedes the previous one");
    if (t.units_ == MaterialUnits::Percentile && ((std::isfinite(b.lower) && (b.lower < 0 || b.lower > 100)) || (std::isfinite(b.upper) && (b.upper < 0 || b.upper > 100))))
      fail("percentile bounds must lie in [0, 100]");
    t.bands_.push_back(b);
  }
  if (t.bands_.empty()) throw Error(source + ": no material bands");
  t.resolved_ = t.units_ == MaterialUnits::Hounsfield;
  return t;
}

MaterialTable MaterialTable::load(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open material table " + path);
  std::ostringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  if (text.size() > (1u << 20)) throw Error(path + ": material table larger than 1 MiB");
  return parse(text, path);
}

MaterialTable MaterialTable::resolve(const Volume& image) const {
  if (units_ == MaterialUnits::Hounsfield) return *this;
  if (image.empty()) throw Error("material table: cannot resolve percentiles on an empty image");
  // A subsample is plenty for percentiles (at most ~1 M values).
  const std::size_t n = image.voxelCount();
  const std::size_t stride = std::max<std::size_t>(1, n / 1000000);
  std::vector<float> v;
  v.reserve(n / stride + 1);
  for (std::size_t i = 0; i < n; i += stride) {
    const float x = image.value(i);
    if (std::isfinite(x)) v.push_back(x);
  }
  if (v.empty()) throw Error("material table: the image has no finite values");
  std::sort(v.begin(), v.end());
  const float background = v[std::size_t(0.02 * double(v.size() - 1))];
  std::vector<float> body;
  for (float x : v)
    if (x > background) body.push_back(x);
  if (body.empty()) body = v;  // a flat image: every voxel is "body"
  auto at = [&](double pct) {
    if (!std::isfinite(pct)) return pct;
    const double pos = pct / 100.0 * double(body.size() - 1);
    const std::size_t i = std::size_t(std::floor(pos));
    const std::size_t j = std::min(i + 1, body.size() - 1);
    return double(body[i]) + (pos - double(i)) * double(body[j] - body[i]);
  };
  MaterialTable out = *this;
  out.units_ = MaterialUnits::Hounsfield;
  out.resolved_ = true;
  for (auto& b : out.bands_) {
    b.lower = at(b.lower);
    b.upper = at(b.upper);
  }
  // Equal percentiles (flat images) may collapse bands: keep them ordered and non-overlapping.
  for (std::size_t i = 1; i < out.bands_.size(); ++i) out.bands_[i].lower = std::max(out.bands_[i].lower, out.bands_[i - 1].upper);
  return out;
}

int MaterialTable::classify(double value) const {
  if (!resolved_) throw Error("material table: a percentile table must be resolved against the image first");
  if (std::isnan(value)) return 0;
  int best = 0;
  double bestDist = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < bands_.size(); ++i) {
    const auto& b = bands_[i];
    if (value >= b.lower && value < b.upper) return int(i);
    const double d = value < b.lower ? b.lower - value : value - b.upper;
    if (d < bestDist) {
      bestDist = d;
      best = int(i);
    }
  }
  return best;
}

}  // namespace handson
