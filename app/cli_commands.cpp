#include <cmath>
#include <exception>
#include <iomanip>
#include <iostream>
#include <new>

#include "app/cli.h"
#include "app/cli_args.h"
#include "app/console.h"
#include "app/io/nifti_io.h"
#include "app/io/volume_io.h"
#include "render/vk_context.h"
#include "sim/error.h"
#include "sim/phantom.h"
#include "sim/resample.h"

namespace handson::cli {

namespace {

const char* const kMainHelp =
    "handson - hands-on deformation of volumetric anatomical images\n"
    "\n"
    "usage: handson [COMMAND] [OPTIONS]\n"
    "\n"
    "With no command, opens the built-in abdominal phantom in a window; with no display, replays the\n"
    "built-in full session headless (the kidney pinched, dragged and turned with the tissue deforming\n"
    "around it) into handson-demo/: frames, contact-sheet.png, timings and the exported volume.\n"
    "\n"
    "commands:\n"
    "  view [PATH]                   open a volume in the touch app (omitted: the built-in phantom)\n"
    "  replay [SCRIPT]               play a session script headless: PNG frames and a timing log\n"
    "  retarget SCRIPT --volume CT --labels L --label N -o OUT.json   aim a gesture script at an organ\n"
    "  compose --volume CT --labels L --organ N --anchor M -o OUT.json   a whole session laid out on that anatomy\n"
    "  stress-gestures [--sequences N]   a random stream of valid and broken gestures through the headless pipeline\n"
    "  soak [--frames N]                 a long session replayed headless: memory and Vulkan allocations must stay flat\n"
    "  info PATH                     dimensions, spacing, orientation and value range of a volume\n"
    "  render [PATH] -o OUT.png      render one frame headless (PATH: NIfTI file or DICOM directory;\n"
    "                                omitted: the built-in phantom)\n"
    "  pick [PATH] --at X,Y[;X,Y..]  GPU depth picking of pixels: first visible surface point of each\n"
    "  select PATH --seed-voxel I,J,K --extent-mm D -o MASK.nii.gz   seeded region growing\n"
    "  gesture-solve --input FILE|-  one rigid gesture solve (JSON in, JSON out)\n"
    "  deform PATH --handle MASK --translate-mm X,Y,Z -o OUT.nii.gz   move a handle, deform the tissue\n"
    "  phantom -o CT.nii.gz          write the built-in phantom (and --labels-out LABELS.nii.gz)\n"
    "  resample PATH --voxels N -o OUT.nii.gz   resample to about N voxels\n"
    "  bench [PATH]                  raymarch benchmark: plain vs empty-space skipping + early termination\n"
    "  devices                       list Vulkan devices\n"
    "\n"
    "'handson COMMAND --help' describes each command.\n";

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

int run(int argc, char** argv) {
  Words words(argv + 1, argv + argc);
  std::string cmd = words.empty() ? "" : words[0];
  if (cmd == "--help" || cmd == "-h" || cmd == "help") {
    std::cout << kMainHelp;
    return 0;
  }
  const bool isCommand = !cmd.empty() && cmd[0] != '-';
  const Words rest = isCommand ? Words(words.begin() + 1, words.end()) : words;
  try {
    if (!isCommand) return cmdDefault(rest);
    if (cmd == "info") return cmdInfo(rest);
    if (cmd == "phantom") return cmdPhantom(rest);
    if (cmd == "resample") return cmdResample(rest);
    if (cmd == "devices") return cmdDevices(rest);
    if (cmd == "render") return cmdRender(rest);
    if (cmd == "pick") return cmdPick(rest);
    if (cmd == "view") return cmdView(rest);
    if (cmd == "select") return cmdSelect(rest);
    if (cmd == "gesture-solve") return cmdGestureSolve(rest);
    if (cmd == "replay") return cmdReplay(rest);
    if (cmd == "retarget") return cmdRetarget(rest);
    if (cmd == "compose") return cmdCompose(rest);
    if (cmd == "stress-gestures") return cmdStressGestures(rest);
    if (cmd == "soak") return cmdSoak(rest);
    if (cmd == "bench") return cmdBench(rest);
    if (cmd == "deform") return cmdDeform(rest);
    std::cerr << "error: unknown command '" << cmd << "'\n\n" << kMainHelp;
    return 2;
  } catch (const UsageError& e) {
    std::cerr << "error: " << e.what() << " (see 'handson " << cmd << " --help')\n";
    return 2;
  } catch (const Error& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  } catch (const std::bad_alloc&) {
    std::cerr << "error: out of memory\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace handson::cli
