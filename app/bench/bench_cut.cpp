// `handson bench cut`: what a cut costs (docs/cutting.md). Incisions of several lengths and depths
// beside the handle's organ (on its side away from the body's midline, 10 mm from its surface, in a sagittal plane: length craniocaudal, depth anterior-posterior, centred on the organ),
// each applied to a fresh copy of the scene: the time of the mesh cut alone (cutMesh) and of the
// whole scene's cut (cutScene: the mesh, the nodes' roles, the loose-piece check), the faces
// separated and the nodes copied; the coarse model of the cut scene (built whole and updated where
// the cut passes, its frame against the uncut model's); and the force a retractor needs to pull the cut's outer lip away (that model,
// the lip a handle, refined; the organ held). Writes cut_timing.csv and, with gnuplot, cut_timing.png.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>
#include <utility>

#include "app/bench/bench.h"
#include "app/cli/args.h"
#include "app/session/console.h"
#include "sim/base/error.h"
#include "sim/coarsening.h"
#include "sim/handle_reaction.h"
#include "sim/scene_cut.h"
#include "sim/sim_scene.h"
#include "sim/two_level.h"

namespace handson::cli {

namespace {

constexpr const char* kBenchCutHelp =
    "usage: handson bench cut [PATH --handle MASK [--handle-label N]] [--out DIR] [--lengths-mm LIST] [--depths-mm LIST]\n"
    "        [--repeat N] [--retract-mm D] [--coarse-tets N] [--fine-tets N] [--spacing MM] [--interface sliding|glued]\n"
    "  Cuts beside the handle's organ (default: the built-in phantom's right kidney): a sagittal quad on the\n"
    "  organ's side away from the midline, 10 mm from it, each length (default 25,50,100 mm, craniocaudal) by\n"
    "  each depth (default 10,15,30 mm, anterior-posterior), centred on the organ, each on a fresh copy of\n"
    "  the scene: the mesh cut's and the whole scene cut's time (median of N, default 3), the faces\n"
    "  separated and the nodes copied (a refused cut: said, 0 faces and no time); the coarse model of the\n"
    "  cut scene built whole and updated from the uncut one where the cut passes (each factorized), the\n"
    "  elements and coarse nodes the cut added, and its frame (the organ dragged 1 mm a frame, 3\n"
    "  iterations) against the uncut model's; and the force a retractor needs to pull the cut's outer lip\n"
    "  (the tissue within 10 mm of it) D mm away (default 10; 0: none), the organ held (the cut scene's\n"
    "  coarse model refined 10 steps), in DIR/cut_timing.csv (scene, fine_tets, length_mm,\n"
    "  depth_mm, cut_faces, copied_nodes, mesh_cut_ms, scene_cut_ms, coarse_build_ms, coarse_update_ms,\n"
    "  added_elements, added_coarse_nodes, frame_ms, uncut_frame_ms, retract_force_N) and\n"
    "  DIR/cut_timing.png (gnuplot).\n"
    "  Meshes default to the app's (6000 coarse, 300000 fine tets).\n";

constexpr double kGapMm = 10.0;  ///< between the organ's surface and the cut

struct CutPlacement {
  double x;                   ///< the sagittal plane's RAS x (mm)
  Eigen::Vector3d centre;     ///< the organ's centre (its bounding box's)
  Eigen::AlignedBox3d organ;  ///< the organ's fine nodes' bounding box
};

// The body's centre across (RAS x): the mean x of the voxels above -500 (HU: not air), every
// fourth voxel along each axis; the image's centre if there are none.
double bodyCentreX(const Volume& image) {
  const Eigen::Vector3i d = image.dims();
  double sum = 0.0;
  std::size_t count = 0;
  for (int k = 0; k < d.z(); k += 4)
    for (int j = 0; j < d.y(); j += 4)
      for (int i = 0; i < d.x(); i += 4)
        if (image.value(i, j, k) > -500.0f) {
          sum += image.geometry().toWorld(Eigen::Vector3d(i, j, k)).x();
          ++count;
        }
  return count ? sum / double(count) : image.geometry().toWorld(0.5 * (d.cast<double>() - Eigen::Vector3d::Ones())).x();
}

// Beside the organ: the bounding box of its fine nodes (those the handle moves and, sliding, those
// on its surface), on the side away from the body's centre.
CutPlacement placeBeside(const SimScene& sc, const Volume& image) {
  Eigen::AlignedBox3d box;
  for (std::size_t n = 0; n < sc.meshes.fine.nodes.size(); ++n)
    if (sc.constraints.handleOf[n] == 0) box.extend(sc.meshes.fine.nodes[n]);
  for (const SlideNode& s : sc.constraints.slide)
    if (s.handle == 0) box.extend(sc.meshes.fine.nodes[std::size_t(s.node)]);
  if (box.isEmpty()) throw Error("bench cut: the handle holds no fine node");
  const bool positive = box.center().x() >= bodyCentreX(image);
  return {positive ? box.max().x() + kGapMm : box.min().x() - kGapMm, box.center(), box};
}

CutQuad sagittalQuad(const CutPlacement& p, double lengthMm, double depthMm) {
  const double y0 = p.centre.y() - depthMm / 2, y1 = p.centre.y() + depthMm / 2;
  const double z0 = p.centre.z() - lengthMm / 2, z1 = p.centre.z() + lengthMm / 2;
  return CutQuad{{Eigen::Vector3d(p.x, y0, z0), Eigen::Vector3d(p.x, y1, z0), Eigen::Vector3d(p.x, y1, z1), Eigen::Vector3d(p.x, y0, z1)}};
}

double millisecondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

struct CutTiming {
  std::size_t faces = 0, copied = 0;
  double meshMs = 0, sceneMs = 0;
};

// The cut timed `repeat` times, each on a fresh copy of the scene (the copy is not timed).
CutTiming timeCut(const SimScene& sc, const CutQuad& q, int repeat) {
  std::vector<double> meshMs, sceneMs;
  CutTiming r;
  for (int k = 0; k < repeat; ++k) {
    auto t0 = std::chrono::steady_clock::now();
    const MeshCut c = cutMesh(sc.meshes.fine, q);
    meshMs.push_back(millisecondsSince(t0));
    SimScene copy = sc;
    t0 = std::chrono::steady_clock::now();
    const SceneCutStats st = cutScene(copy, {q});
    sceneMs.push_back(millisecondsSince(t0));
    r.faces = st.cutFaces;
    r.copied = st.copiedNodes;
  }
  r.meshMs = median(meshMs);
  r.sceneMs = median(sceneMs);
  return r;
}

// The coarse model of the cut scene, built whole and updated from the uncut scene's where the cut
// passes (each with its preconditioner's factor: ready for a frame; docs/cutting.md), and the
// updated one's frames against the uncut one's: the organ dragged craniocaudally 1 mm a frame,
// three iterations a frame (the app's), the median of frames 3-12.
struct CoarseCut {
  double buildMs = 0, updateMs = 0, frameMs = 0;
  std::size_t addedElements = 0, addedNodes = 0;
};

double frameMs(CoarseModel& model, const Eigen::Vector3d& organ) {
  model.prepareSolve();
  std::vector<Eigen::Vector3d> xc = model.restState();
  std::vector<double> ms;
  for (int k = 1; k <= 12; ++k) {
    const std::vector<RigidTransform> T{RigidTransform::about(organ, Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 0, k))};
    const auto t0 = std::chrono::steady_clock::now();
    model.solve(T, xc, 3);
    if (k > 2) ms.push_back(millisecondsSince(t0));
  }
  return median(ms);
}

CoarseCut coarseOfCut(const CoarseModel& uncut, const SimScene& cut) {
  CoarseCut r;
  auto t0 = std::chrono::steady_clock::now();
  {
    CoarseModel whole(cut.meshes, cut.fineK, cut.constraints);
    whole.prepareSolve();
    r.buildMs = millisecondsSince(t0);
  }
  t0 = std::chrono::steady_clock::now();
  CoarseModel model(uncut, cut.meshes, cut.fineK, cut.constraints);
  model.prepareSolve();
  r.updateMs = millisecondsSince(t0);
  r.addedElements = model.elementCount() - cut.meshes.coarseGrid.cellCount();
  r.addedNodes = model.restState().size() - cut.meshes.coarse.nodes.size();
  r.frameMs = frameMs(model, cut.handleCentroid[0]);
  return r;
}

// The force (N) a retractor needs to pull the cut's lip on the side away from the organ `mm` away
// from the cut, the organ held: the coarse model of the cut scene (`cut`, which takes the lip as a
// handle of its own), refined `steps` steps.
double retractForce(const CoarseModel& uncut, SimScene& cut, const CutQuad& q, double mm, int steps = 10) {
  const CutLip lip = lipAwayFrom(q, cut.handleCentroid[0], 10.0);
  const int handle = addLipHandle(cut, lip);
  const std::vector<RigidTransform> T{RigidTransform{}, RigidTransform{Eigen::Matrix3d::Identity(), mm * lip.side * cutPlane(q).n}};
  CoarseModel model(uncut, cut.meshes, cut.fineK, cut.constraints);
  std::vector<Eigen::Vector3d> xc = model.restState();
  model.solve(T, xc, kOneOffSolveIterations);
  std::vector<Eigen::Vector3d> x = model.reconstruct(T, xc);
  const FineRefiner refiner(model, cut.fineK, cut.youngs, cut.poisson);
  for (int k = 0; k < steps; ++k) refiner.step(T, xc, x, 10);
  return fineHandleReactions(cut.meshes.fine, cut.fineK, cut.constraints, T, x)[std::size_t(handle)].forceN.norm();
}

void chart(const std::filesystem::path& out, const std::vector<double>& depths) {
  if (std::system("command -v gnuplot > /dev/null 2>&1") != 0) return;
  const auto gp = out / "cut_timing.gp";
  const std::string f = (out / "cut_timing.csv").string();
  std::ofstream g(gp);
  g << "set datafile separator ','\nset terminal pngcairo size 800,480 font ',11'\nset output '" << (out / "cut_timing.png").string()
    << "'\nset termoption noenhanced\nset title 'Time to cut the fine mesh beside the organ'\nset xlabel 'cut length (mm)'\n"
       "set ylabel 'time (ms)'\nset grid\nset key top left\nset yrange [0:*]\n";
  std::string plot;
  for (double d : depths)
    for (const auto& [col, what] : {std::pair<int, const char*>{7, "mesh cut"}, {8, "scene cut"}}) {
      std::ostringstream s;
      s << (plot.empty() ? "plot " : ", ") << "'" << f << "' using 3:($4 == " << d << " ? $" << col << " : 1/0) with linespoints title '" << what
        << ", depth " << d << " mm'";
      plot += s.str();
    }
  g << plot << "\n";
  g.close();
  if (std::system(("gnuplot " + gp.string() + " 2>/dev/null").c_str()) != 0) std::cerr << "gnuplot failed: no chart\n";
}

}  // namespace

int cmdBenchCut(const Words& words) {
  Args args(words, {"--handle", "--handle-label", "--out", "--lengths-mm", "--depths-mm", "--repeat", "--retract-mm", "--coarse-tets", "--fine-tets", "--spacing", "--interface"},
            {"--quiet"});
  if (args.help() || args.positional().size() > 1 || (args.positional().size() == 1) != bool(args.value("--handle"))) {
    usageStream(args) << kBenchCutHelp;
    return args.help() ? 0 : 2;
  }
  const std::vector<int> lengths = integerListOption(args, "--lengths-mm", "25,50,100", 1, 1000);
  const std::vector<int> depths = integerListOption(args, "--depths-mm", "10,15,30", 1, 1000);
  const int repeat = int(args.integer("--repeat", 3, 1, 100));
  SimSettings s;
  s.coarseTets = int(args.integer("--coarse-tets", s.coarseTets, 6, 2000000));
  s.fineTets = int(args.integer("--fine-tets", s.fineTets, 6, 20000000));
  interfaceOption(args, "--", s);
  const std::filesystem::path out = args.valueOr("--out", "bench-out");
  std::filesystem::create_directories(out);
  const HandleScene loaded = handleSceneOptions(args, 2.0, args.flag("--quiet") ? ProgressFn{} : consoleProgress());
  const std::string scene = args.positional().empty() ? "phantom" : std::filesystem::path(args.positional()[0]).filename().string();
  const SimScene sc = buildSimScene(loaded.image, {SimHandle{loaded.handle, {RigidTransform{}}}}, s);
  const CutPlacement at = placeBeside(sc, loaded.image);
  std::cout << std::fixed << std::setprecision(1) << "cuts beside " << scene << "'s handle (x " << at.organ.min().x() << " to " << at.organ.max().x()
            << " mm; the region " << sc.lo.x() << " to " << sc.hi.x() << ") at x = " << at.x << " mm (" << sc.meshes.fine.tets.size() << " fine tets, median of "
            << repeat << "):\n";
  const double retractMm = args.number("--retract-mm", 10.0, 0.0, 100.0);
  CoarseModel uncut(sc.meshes, sc.fineK, sc.constraints);  // sc stays uncut: each cut is made on a copy
  const double uncutFrameMs = frameMs(uncut, sc.handleCentroid[0]);
  std::cout << "  the uncut coarse model's frame: " << std::setprecision(2) << uncutFrameMs << " ms\n" << std::setprecision(1);
  std::ofstream csv(out / "cut_timing.csv");
  csv << "scene,fine_tets,length_mm,depth_mm,cut_faces,copied_nodes,mesh_cut_ms,scene_cut_ms,coarse_build_ms,coarse_update_ms,added_elements,added_coarse_nodes,frame_ms,"
         "uncut_frame_ms,retract_force_N\n";
  for (int d : depths)
    for (int l : lengths) {
      const CutQuad q = sagittalQuad(at, l, d);
      CutTiming t;
      CoarseCut c;
      double force = std::nan("");
      try {
        t = timeCut(sc, q, repeat);
      } catch (const Error& e) {  // a refused cut is a result (e.g. narrower than the mesh's faces): said, and the rest go on
        std::cout << "  " << l << " x " << d << " mm: refused: " << e.what() << "\n";
        csv << scene << "," << sc.meshes.fine.tets.size() << "," << l << "," << d << ",0,0,nan,nan,nan,nan,0,0,nan," << uncutFrameMs << ",nan\n";
        continue;
      }
      SimScene cut = sc;  // the cut is made: its coarse model is a result, not a refusal
      cutScene(cut, {q});
      c = coarseOfCut(uncut, cut);
      try {
        if (retractMm > 0.0) force = retractForce(uncut, cut, q, retractMm);  // the last use of `cut`: its lip becomes a handle
      } catch (const Error& e) {  // the cut stands; its lip could not be retracted (no free tissue there)
        std::cout << "  " << l << " x " << d << " mm: no retractor: " << e.what() << "\n";
      }
      csv << scene << "," << sc.meshes.fine.tets.size() << "," << l << "," << d << "," << t.faces << "," << t.copied << "," << t.meshMs << "," << t.sceneMs
          << "," << c.buildMs << "," << c.updateMs << "," << c.addedElements << "," << c.addedNodes << "," << c.frameMs << "," << uncutFrameMs << "," << force << "\n";
      std::cout << "  " << l << " x " << d << " mm: " << t.faces << " faces separated, " << t.copied << " nodes copied, mesh cut " << t.meshMs
                << " ms, scene cut " << t.sceneMs << " ms; coarse model " << c.updateMs << " ms updated (" << c.buildMs << " built whole; " << c.addedElements << " elements added by split cells, " << c.addedNodes
                << " coarse nodes added), frame " << std::setprecision(2) << c.frameMs << " ms (" << c.frameMs / uncutFrameMs << "x)"
                << std::setprecision(1) << "; its lip pulled " << retractMm << " mm: " << force << " N\n";
    }
  csv.close();
  chart(out, std::vector<double>(depths.begin(), depths.end()));
  std::cout << "wrote " << (out / "cut_timing.csv").string() << "\n";
  return 0;
}

}  // namespace handson::cli
