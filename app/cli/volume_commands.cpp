#include <cmath>
#include <iomanip>
#include <iostream>

#include "app/cli/commands.h"
#include "app/io/nifti_io.h"
#include "app/io/volume_io.h"
#include "app/session/console.h"
#include "render/vk_context.h"
#include "sim/base/error.h"
#include "sim/phantom.h"
#include "sim/resample.h"

namespace handson::cli {

namespace {

void printGeometry(const Volume& v) {
  const auto& g = v.geometry();
  std::cout << std::fixed << std::setprecision(4);
  std::cout << "dimensions:  " << g.dims.x() << " x " << g.dims.y() << " x " << g.dims.z() << " (" << g.voxelCount() << " voxels)\n";
  std::cout << "spacing:     " << g.spacing.x() << " x " << g.spacing.y() << " x " << g.spacing.z() << " mm\n";
  std::cout << "origin:      (" << g.origin.x() << ", " << g.origin.y() << ", " << g.origin.z() << ") mm RAS\n";
  std::cout << "direction:   i=(" << g.direction(0, 0) << ", " << g.direction(1, 0) << ", " << g.direction(2, 0) << ") j=("
            << g.direction(0, 1) << ", " << g.direction(1, 1) << ", " << g.direction(2, 1) << ") k=(" << g.direction(0, 2) << ", "
            << g.direction(1, 2) << ", " << g.direction(2, 2) << ")\n";
  const Eigen::Vector3d lo = g.toWorld(Eigen::Vector3d::Zero());
  const Eigen::Vector3d hi = g.toWorld((g.dims.array() - 1).cast<double>().matrix());
  std::cout << "extent:      (" << lo.x() << ", " << lo.y() << ", " << lo.z() << ") .. (" << hi.x() << ", " << hi.y() << ", " << hi.z()
            << ") mm (voxel centres)\n";
  const auto [mn, mx] = v.valueRange();
  std::cout << std::setprecision(2) << "type:        " << scalarTypeName(v.type()) << "\nvalue range: " << mn << " .. " << mx << "\n";
}

}  // namespace

int cmdInfo(const Words& words) {
  Args args(words, {"--frame"}, {"--quiet"});
  if (args.help() || args.positional().size() != 1) {
    usageStream(args) << "usage: handson info PATH [--frame N]\n  PATH: a NIfTI file (.nii, .nii.gz, .hdr/.img), a DICOM series directory or one of\n"
                         "  its files (the format is told by the content)\n"
                      << kFrameHelp;
    return args.help() ? 0 : 2;
  }
  LoadReport rep;
  const Volume v = loadVolume(args.positional()[0], &rep, args.flag("--quiet") ? ProgressFn{} : consoleProgress(), loadOptions(args));
  for (const auto& w : rep.warnings) std::cerr << "warning: " << w << "\n";
  std::cout << "file:        " << args.positional()[0] << "\nformat:      " << rep.format << "\n";
  if (rep.frames > 1) std::cout << "volumes:     " << rep.frames << " (this is volume " << rep.frame << ")\n";
  printGeometry(v);
  return 0;
}

int cmdPhantom(const Words& words) {
  Args args(words, {"-o", "--labels-out", "--spacing", "--noise", "--seed"}, {});
  if (args.help() || !args.value("-o") || !args.positional().empty()) {
    usageStream(args) << "usage: handson phantom -o CT.nii.gz [--labels-out LABELS.nii.gz] [--spacing MM] [--noise HU] [--seed N]\n"
                 "  The built-in abdominal phantom (int16 HU) and its uint8 label map:\n"
                 "  1 body, 2 bone, 3 kidney_left, 4 kidney_right, 8 liver, 9 artery, 11 venous_system.\n"
                 "  --spacing MM  isotropic voxel size (default 2)\n  --noise HU    noise standard deviation (default 12)\n";
    return args.help() ? 0 : 2;
  }
  PhantomOptions o;
  o.spacingMm = args.number("--spacing", o.spacingMm, 0.25, 50.0);
  o.noiseHu = args.number("--noise", o.noiseHu, 0.0, 500.0);
  o.seed = std::uint32_t(args.integer("--seed", o.seed, 0, 0xffffffffL));
  const Phantom ph = makePhantom(o);
  writeVolume(ph.ct, *args.value("-o"));
  std::cout << "wrote " << *args.value("-o") << " (" << ph.ct.dims().x() << "x" << ph.ct.dims().y() << "x" << ph.ct.dims().z() << ", "
            << o.spacingMm << " mm)\n";
  if (auto l = args.value("--labels-out")) {
    writeVolume(ph.labels, *l);
    std::cout << "wrote " << *l << "\n";
  }
  return 0;
}

int cmdResample(const Words& words) {
  Args args(words, {"--voxels", "-o"}, {"--quiet"});
  if (args.help() || args.positional().size() != 1 || !args.value("-o") || !args.value("--voxels")) {
    usageStream(args) << "usage: handson resample PATH --voxels N -o OUT.nii.gz\n"
                 "  Resamples to about N voxels over the same physical box (box-filtered when shrinking;\n"
                 "  label maps (uint8) use nearest neighbour).\n";
    return args.help() ? 0 : 2;
  }
  const ProgressFn progress = args.flag("--quiet") ? ProgressFn{} : consoleProgress();
  const long n = args.integer("--voxels", 0, 1, long(kMaxVoxels));
  const Volume v = loadVolume(args.positional()[0], nullptr, progress);
  const Volume r = resampleToVoxelCount(v, std::size_t(n), progress);
  writeVolume(r, *args.value("-o"));
  std::cout << "wrote " << *args.value("-o") << " (" << r.dims().x() << "x" << r.dims().y() << "x" << r.dims().z() << " = " << r.voxelCount()
            << " voxels)\n";
  return 0;
}

int cmdDevices(const Words& words) {
  Args args(words, {}, {});
  if (args.help()) {
    usageStream(args) << "usage: handson devices\n  Lists the Vulkan devices; choose one with --device or HANDSON_DEVICE.\n";
    return 0;
  }
  const auto devs = vk::Context::listDevices();
  if (devs.empty()) {
    std::cerr << "error: no Vulkan device found (on Debian: apt-get install mesa-vulkan-drivers)\n";
    return 1;
  }
  for (std::size_t i = 0; i < devs.size(); ++i)
    std::cout << "[" << i << "] " << devs[i].name << " (" << vk::deviceTypeName(devs[i].type) << ", Vulkan " << VK_API_VERSION_MAJOR(devs[i].apiVersion)
              << "." << VK_API_VERSION_MINOR(devs[i].apiVersion) << ")\n";
  return 0;
}

}  // namespace handson::cli
