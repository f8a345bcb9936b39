// `handson bench visibility --out DIR`: how well each organ can be seen and picked with the
// defaults (#47): a clip box of the organ's label bounds +- a margin, the camera from the side of
// the body the organ is nearest (framing the clip), the default preset (its window fitted to the
// clip: render/auto_window.h). Through `render` and `pick`'s own scene (app/cli/headless_scene.h):
// the settled still frame, and depth picks on a grid of the view. Per organ: the grid points that
// hit anything and those that hit the organ (the label at the picked voxel), and the mean CIELAB
// colour difference between the organ's grid pixels and the other hit ones (visibility.csv,
// visibility.md, a picture per organ).
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "app/bench/bench.h"
#include "app/cli/headless_scene.h"
#include "app/io/nifti_io.h"
#include "app/io/png_io.h"
#include "app/tools/visibility.h"
#include "sim/base/error.h"
#include "sim/phantom.h"

namespace handson::cli {

namespace {

struct VisibilityCase {
  std::string volume, ctPath;  ///< ctPath empty: the built-in phantom
  int label = 0;
  std::string organ;
};

struct VisibilityRow {
  VisibilityCase c;
  std::string preset;
  double azimuth = 0.0, windowShift = 0.0;
  int grid = 0, hits = 0, organHits = 0;
  double deltaE = 0.0;
};

// The kidneys, spleen and liver of the shared CTs (their label tables: ../shared/data/README.md),
// or the phantom's kidneys and liver without them.
std::vector<VisibilityCase> visibilityCases(const std::string& data) {
  namespace fs = std::filesystem;
  std::vector<VisibilityCase> cases;
  const fs::path ircadb = fs::path(data) / "ircadb1.1", totalseg = fs::path(data) / "totalseg-small";
  if (fs::exists(ircadb / "labels.nii.gz"))
    for (const auto& [label, organ] : std::vector<std::pair<int, std::string>>{{3, "kidney_left"}, {4, "kidney_right"}, {7, "spleen"}, {8, "liver"}})
      cases.push_back({"ircadb1.1", (ircadb / "ct.nii.gz").string(), label, organ});
  if (fs::exists(totalseg / "labels.nii.gz"))
    for (const auto& [label, organ] : std::vector<std::pair<int, std::string>>{{2, "kidney_right"}, {3, "kidney_left"}, {1, "spleen"}, {5, "liver"}})
      cases.push_back({"totalseg-small", (totalseg / "ct.nii.gz").string(), label, organ});
  if (cases.empty())
    for (const auto& [label, organ] : std::vector<std::pair<int, std::string>>{{3, "kidney_left"}, {4, "kidney_right"}, {8, "liver"}})
      cases.push_back({"phantom", "", label, organ});
  return cases;
}

std::string labelsPathOf(const VisibilityCase& c) {
  return (std::filesystem::path(c.ctPath).parent_path() / "labels.nii.gz").string();
}

struct VisibilityOptions {
  int size = 384, grid = 48;
  double marginMm = 15.0;
  bool autoWindow = true;
  float faintThreshold = RenderSettings{}.pickFaintThreshold;  ///< the picks' faint-ray rule (render_params.h)
  std::string preset;  ///< empty: each volume's default
  std::string out;
};

// A case's CT and labels, read once for all of its volume's organs.
struct LoadedVolume {
  std::string name;
  Volume ct, labels;
};

// One organ: the scene as `render`/`pick` open it, the still frame, the grid's picks.
VisibilityRow measure(const VisibilityCase& c, const LoadedVolume& loaded, const VisibilityOptions& o) {
  const Volume& labels = loaded.labels;
  const int size = o.size, grid = o.grid;
  const auto box = labelBox(labels, c.label);
  if (!box) throw Error("bench visibility: no voxel of label " + std::to_string(c.label) + " in " + c.volume);
  VisibilityRow row{c};
  const Eigen::Vector3d lo = box->lo.array() - o.marginMm, hi = box->hi.array() + o.marginMm;
  std::ostringstream clip;
  clip << std::setprecision(9) << lo.x() << "," << lo.y() << "," << lo.z() << "," << hi.x() << "," << hi.y() << "," << hi.z();
  // The side is chosen on the CT's own values: the scene's volume below (the phantom: its CT).
  row.azimuth = nearestSideAzimuth(loaded.ct, 0.5 * (box->lo + box->hi));
  std::ostringstream cam;
  cam << row.azimuth << ",0";
  Words words{"--size", std::to_string(size) + "x" + std::to_string(size), "--camera", cam.str(), "--clip-box", clip.str(), "--quiet"};
  if (!c.ctPath.empty()) words.insert(words.begin(), c.ctPath);
  if (!o.autoWindow) words.push_back("--no-auto-window");
  if (!o.preset.empty()) words.insert(words.end(), {"--preset", o.preset});
  const Args args(words, kRenderValueOptions, kRenderFlagOptions);
  HeadlessScene scene = openHeadlessScene(c.ctPath, args);
  row.preset = scene.tf.name;
  row.windowShift = scene.windowShift;
  scene.settings.pickFaintThreshold = o.faintThreshold;
  FrameRequest req;
  req.params = scene.params(std::uint32_t(grid * grid));
  req.stillPhases = scene.settings.jitter ? scene.jitterPhases : 0;
  const double cell = double(size) / grid;
  for (int j = 0; j < grid; ++j)
    for (int i = 0; i < grid; ++i) req.pickPoints.emplace_back(float(2.0 * (i + 0.5) * cell / size - 1.0), float(2.0 * (j + 0.5) * cell / size - 1.0));
  for (int k = 0; k < std::max(req.stillPhases, 1); ++k) scene.renderer->submit(req);
  const FrameResult r = scene.renderer->waitLast();
  std::vector<std::array<double, 3>> organ, other;
  for (int j = 0; j < grid; ++j)
    for (int i = 0; i < grid; ++i) {
      const auto& p = r.picks[std::size_t(j * grid + i)];
      if (!(p.world.w > 0.5f)) continue;
      ++row.hits;
      const std::size_t px = std::size_t(int((j + 0.5) * cell) * r.width + int((i + 0.5) * cell)) * 4;
      const auto lab = srgbToLab(r.rgba[px], r.rgba[px + 1], r.rgba[px + 2]);
      // The label at the picked point, on the label map's own grid (it need not be the CT's).
      const bool onOrgan = labelAt(labels, Eigen::Vector3d(p.world.x, p.world.y, p.world.z)) == c.label;
      row.organHits += onOrgan;
      (onOrgan ? organ : other).push_back(lab);
    }
  row.grid = grid * grid;
  row.deltaE = meanPairwiseDeltaE(organ, other);
  writePng(o.out + "/visibility_" + c.volume + "_" + c.organ + ".png", r.width, r.height, r.rgba);
  if (scene.context->validationMessageCount() > 0) throw Error("bench visibility: Vulkan validation messages");
  return row;
}

void writeRows(const std::vector<VisibilityRow>& rows, const std::string& out, int size) {
  std::ofstream csv(out + "/visibility.csv");
  csv << "volume,organ,label,preset,azimuth_deg,window_shift,grid_points,hits,organ_hits,organ_share,delta_e\n";
  std::ofstream md(out + "/visibility.md");
  md << "Each organ's label box +- the margin as a clip, framed from the side of the body it is nearest, the default preset windowed "
        "on the clip ("
     << size << " x " << size << " view; grid points that hit anything / the organ; mean CIELAB dE between the organ's grid pixels and the other hits)\n\n"
     << "| volume | organ | preset | azimuth | hits | organ hits | organ share | dE |\n|---|---|---|---|---|---|---|---|\n";
  for (const VisibilityRow& r : rows) {
    const double share = double(r.organHits) / r.grid;
    csv << r.c.volume << "," << r.c.organ << "," << r.c.label << "," << r.preset << "," << r.azimuth << "," << r.windowShift << ","
        << r.grid << "," << r.hits << "," << r.organHits << "," << share << "," << r.deltaE << "\n";
    md << std::defaultfloat << std::setprecision(6) << "| " << r.c.volume << " | " << r.c.organ << " | " << r.preset << " | " << r.azimuth << " | " << r.hits << " | " << r.organHits << " | "
       << std::fixed << std::setprecision(3) << share << " | " << std::setprecision(1) << r.deltaE << " |\n";
  }
  std::cout << std::ifstream(out + "/visibility.md").rdbuf();
}

}  // namespace

int cmdBenchVisibility(const Words& words) {
  Args args(words, {"--out", "--data", "--size", "--grid", "--margin-mm", "--preset", "--faint-threshold"}, {"--no-auto-window"});
  if (args.help() || !args.value("--out") || !args.positional().empty()) {
    usageStream(args) << "usage: handson bench visibility --out DIR [--data DIR] [--size N] [--grid G] [--margin-mm M] [--preset NAME]\n"
                         "                               [--no-auto-window] [--faint-threshold B]\n"
                         "  How well each organ is seen and picked with the defaults: its label box +- M mm (default 15) as a clip\n"
                         "  box, framed from the side of the body it is nearest, the default preset (its window fitted to the clip);\n"
                         "  an N x N still frame (default 384) and depth picks on a G x G grid (default 48): the grid points that hit\n"
                         "  anything and the organ, and the mean CIELAB dE between the organ's and the other hit pixels. The kidneys,\n"
                         "  spleen and liver of DIR/ircadb1.1 and DIR/totalseg-small (default ../shared/data), else the phantom's.\n"
                         "  --preset NAME measures another preset; --no-auto-window keeps the preset's own window (the baseline);\n"
                         "  --faint-threshold B the picks' faint-ray rule as `pick` takes it (default 0: faint rays miss).\n"
                         "  Writes DIR/visibility.csv, visibility.md\n"
                         "  and visibility_VOLUME_ORGAN.png.\n";
    return args.help() ? 0 : 2;
  }
  VisibilityOptions o;
  o.out = *args.value("--out");
  o.size = int(args.integer("--size", 384, 16, 4096));
  o.grid = int(args.integer("--grid", 48, 2, 300));
  if (o.grid > o.size) throw UsageError("--grid must not exceed --size");
  o.marginMm = args.number("--margin-mm", 15.0, 0.0, 500.0);
  o.autoWindow = !args.flag("--no-auto-window");
  o.faintThreshold = float(args.number("--faint-threshold", o.faintThreshold, 0.0, 1.0));
  o.preset = args.valueOr("--preset", "");
  if (!o.preset.empty()) (void)transferFunctionPreset(o.preset);  // an unknown name: the list, before any work
  std::filesystem::create_directories(o.out);
  std::vector<VisibilityRow> rows;
  LoadedVolume loaded;
  for (const VisibilityCase& c : visibilityCases(args.valueOr("--data", "../shared/data"))) {
    if (loaded.name != c.volume) {
      if (c.ctPath.empty()) {
        Phantom p = makePhantom();
        loaded = {c.volume, std::move(p.ct), std::move(p.labels)};
      } else {
        loaded = {c.volume, readNifti(c.ctPath), readNifti(labelsPathOf(c))};
      }
    }
    rows.push_back(measure(c, loaded, o));
    std::cerr << "bench visibility: " << c.volume << " " << c.organ << ": " << rows.back().organHits << " of " << rows.back().grid << " grid points on the organ\n";
  }
  writeRows(rows, o.out, o.size);
  return 0;
}

}  // namespace handson::cli
