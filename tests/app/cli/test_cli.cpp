// The handson command line on good and bad input: exit status and one clear message, no crash.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <array>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "app/io/nifti_io.h"
#include "app/io/png_io.h"
#include "tests/app/run_handson.h"

namespace fs = std::filesystem;

namespace {

using CliRun = handson::test::HandsonRun;
using handson::test::runHandson;

class Cli : public ::testing::Test {
 protected:
  fs::path dir;
  void SetUp() override {
    dir = fs::temp_directory_path() / ("handson_cli_" + std::to_string(::getpid()) + "_" +
                                       ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }
  std::string p(const char* name) const { return (dir / name).string(); }
};

}  // namespace

TEST_F(Cli, HelpEverywhere) {
  for (const char* c : {"--help", "info --help", "render --help", "pick --help", "phantom --help", "resample --help", "bench --help"}) {
    const CliRun r = runHandson(c);
    EXPECT_EQ(r.status, 0) << c;
    EXPECT_NE(r.output.find("usage"), std::string::npos) << c;
  }
}

TEST_F(Cli, TheWindowAndTheReplayTakeTheSameSessionOptions) {
  // One set of session options, parsed once: each is accepted by both modes (with --help, nothing
  // runs) and described in both helps. `view --selection-corrections` had been refused as unknown.
  const char* const shared[] = {"--frame 0", "--labels l.nii.gz", "--timings t.csv", "--export-dir d", "--export-format nrrd", "--selection-backend cpu",
                                "--selection-rim off", "--selection-bound ball", "--selection-corrections grown", "--device x", "--frames 3",
                                "--validation", "--quiet", "--print-camera", "--sim-interface glued"};
  for (const char* mode : {"view", "replay"})
    for (const char* option : shared) {
      const CliRun r = runHandson(std::string(mode) + " " + option + " --help");
      EXPECT_EQ(r.status, 0) << mode << " " << option << ": " << r.output;
      const std::string name = std::string(option).substr(0, std::string(option).find(' '));
      EXPECT_NE(r.output.find(name), std::string::npos) << mode << " --help does not describe " << name;
    }
}

TEST_F(Cli, PhantomRoundTripsThroughInfo) {
  const CliRun w = runHandson("phantom -o " + p("ct.nii.gz") + " --labels-out " + p("labels.nii.gz") + " --spacing 8");
  ASSERT_EQ(w.status, 0) << w.output;
  const CliRun i = runHandson("info " + p("ct.nii.gz"));
  ASSERT_EQ(i.status, 0) << i.output;
  EXPECT_NE(i.output.find("48 x 36 x 30"), std::string::npos) << i.output;
  EXPECT_NE(i.output.find("int16"), std::string::npos);
  const handson::Volume labels = handson::readNifti(p("labels.nii.gz"));
  EXPECT_EQ(labels.type(), handson::ScalarType::UInt8);
}

TEST_F(Cli, RenderWritesAPngOfTheRequestedSize) {
  const CliRun r = runHandson("render -o " + p("f.png") + " --size 48x32 --validation --quiet");
  ASSERT_EQ(r.status, 0) << r.output;
  int w = 0, h = 0;
  const auto px = handson::readPng(p("f.png"), w, h);
  EXPECT_EQ(w, 48);
  EXPECT_EQ(h, 32);
  EXPECT_EQ(r.output.find("validation"), std::string::npos) << r.output;
}

TEST_F(Cli, PickReportsHitsAndMisses) {
  const CliRun r = runHandson("pick --at '32,32;0,0' --size 64x64 --json --quiet");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("{\"x\":32.000,\"y\":32.000,\"hit\":true"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("{\"x\":0.000,\"y\":0.000,\"hit\":false}"), std::string::npos) << r.output;
}

TEST_F(Cli, BadInputGivesOneClearMessageAndNonZeroExit) {
  std::ofstream(p("garbage.nii")) << "this is not a NIfTI file at all, just some text padding padding padding";
  {
    std::ofstream t(p("truncated.nii.gz"), std::ios::binary);
    t << "\x1f\x8b\x08";
  }
  fs::create_directories(dir / "empty-dir");
  ASSERT_EQ(runHandson("phantom -o " + p("ct.nii.gz") + " --spacing 8").status, 0);
  struct Case {
    std::string args;
    int status;
    const char* mentions;
  } cases[] = {
      {"info " + p("missing.nii.gz"), 1, "does not exist"},
      {"info " + p("garbage.nii"), 1, "garbage.nii"},
      {"info " + p("truncated.nii.gz"), 1, "truncated.nii.gz"},
      {"info " + (dir / "empty-dir").string(), 1, "DICOM"},
      {"info", 2, "usage"},
      {"frobnicate", 2, "unknown command"},
      {"render --size 0x10 -o " + p("x.png"), 2, "--size"},
      {"render --size 64x64 --camera a,b -o " + p("x.png"), 2, "--camera"},
      {"pick --at 8,8 --size 16x16 --faint-threshold 1.5", 2, "--faint-threshold"},
      {"render --preset nope -o " + p("x.png"), 1, "unknown transfer-function preset"},
      {"render --size 16x16 -o /nonexistent-dir/x.png --quiet", 1, "does not exist"},
      {"render --device no-such-gpu --size 16x16 -o " + p("x.png"), 1, "no Vulkan device matches"},
      {"phantom -o " + p("p.nii.gz") + " --spacing nan", 2, "--spacing"},
      {"resample " + p("missing.nii") + " --voxels 1000 -o " + p("r.nii.gz"), 1, "does not exist"},
      {"pick --at 1,2,3", 2, "--at"},
      {"select " + p("ct.nii.gz") + " --seed-voxel 500,1,1 --extent-mm 10 -o " + p("m.nii.gz"), 1, "outside the volume"},
      {"select " + p("ct.nii.gz") + " --seed-voxel 0,0,0 --extent-mm 10 -o " + p("m.nii.gz"), 1, "air"},
      {"select " + p("ct.nii.gz") + " --seed-voxel 24,18,15 --extent-mm 0 -o " + p("m.nii.gz"), 2, "--extent-mm"},
      {"select " + p("ct.nii.gz") + " --seed-voxel 24,18,15 --extent-mm nan -o " + p("m.nii.gz"), 2, "--extent-mm"},
      {"select " + p("ct.nii.gz") + " --seed-mm 1e9,0,0 --extent-mm 5 -o " + p("m.nii.gz"), 1, "outside the volume"},
      {"select " + p("ct.nii.gz") + " --seed-voxel 1.5,2,3 --extent-mm 5 -o " + p("m.nii.gz"), 2, "integers"},
      {"select " + p("ct.nii.gz") + " --seed-voxel 24,18,15 --extent-mm 5 --statistics median -o " + p("m.nii.gz"), 2, "--statistics"},
      {"select " + p("ct.nii.gz") + " --seed-voxel 24,18,15 --extent-mm 5 --bound geodesic -o " + p("m.nii.gz"), 2, "--bound"},
  };
  for (const auto& c : cases) {
    const CliRun r = runHandson(c.args);
    EXPECT_EQ(r.status, c.status) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find(c.mentions), std::string::npos) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find("error"), std::string::npos) << c.args;
  }
  EXPECT_FALSE(fs::exists(p("x.png")));  // no half-written outputs
  EXPECT_FALSE(fs::exists(p("m.nii.gz")));
}

TEST_F(Cli, SelectWritesAMaskOnTheInputGridWithCpuAndGpuAgreeing) {
  ASSERT_EQ(runHandson("phantom -o " + p("ct.nii.gz") + " --labels-out " + p("labels.nii.gz") + " --spacing 6").status, 0);
  // The right kidney's centre in RAS mm (sim/phantom.h): (78, -55, -14).
  for (const char* backend : {"cpu", "gpu"}) {
    const CliRun r = runHandson(std::string("select ") + p("ct.nii.gz") + " --seed-mm 78,-55,-14 --extent-mm 30 --rim off --validation --quiet --backend " +
                                backend + " -o " + p((std::string("mask-") + backend + ".nii.gz").c_str()));
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("selected"), std::string::npos) << r.output;
  }
  const handson::Volume cpu = handson::readNifti(p("mask-cpu.nii.gz"));
  const handson::Volume gpu = handson::readNifti(p("mask-gpu.nii.gz"));
  const handson::Volume labels = handson::readNifti(p("labels.nii.gz"));
  ASSERT_EQ(cpu.type(), handson::ScalarType::UInt8);
  ASSERT_EQ(cpu.dims(), labels.dims());
  EXPECT_LT((cpu.geometry().origin - labels.geometry().origin).norm(), 1e-4);
  std::size_t selected = 0, inKidney = 0;
  for (std::size_t i = 0; i < cpu.voxelCount(); ++i) {
    EXPECT_EQ(cpu.value(i), gpu.value(i));
    selected += cpu.value(i) > 0;
    inKidney += cpu.value(i) > 0 && labels.value(i) == 4.0f;
  }
  EXPECT_GT(selected, 20u);
  EXPECT_GE(double(inKidney) / double(selected), 0.9);
  // By default (--rim on) the same selection with its boundary rim, on either backend alike (a superset).
  for (const char* backend : {"cpu", "gpu"}) {
    const CliRun r = runHandson(std::string("select ") + p("ct.nii.gz") + " --seed-mm 78,-55,-14 --extent-mm 30 --quiet --backend " + backend +
                                " -o " + p((std::string("rim-") + backend + ".nii.gz").c_str()));
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("of the voxels are its boundary rim"), std::string::npos) << r.output;
  }
  const handson::Volume rimCpu = handson::readNifti(p("rim-cpu.nii.gz")), rimGpu = handson::readNifti(p("rim-gpu.nii.gz"));
  std::size_t withRim = 0;
  for (std::size_t i = 0; i < cpu.voxelCount(); ++i) {
    EXPECT_EQ(rimCpu.value(i), rimGpu.value(i));
    if (cpu.value(i) > 0) {
      EXPECT_GT(rimCpu.value(i), 0.0f);
    }
    withRim += rimCpu.value(i) > 0;
  }
  EXPECT_GE(withRim, selected);
  EXPECT_EQ(runHandson("select " + p("ct.nii.gz") + " --seed-mm 78,-55,-14 --extent-mm 30 --rim maybe -o " + p("x.nii.gz")).status, 2);
  // --statistics moments (the earlier rule of the refined statistics): both backends select the
  // same voxels under it as well.
  for (const char* backend : {"cpu", "gpu"}) {
    const CliRun r = runHandson(std::string("select ") + p("ct.nii.gz") + " --seed-mm 78,-55,-14 --extent-mm 30 --statistics moments --quiet --backend " +
                                backend + " -o " + p((std::string("moments-") + backend + ".nii.gz").c_str()));
    ASSERT_EQ(r.status, 0) << r.output;
  }
  const handson::Volume momCpu = handson::readNifti(p("moments-cpu.nii.gz")), momGpu = handson::readNifti(p("moments-gpu.nii.gz"));
  std::size_t momSelected = 0;
  for (std::size_t i = 0; i < momCpu.voxelCount(); ++i) {
    EXPECT_EQ(momCpu.value(i), momGpu.value(i));
    momSelected += momCpu.value(i) > 0;
  }
  EXPECT_GT(momSelected, 20u);
  // --bound ball (the earlier rule): both backends agree under it too, and it selects at least the
  // default path bound's voxels (the geodesic ball of the same extent lies inside the ball).
  for (const char* backend : {"cpu", "gpu"}) {
    const CliRun r = runHandson(std::string("select ") + p("ct.nii.gz") + " --seed-mm 78,-55,-14 --extent-mm 30 --bound ball --quiet --backend " +
                                backend + " -o " + p((std::string("ball-") + backend + ".nii.gz").c_str()));
    ASSERT_EQ(r.status, 0) << r.output;
  }
  const handson::Volume ballCpu = handson::readNifti(p("ball-cpu.nii.gz")), ballGpu = handson::readNifti(p("ball-gpu.nii.gz"));
  const handson::Volume pathCpu = handson::readNifti(p("rim-cpu.nii.gz"));  // the default: path bound, with the rim
  std::size_t ballSelected = 0, pathSelected = 0;
  for (std::size_t i = 0; i < ballCpu.voxelCount(); ++i) {
    EXPECT_EQ(ballCpu.value(i), ballGpu.value(i));
    ballSelected += ballCpu.value(i) > 0;
    pathSelected += pathCpu.value(i) > 0;
  }
  EXPECT_GE(ballSelected, pathSelected);
  EXPECT_GT(pathSelected, 20u);
}

TEST_F(Cli, RenderClipsAndRefusesMalformedClipValues) {
  const std::string common = "render --size 48x48 --validation --quiet --camera 90,0 -o ";
  ASSERT_EQ(runHandson(common + p("plain.png")).status, 0);
  CliRun r = runHandson(common + p("plane.png") + " --clip-plane -1,0,0,-60");
  ASSERT_EQ(r.status, 0) << r.output;
  r = runHandson(common + p("box.png") + " --clip-box -40,-120,-200,40,-30,200");
  ASSERT_EQ(r.status, 0) << r.output;
  int w = 0, h = 0;
  const auto a = handson::readPng(p("plain.png"), w, h), b = handson::readPng(p("plane.png"), w, h), c = handson::readPng(p("box.png"), w, h);
  EXPECT_NE(a, b);
  EXPECT_NE(a, c);
  // Without a camera distance the clip is framed: what it leaves of the volume spans at least 60 %
  // of the view's shorter side (measured: the rows and columns holding anything drawn, against the
  // background in the corner), more than the same box seen from 600 mm.
  ASSERT_EQ(runHandson("render --size 64x48 --quiet --camera 90,0,600 -o " + p("box-far.png") + " --clip-box -40,-120,-200,40,-30,200").status, 0);
  ASSERT_EQ(runHandson("render --size 64x48 --quiet --camera 90,0 -o " + p("box-framed.png") + " --clip-box -40,-120,-200,40,-30,200").status, 0);
  auto drawnSpan = [&](const std::string& file) {
    int pw = 0, ph = 0;
    const auto px = handson::readPng(file, pw, ph);
    int x0 = pw, x1 = -1, y0 = ph, y1 = -1;
    for (int y = 0; y < ph; ++y)
      for (int x = 0; x < pw; ++x) {
        int diff = 0;
        for (int k = 0; k < 3; ++k) diff += std::abs(int(px[std::size_t(4 * (y * pw + x) + k)]) - int(px[std::size_t(k)]));
        if (diff <= 12) continue;
        x0 = std::min(x0, x);
        x1 = std::max(x1, x);
        y0 = std::min(y0, y);
        y1 = std::max(y1, y);
      }
    return std::max(x1 - x0 + 1, y1 - y0 + 1);
  };
  const int framed = drawnSpan(p("box-framed.png")), far = drawnSpan(p("box-far.png"));
  EXPECT_GE(framed, int(0.6 * 48)) << far;
  EXPECT_GT(framed, far + 8);
  for (const char* bad : {"--clip-box 1,2,3", "--clip-box 10,0,0,0,1,1", "--clip-box 0,0,0,1,1,nan", "--clip-plane 0,0,0,5", "--clip-plane 1,0,0"}) {
    r = runHandson(common + p("bad.png") + " " + bad);
    EXPECT_EQ(r.status, 2) << bad << "\n" << r.output;
    EXPECT_NE(r.output.find("--clip"), std::string::npos) << bad << "\n" << r.output;
  }
  EXPECT_FALSE(fs::exists(p("bad.png")));
}

TEST_F(Cli, SelectWithLabelsWritesTheLabelledOrganUnderTheSeedExactly) {
  ASSERT_EQ(runHandson("phantom -o " + p("ct.nii.gz") + " --labels-out " + p("labels.nii.gz") + " --spacing 6").status, 0);
  ASSERT_EQ(runHandson("phantom -o " + p("ct8.nii.gz") + " --labels-out " + p("labels8.nii.gz") + " --spacing 8").status, 0);
  CliRun r = runHandson("select " + p("ct.nii.gz") + " --labels " + p("labels.nii.gz") + " --seed-mm 78,-55,-14 --quiet -o " + p("kidney.nii.gz"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("label 4's connected component"), std::string::npos) << r.output;
  const handson::Volume labels = handson::readNifti(p("labels.nii.gz"));
  const handson::Volume mask = handson::readNifti(p("kidney.nii.gz"));
  ASSERT_TRUE(mask.geometry().sameGrid(labels.geometry()));
  for (std::size_t i = 0; i < mask.voxelCount(); ++i) ASSERT_EQ(mask.value(i) > 0, labels.value(i) == 4.0f) << i;
  // Labels on another grid of the same space: resampled by nearest neighbour, with a warning; the
  // kidney then matches its own 6 mm labels to within the 8 mm grid's staircase.
  r = runHandson("select " + p("ct.nii.gz") + " --labels " + p("labels8.nii.gz") + " --seed-mm 78,-55,-14 --quiet -o " + p("kidney8.nii.gz"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("warning:"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("nearest neighbour"), std::string::npos) << r.output;
  const handson::Volume mask8 = handson::readNifti(p("kidney8.nii.gz"));
  std::size_t both = 0, a = 0, b = 0;
  for (std::size_t i = 0; i < mask8.voxelCount(); ++i) {
    a += mask8.value(i) > 0;
    b += labels.value(i) == 4.0f;
    both += mask8.value(i) > 0 && labels.value(i) == 4.0f;
  }
  EXPECT_GT(2.0 * double(both) / double(a + b), 0.8);
  // Refused, with a clear message: a seed on background, a label map that is no label map, one
  // elsewhere in space, growth options beside --labels.
  r = runHandson("select " + p("ct.nii.gz") + " --labels " + p("labels.nii.gz") + " --seed-voxel 0,0,0 -o " + p("x.nii.gz"));
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("background"), std::string::npos) << r.output;
  r = runHandson("select " + p("ct.nii.gz") + " --labels " + p("ct.nii.gz") + " --seed-voxel 5,5,5 -o " + p("x.nii.gz"));
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("whole numbers"), std::string::npos) << r.output;
  handson::Volume far = handson::readNifti(p("labels8.nii.gz"));
  far.geometry().origin += Eigen::Vector3d(1000, 0, 0);
  handson::writeNifti(far, p("far.nii.gz"));
  r = runHandson("select " + p("ct.nii.gz") + " --labels " + p("far.nii.gz") + " --seed-voxel 5,5,5 -o " + p("x.nii.gz"));
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("does not overlap"), std::string::npos) << r.output;
  r = runHandson("select " + p("ct.nii.gz") + " --labels " + p("labels.nii.gz") + " --seed-voxel 5,5,5 --extent-mm 20 -o " + p("x.nii.gz"));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("--extent-mm"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(p("x.nii.gz")));
}

TEST_F(Cli, GestureSolveReadsJsonAndRecoversAMotion) {
  // Two fingers at depth 400 mm move by a known twist and translation; LM recovers them.
  std::ofstream(p("case.json")) << R"({"projection": [[2.1, 0, 0], [0, 3.17, 0]],
    "points": [[0, 0, 400], [50, 0, 400]], "targets": [[0.01, 0], [0.27, 0.01]], "solver": "lm"})";
  CliRun r = runHandson("gesture-solve --input " + p("case.json"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("\"rotation\":[["), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("\"translation\":["), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("\"ok\":true"), std::string::npos) << r.output;
  const std::pair<const char*, const char*> bad[] = {
      {"{nope", "not valid JSON"},
      {R"({"projection": [[1, 0, 0]], "points": [[0, 0, 1]], "targets": [[0, 0]]})", "2x3"},
      {R"({"projection": [[1, 0, 0], [0, 1, 0]], "points": [[0, 0, 1]], "targets": []})", "same length"},
      {R"({"projection": [[1, 0, 0], [0, 1, 0]], "points": [[0, 0]], "targets": [[0, 0]]})", "[x, y, z]"},
      {R"({"projection": [[1, 0, 0], [0, 1, 0]], "points": [[0, 0, 1]], "targets": [[0, 0]], "locks": ["spin"]})", "unknown lock"},
      {R"({"projection": [[1, 0, 0], [0, 1, 0]], "points": [[0, 0, 1]], "targets": [[0, 0]], "solver": "magic"})", "solver"},
      {R"({"projection": [[1, 0, 0], [0, 1, 0]], "points": [[0, 0, -1]], "targets": [[0, 0]]})", "behind the camera"},
  };
  for (const auto& [text, mention] : bad) {
    std::ofstream(p("bad.json")) << text;
    r = runHandson("gesture-solve --input " + p("bad.json"));
    EXPECT_EQ(r.status, 1) << text;
    EXPECT_NE(r.output.find(mention), std::string::npos) << text << "\n" << r.output;
  }
}

TEST_F(Cli, DeformCutsTheTissueForBothModelsAndRefusesBadCuts) {
  // A plane through the kidney across the region (--cut-quad): the fine reference's 6 mm move takes
  // less force than uncut, and the opening the cut leaves is not covered by the deformed tets; the
  // coarse model, built on the cut scene, takes less force than uncut too, and refined 10 steps it
  // gives the fine reference's force within 1 % and the same opening; with a retractor, on the GPU
  // and the CPU alike. Refused: a retractor with no
  // cut, eleven numbers, corners off one plane (usage, 2), a quad that misses the tissue, a cut for
  // the coarse tet elements, which do not see cuts (1).
  ASSERT_EQ(runHandson("phantom -o " + p("ct.nii.gz") + " --labels-out " + p("labels.nii.gz") + " --spacing 5 --noise 0").status, 0);
  const std::string common = "deform " + p("ct.nii.gz") + " --handle " + p("labels.nii.gz") +
                             " --handle-label 4 --coarse-tets 300 --fine-tets 8100 --quiet --translate-mm 0,0,6 -o " + p("d.nii.gz") + " ";
  const std::string plane = " --cut-quad 80,-300,-300,80,300,-300,80,300,300,80,-300,300";
  auto forceZ = [&](const std::string& json) {
    std::ifstream f(json);
    const std::string text((std::istreambuf_iterator<char>(f)), {});
    const auto at = text.find("\"force_N\": [");
    return at == std::string::npos ? 0.0 : std::strtod(text.c_str() + text.find(',', text.find(',', at) + 1) + 1, nullptr);
  };
  CliRun r = runHandson(common + "--model fine --forces-out " + p("uncut.json"));
  ASSERT_EQ(r.status, 0) << r.output;
  r = runHandson(common + "--model fine --forces-out " + p("cut.json") + plane);
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(r.has("cut: 1 quad(s), ")) << r.output;
  const double uncut = forceZ(p("uncut.json")), cut = forceZ(p("cut.json"));
  std::printf("craniocaudal force: uncut %.3f N, cut %.3f N\n", uncut, cut);
  EXPECT_LT(uncut, 0.0) << "the tissue pulls the kidney back";
  EXPECT_LT(std::abs(cut), 0.95 * std::abs(uncut));
  const auto covered = r.output.find(", covered ");
  const auto region = r.output.find("region voxels ");
  ASSERT_NE(covered, std::string::npos);
  EXPECT_LT(std::atol(r.output.c_str() + covered + 10), std::atol(r.output.c_str() + region + 14)) << "the opening: " << r.output;
  const long fineCovered = std::atol(r.output.c_str() + covered + 10);
  r = runHandson(common + "--forces-out " + p("coarse-uncut.json"));
  ASSERT_EQ(r.status, 0) << r.output;
  r = runHandson(common + "--forces-out " + p("coarse-cut.json") + plane);
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(r.has("coarse model of the cut scene: ")) << r.output;
  std::printf("the coarse model: uncut %.3f N, cut %.3f N\n", forceZ(p("coarse-uncut.json")), forceZ(p("coarse-cut.json")));
  EXPECT_LT(std::abs(forceZ(p("coarse-cut.json"))), 0.95 * std::abs(forceZ(p("coarse-uncut.json"))));
  r = runHandson(common + "--refine-steps 10 --forces-out " + p("refined.json") + plane);
  ASSERT_EQ(r.status, 0) << r.output;
  const double refined = forceZ(p("refined.json"));
  std::printf("refined on the cut mesh: %.3f N\n", refined);
  EXPECT_NEAR(refined, cut, 0.01 * std::abs(cut));
  EXPECT_EQ(std::atol(r.output.c_str() + r.output.find(", covered ") + 10), fineCovered) << r.output;
  // A retractor on the cut's lip away from the kidney (--retract-mm): a handle of its own, whose
  // reaction is the second in --forces-out, pulled back by the tissue (along the cut's normal).
  r = runHandson(common + "--model fine --retract-mm 5 --forces-out " + p("retract.json") + plane);
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(r.has("retractor: the cut's lip (")) << r.output;
  {
    std::ifstream f(p("retract.json"));
    const std::string text((std::istreambuf_iterator<char>(f)), {});
    const auto second = text.find("\"force_N\": [", text.find("\"force_N\": [") + 1);
    ASSERT_NE(second, std::string::npos) << text;
    const double fx = std::strtod(text.c_str() + second + 12, nullptr);
    std::printf("the lip pulled 5 mm: %.3f N along x\n", fx);
    EXPECT_GT(std::abs(fx), 0.1) << text;
  }
  // The coarse model with the retractor a handle of its own: the GPU passes draw the same voxels as
  // the CPU (the retractor's tets, not a rigid draw).
  long coveredBy[2] = {0, 0};
  for (const int gpu : {0, 1}) {
    r = runHandson(common + "--retract-mm 5 --validation --backend " + (gpu ? "gpu" : "cpu") + plane);
    ASSERT_EQ(r.status, 0) << r.output;
    coveredBy[gpu] = std::atol(r.output.c_str() + r.output.find(", covered ") + 10);
  }
  EXPECT_EQ(coveredBy[1], coveredBy[0]);
  for (const std::string& bad : {std::string("--model fine --retract-mm 5"), std::string("--model fine --cut-quad 1,2,3,4,5,6,7,8,9,10,11"),
                                 std::string("--model fine --cut-quad 80,-300,-300,80,300,-300,90,300,300,80,-300,300")}) {
    r = runHandson(common + bad);
    EXPECT_EQ(r.status, 2) << bad << "\n" << r.output;
    EXPECT_TRUE(r.has("--cut-quad")) << r.output;
  }
  r = runHandson(common + "--model fine --cut-quad 900,-300,-300,900,300,-300,900,300,300,900,-300,300");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_TRUE(r.has("separates no tissue")) << r.output;
  r = runHandson(common + "--coarse-element tet" + plane);
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_TRUE(r.has("do not see cuts")) << r.output;
}

TEST_F(Cli, DeformMovesTheHandleRegionOnlyAndWritesAMeshForParaView) {
  ASSERT_EQ(runHandson("phantom -o " + p("ct.nii.gz") + " --labels-out " + p("labels.nii.gz") + " --spacing 5 --noise 0").status, 0);
  const std::string common = "deform " + p("ct.nii.gz") + " --handle " + p("labels.nii.gz") + " --handle-label 4 --coarse-tets 300 --fine-tets 8100 --quiet ";
  CliRun r = runHandson(common + "--translate-mm 0,0,0 -o " + p("same.nii.gz"));
  ASSERT_EQ(r.status, 0) << r.output;
  const handson::Volume ct = handson::readNifti(p("ct.nii.gz"));
  const handson::Volume same = handson::readNifti(p("same.nii.gz"));
  ASSERT_EQ(same.dims(), ct.dims());
  double diff = 0;
  for (std::size_t i = 0; i < ct.voxelCount(); ++i) diff = std::max(diff, double(std::abs(same.value(i) - ct.value(i))));
  EXPECT_LE(diff, 1.0) << "zero motion reproduces the input within 1 HU";
  EXPECT_TRUE(r.has("tissue past its strain limit: none\n")) << r.output;

  // The coarse model, the fine reference, and the coarse model on the image-adapted (TetGen) fine mesh.
  for (const char* model : {"coarse", "fine", "coarse --fine-mesh adapted"}) {
    const std::string out = p((std::string(model).substr(0, 6) + std::to_string(std::string(model).size()) + ".nii.gz").c_str());
    r = runHandson(common + "--interface glued --model " + model + " --translate-mm 12,0,0 --rotate-deg 0,0,20 -o " + out + " --mesh-out " + p("mesh.vtu") +
                   " --forces-out " + p("forces.json") + " --strain-out " + p("strain.nii.gz"));
    ASSERT_EQ(r.status, 0) << r.output;
    // The tissue past its limit is reported (a 12 mm, 20-degree move strains soft tissue beside the
    // glued kidney past 22 % in every model), all of it put down to the one handle.
    const auto limits = r.output.find("tissue past its strain limit: ");
    ASSERT_NE(limits, std::string::npos) << r.output;
    const std::string line = r.output.substr(limits, r.output.find('\n', limits) - limits);
    EXPECT_NE(line.find("fluid-and-soft-tissue"), std::string::npos) << line;
    EXPECT_NE(line.find("), from handle 1 ("), std::string::npos) << line;
    {
      // The strain on the input's grid: stretched tissue around the moved kidney, nothing outside
      // the simulated region (the far side of the body), never a non-finite value.
      const handson::Volume st = handson::readNifti(p("strain.nii.gz"));
      ASSERT_EQ(st.dims(), handson::readNifti(p("ct.nii.gz")).dims());
      float hi = 0.0f;
      bool finite = true;
      for (std::size_t i = 0; i < st.voxelCount(); ++i) {
        hi = std::max(hi, st.value(i));
        finite = finite && std::isfinite(st.value(i));
      }
      EXPECT_TRUE(finite);
      EXPECT_GT(hi, 0.05f) << model << ": 12 mm and 20 degrees stretch the tissue beside the kidney";
      EXPECT_EQ(st.value(0, 0, 0), 0.0f) << "outside the region";
    }
    {
      // The tissue pulls the kidney back against its +12 mm in x (the handle's reaction, newtons).
      std::ifstream f(p("forces.json"));
      const std::string json((std::istreambuf_iterator<char>(f)), {});
      const auto at = json.find("\"force_N\": [");
      ASSERT_NE(at, std::string::npos) << json;
      EXPECT_LT(std::strtod(json.c_str() + at + 12, nullptr), 0.0) << model << "\n" << json;
      EXPECT_NE(json.find("\"torque_Nmm\": ["), std::string::npos) << json;
      EXPECT_NE(json.find(std::string("\"model\": \"") + (std::string(model) == "fine" ? "fine" : "coarse")), std::string::npos) << json;
    }
    EXPECT_NE(r.output.find("inverted fine tets"), std::string::npos) << r.output;
    if (std::string(model).find("adapted") != std::string::npos) {
      const auto at = r.output.find("image-adapted: ");
      ASSERT_NE(at, std::string::npos) << r.output;
      EXPECT_GT(std::atoi(r.output.c_str() + at + 15), 0) << "points were added at stiffness jumps: " << r.output;
    }
    const handson::Volume d = handson::readNifti(out);
    const handson::Volume lab = handson::readNifti(p("labels.nii.gz"));
    // The kidney's label centroid moved about +12 mm in x: compare the centroids of kidney-like HU
    // (enhanced cortex > 120 HU) within the right half of the body, before and after.
    const auto& g = ct.geometry();
    Eigen::Vector3d c0 = Eigen::Vector3d::Zero(), c1 = Eigen::Vector3d::Zero();
    double n0 = 0, n1 = 0;
    std::size_t changedFar = 0;
    for (std::size_t i = 0; i < ct.voxelCount(); ++i) {
      const Eigen::Vector3d w = g.toWorld(g.voxelOf(i).cast<double>());
      if (lab.value(i) == 4) {
        c0 += w;
        ++n0;
      }
      if (w.x() > 30 && w.y() < -20 && std::abs(d.value(i) - ct.value(i)) > 0 && d.value(i) > 120 && d.value(i) < 400) {
        c1 += w;
        ++n1;
      }
      if (std::abs(w.x()) > 0 && w.x() < -40 && d.value(i) != ct.value(i)) ++changedFar;  // the other side of the body
    }
    ASSERT_GT(n0, 0);
    ASSERT_GT(n1, 0);
    EXPECT_GT((c1 / n1).x() - (c0 / n0).x(), 4.0) << model << ": the kidney's bright voxels moved toward +x";
    EXPECT_EQ(changedFar, 0u) << model << ": nothing changes outside the simulated region";
  }
  std::ifstream vtu(p("mesh.vtu"));
  const std::string text((std::istreambuf_iterator<char>(vtu)), {});
  for (const char* name : {"UnstructuredGrid", "Name=\"displacement\"", "Name=\"dirichlet\"", "Name=\"youngs_modulus\"", "Name=\"poisson_ratio\"",
                           "Name=\"coarse_element\"", "Name=\"strain\"", "Name=\"strain_over_limit\""})
    EXPECT_NE(text.find(name), std::string::npos) << name;
  {
    // The last model's mesh: its strain over the limit passes 1 where the tissue past it was reported.
    const auto at = text.find("Name=\"strain_over_limit\"");
    ASSERT_NE(at, std::string::npos);
    std::istringstream values(text.substr(text.find('>', at) + 1, text.find("</DataArray>", at) - text.find('>', at) - 1));
    double worst = 0.0, v = 0.0;
    while (values >> v) worst = std::max(worst, v);
    EXPECT_GT(worst, 1.0) << "the mesh's tissue past its limit, as the summary reported it";
  }

  // Bad input: a usage error (2) or a clear failure (1), never a crash.
  EXPECT_EQ(runHandson("deform " + p("ct.nii.gz") + " --handle " + p("labels.nii.gz") + " -o " + p("x.nii.gz")).status, 2);
  EXPECT_EQ(runHandson(common + "--translate-mm 1,2 -o " + p("x.nii.gz")).status, 2);
  EXPECT_EQ(runHandson(common + "--translate-mm 1,0,0 --backend magic -o " + p("x.nii.gz")).status, 2);
  EXPECT_EQ(runHandson(common + "--translate-mm 1,0,0 --model magic -o " + p("x.nii.gz")).status, 2);
  EXPECT_EQ(runHandson(common + "--translate-mm 1,0,0 --interface velcro -o " + p("x.nii.gz")).status, 2);
  EXPECT_EQ(runHandson(common + "--translate-mm 1,0,0 --fine-material neo-hookean -o " + p("x.nii.gz")).status, 2) << "needs --model fine";
  EXPECT_EQ(runHandson(common + "--translate-mm 1,0,0 --model fine --fine-material rubber -o " + p("x.nii.gz")).status, 2);
  r = runHandson("deform " + p("ct.nii.gz") + " --handle " + p("labels.nii.gz") + " --handle-label 4 --translate-mm 1,0,0 --coarse-tets 2000000 " +
                 "--fine-tets 20000000 --quiet -o " + p("x.nii.gz"));
  EXPECT_EQ(r.status, 1) << "refused before allocating: " << r.output;
  r = runHandson("deform " + p("ct.nii.gz") + " --handle " + p("labels.nii.gz") + " --handle-label 77 --translate-mm 1,0,0 --quiet -o " + p("x.nii.gz"));
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("selects no voxel"), std::string::npos) << r.output;
  ASSERT_EQ(runHandson("phantom -o " + p("other.nii.gz") + " --spacing 7").status, 0);
  r = runHandson("deform " + p("ct.nii.gz") + " --handle " + p("other.nii.gz") + " --translate-mm 1,0,0 --quiet -o " + p("x.nii.gz"));
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("grid"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(p("x.nii.gz")));
}

TEST_F(Cli, DeformOnTheGpuAgreesWithTheCpuReference) {
  ASSERT_EQ(runHandson("phantom -o " + p("ct.nii.gz") + " --labels-out " + p("labels.nii.gz") + " --spacing 5").status, 0);
  const std::string common = "deform " + p("ct.nii.gz") + " --handle " + p("labels.nii.gz") +
                             " --handle-label 4 --coarse-tets 300 --fine-tets 19200 --quiet --translate-mm 10,0,0 --rotate-deg 0,0,30 ";
  // coarse: the interpolation pass from the coarse state; refined: fine positions uploaded.
  // Graded cells (hanging nodes in the state, through the same pass and the refinement's transfers).
  for (const char* extra : {"--model coarse", "--model coarse --refine-steps 2", "--model coarse --graded-split 0",
                            "--model coarse --graded-split 0 --refine-steps 2 --interface glued"}) {
    CliRun r = runHandson(common + extra + " -o " + p("cpu.nii.gz"));
    ASSERT_EQ(r.status, 0) << r.output;
    r = runHandson(common + extra + " --backend gpu --validation -o " + p("gpu.nii.gz"));
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("(gpu)"), std::string::npos) << r.output;
    const handson::Volume a = handson::readNifti(p("cpu.nii.gz"));
    const handson::Volume b = handson::readNifti(p("gpu.nii.gz"));
    ASSERT_EQ(a.dims(), b.dims());
    std::size_t within = 0, changed = 0;
    const handson::Volume ct = handson::readNifti(p("ct.nii.gz"));
    for (std::size_t i = 0; i < a.voxelCount(); ++i) {
      within += std::abs(a.value(i) - b.value(i)) <= 1.0f ? 1 : 0;
      changed += a.value(i) != ct.value(i) ? 1 : 0;
    }
    EXPECT_GT(changed, 1000u) << extra;
    EXPECT_GE(double(within) / double(a.voxelCount()), 0.999) << extra;
  }
}

TEST_F(Cli, SimulationOptionsAreCheckedBeforeAnyWork) {
  const std::pair<const char*, int> bad[] = {
      {"replay --sim maybe", 2},
      {"replay --sim-coarse-tets 0", 2},
      {"replay --sim-fine-tets 10 --sim-coarse-tets 100", 2},
      {"replay --sim-refine-steps -1", 2},
      {"replay --quiet --export /nonexistent-dir/x.nii.gz", 1},
      {"bench deform --frames 0", 2},
      {"bench deform --commit-voxels -1", 2},
      {"bench deform --coarse-element hex", 2},
      {"replay --sim-fine-mesh fancy", 2},
      {"replay --sim-graded-split 11", 2},
      {"deform /nonexistent.nii.gz --handle x.nii.gz --translate-mm 1,0,0 -o y.nii.gz --graded-split 0 --interface stuck", 2},
      {"replay --sim-graded-split 0 --sim-coarse-element tet", 2},
      {"replay --sim-graded-split 1 --sim-coarse-solver assembled", 2},
      {"deform /nonexistent.nii.gz --handle x.nii.gz --translate-mm 1,0,0 -o y.nii.gz --graded-split nan", 2},
      {"replay --sim-fine-mesh adapted --sim-coarse-element tet", 2},
      {"replay --sim-fine-mesh adapted --sim-adapt-contrast 1", 2},
      {"bench mesh --regular-list 0", 2},
      {"bench stability --angles 400", 2},
      {"bench selection --extents 0", 2},
      {"bench selection --protocol clicks", 2},
      {"bench selection --gestures 5", 2},
      {"bench selection --protocol gestures --corrections loose", 2},
      {"bench selection --protocol gestures --gestures 0", 2},
      {"bench --smoke --quick --out /tmp/handson-never-written", 2},
      {"deform /nonexistent.nii.gz --handle x.nii.gz --translate-mm 1,0,0 -o y.nii.gz --backend gpu", 1},
  };
  for (const auto& [args, status] : bad) {
    const CliRun r = runHandson(args);
    EXPECT_EQ(r.status, status) << args << "\n" << r.output;
    EXPECT_NE(r.output.find("error"), std::string::npos) << args << "\n" << r.output;
  }
}

TEST_F(Cli, DeformLoadsItsPreprocessingFromTheCacheTheSecondTime) {
  ASSERT_EQ(runHandson("phantom -o " + p("ct.nii.gz") + " --labels-out " + p("labels.nii.gz") + " --spacing 6 --noise 0").status, 0);
  const std::string common = "deform " + p("ct.nii.gz") + " --handle " + p("labels.nii.gz") + " --handle-label 4 --coarse-tets 300 --fine-tets 8100 " +
                             "--translate-mm 6,0,0 --quiet --cache-dir " + p("cache") + " -o ";
  const CliRun first = runHandson(common + p("a.nii.gz"));
  ASSERT_EQ(first.status, 0) << first.output;
  EXPECT_EQ(first.output.find("loaded from the cache"), std::string::npos) << first.output;
  const CliRun second = runHandson(common + p("b.nii.gz"));
  ASSERT_EQ(second.status, 0) << second.output;
  EXPECT_NE(second.output.find("loaded from the cache"), std::string::npos) << second.output;
  std::ifstream a(p("a.nii.gz"), std::ios::binary), b(p("b.nii.gz"), std::ios::binary);
  const std::string da((std::istreambuf_iterator<char>(a)), {}), db((std::istreambuf_iterator<char>(b)), {});
  EXPECT_EQ(da, db) << "the same deformed volume from the cached preprocessing";
  // Another resolution is another scene: a miss.
  const CliRun third = runHandson("deform " + p("ct.nii.gz") + " --handle " + p("labels.nii.gz") + " --handle-label 4 --coarse-tets 600 --fine-tets 8100 " +
                                  "--translate-mm 6,0,0 --quiet --cache-dir " + p("cache") + " -o " + p("c.nii.gz"));
  ASSERT_EQ(third.status, 0) << third.output;
  EXPECT_EQ(third.output.find("loaded from the cache"), std::string::npos) << third.output;
}
