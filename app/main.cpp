// handson: the command dispatch. Each command lives in app/cli (app/cli/commands.h) or app/bench
// (app/bench/bench.h); this file maps their names and turns what they throw into the exit status.
#include <exception>
#include <iostream>
#include <new>
#include <string>

#include "app/bench/bench.h"
#include "app/cli/commands.h"
#include "sim/base/error.h"

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

/// Runs the command line; returns the process exit status (0 ok, 1 failure, 2 usage error).
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

}  // namespace
}  // namespace handson::cli

int main(int argc, char** argv) { return handson::cli::run(argc, argv); }
