#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "app/cli/args.h"
#include "app/cli/commands.h"
#include "app/cli/headless_scene.h"
#include "app/io/png_io.h"
#include "sim/base/error.h"

namespace handson::cli {

namespace {

std::vector<std::string> withExtra(std::vector<std::string> base, std::initializer_list<const char*> extra) {
  for (const char* e : extra) base.emplace_back(e);
  return base;
}

void printTimings(const FrameResult& r) {
  for (const auto& t : r.timings) std::cerr << "  " << std::setw(16) << std::left << t.name << std::fixed << std::setprecision(2) << t.gpuMs << " ms\n";
}

int renderToPng(const std::string& path, const Args& args, const std::string& out) {
  HeadlessScene scene = openHeadlessScene(path, args);
  // The settled still frame: the mean of the jitter phases, one pass each (render/render_params.h).
  FrameRequest req;
  req.params = scene.params();
  req.stillPhases = scene.settings.jitter ? scene.jitterPhases : 0;
  for (int k = 0; k < std::max(req.stillPhases, 1); ++k) scene.renderer->submit(req);
  const FrameResult r = scene.renderer->waitLast();
  writePng(out, r.width, r.height, r.rgba);
  if (!args.flag("--quiet")) {
    std::cerr << "rendered " << scene.source << " (" << scene.tf.name << ") on " << scene.context->summary().name << "\n";
    printTimings(r);
  }
  if (scene.context->validationMessageCount() > 0) {
    std::cerr << "error: " << scene.context->validationMessageCount() << " Vulkan validation message(s)\n";
    return 1;
  }
  return 0;
}

}  // namespace

int cmdRender(const Words& words) {
  Args args(words, withExtra(kRenderValueOptions, {"-o"}), kRenderFlagOptions);
  if (args.help() || !args.value("-o") || args.positional().size() > 1) {
    usageStream(args) << "usage: handson render [PATH] -o OUT.png [options]\n"
                 "  Renders one frame headless. PATH: NIfTI file or DICOM directory; omitted: the built-in phantom.\n"
              << kRenderOptionsHelp;
    return args.help() ? 0 : 2;
  }
  const std::string out = *args.value("-o");
  const int rc = renderToPng(args.positional().empty() ? "" : args.positional()[0], args, out);
  if (rc == 0) std::cout << "wrote " << out << "\n";
  return rc;
}

int cmdPick(const Words& words) {
  Args args(words, withExtra(kRenderValueOptions, {"--at", "--threshold", "--faint-threshold"}), withExtra(kRenderFlagOptions, {"--json"}));
  if (args.help() || !args.value("--at") || args.positional().size() > 1) {
    usageStream(args) << "usage: handson pick [PATH] --at X,Y[;X,Y...] [--threshold A] [--faint-threshold B] [options]\n"
                 "  GPU depth picking: for each pixel (x right, y down, in the --size image), the first point along\n"
                 "  its viewing ray where the accumulated opacity reaches A (default 0.5); on a ray that ends fainter\n"
                 "  than A but at least B opaque (default 0: such rays miss; 0.2: a fifth of the pixel's colour), its\n"
                 "  most visible point (the sample giving the pixel most of its colour). A RAS point in mm and the\n"
                 "  nearest voxel index; or 'miss'. --json prints one JSON object per point.\n"
              << kRenderOptionsHelp;
    return args.help() ? 0 : 2;
  }
  std::vector<glm::vec2> pixels;
  {
    std::stringstream ss(*args.value("--at"));
    std::string item;
    while (std::getline(ss, item, ';')) {
      const auto v = parseNumberList(item, "--at");
      if (v.size() != 2) throw UsageError("--at takes X,Y pairs separated by ';'");
      pixels.emplace_back(float(v[0]), float(v[1]));
    }
  }
  if (pixels.empty() || pixels.size() > 100000) throw UsageError("--at needs between 1 and 100000 points");
  HeadlessScene scene = openHeadlessScene(args.positional().empty() ? "" : args.positional()[0], args);
  scene.settings.pickThreshold = float(args.number("--threshold", 0.5, 1e-4, 1.0));
  scene.settings.pickFaintThreshold = float(args.number("--faint-threshold", RenderSettings{}.pickFaintThreshold, 0.0, 1.0));
  FrameRequest req;
  req.params = scene.params(std::uint32_t(pixels.size()));
  req.readbackImage = false;
  for (const auto& p : pixels) req.pickPoints.push_back(pixelToNdc(p.x, p.y, scene.settings.width, scene.settings.height));
  scene.renderer->submit(req);
  const FrameResult r = scene.renderer->waitLast();
  const bool json = args.flag("--json");
  std::cout << std::fixed << std::setprecision(3);
  for (std::size_t i = 0; i < pixels.size(); ++i) {
    const auto& p = r.picks[i];
    const bool hit = p.world.w > 0.5f;
    if (json) {
      std::cout << "{\"x\":" << pixels[i].x << ",\"y\":" << pixels[i].y << ",\"hit\":" << (hit ? "true" : "false");
      if (hit)
        std::cout << ",\"world\":[" << p.world.x << "," << p.world.y << "," << p.world.z << "],\"voxel\":[" << p.voxel.x << "," << p.voxel.y
                  << "," << p.voxel.z << "]";
      std::cout << "}\n";
    } else if (hit) {
      std::cout << pixels[i].x << "," << pixels[i].y << ": world (" << p.world.x << ", " << p.world.y << ", " << p.world.z << ") mm, voxel ("
                << p.voxel.x << ", " << p.voxel.y << ", " << p.voxel.z << ")\n";
    } else {
      std::cout << pixels[i].x << "," << pixels[i].y << ": miss\n";
    }
  }
  return scene.context->validationMessageCount() > 0 ? 1 : 0;
}

}  // namespace handson::cli
