// The on-disk preprocessing cache: a loaded scene and coarse model behave bit for bit like the built
// ones; a second build with the same inputs loads; any change of input misses; a truncated or
// corrupt file is rebuilt, never trusted.
#include <gtest/gtest.h>

#include <algorithm>

#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "sim/base/error.h"
#include "sim/handle_reaction.h"
#include "sim/phantom.h"
#include "sim/scene_cache.h"

using namespace handson;
namespace fs = std::filesystem;

namespace {

struct Inputs {
  Phantom phantom;
  std::vector<SimHandle> handles;
  SimSettings settings;
};

const Inputs& inputs() {
  static const Inputs* in = [] {
    auto* x = new Inputs;
    PhantomOptions po;
    po.spacingMm = 4.0;
    x->phantom = makePhantom(po);
    SimHandle h;
    const auto* lab = x->phantom.labels.data<std::uint8_t>();
    for (std::size_t i = 0; i < x->phantom.labels.voxelCount(); ++i)
      if (lab[i] == label::kKidneyRight) h.voxels.push_back(std::uint32_t(i));
    x->handles = {h};
    x->settings.coarseTets = 300;
    x->settings.fineTets = 300 * 64;
    return x;
  }();
  return *in;
}

fs::path tempDir(const char* name) {
  const fs::path d = fs::temp_directory_path() / (std::string(name) + "_" + std::to_string(getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

// The coarse model's answer to a kidney motion: solve + reconstruction.
std::vector<Eigen::Vector3d> answer(CoarseModel& m, const SimScene& sc) {
  const std::vector<RigidTransform> T = {RigidTransform::about(sc.handleCentroid[0], Eigen::Vector3d(0, 0, 0.4), Eigen::Vector3d(9, 0, 0))};
  auto xc = m.restState();
  m.solve(T, xc, 10);
  return m.reconstruct(T, xc);
}

}  // namespace

class SceneCacheKinds : public ::testing::TestWithParam<SimSettings::FineMesh> {};
INSTANTIATE_TEST_SUITE_P(BothFineMeshes, SceneCacheKinds, ::testing::Values(SimSettings::FineMesh::Regular, SimSettings::FineMesh::ImageAdapted),
                         [](const auto& p) { return std::string(p.param == SimSettings::FineMesh::Regular ? "regular" : "adapted"); });

TEST_P(SceneCacheKinds, ALoadedSceneAndModelAnswerBitForBitLikeTheBuiltOnes) {
  struct Case {
    SimSettings::Region region;
    bool sliding;  // a sliding interface: its slide nodes and ghost blocks are cached too
    const char* name;
  };
  for (const Case c : {Case{SimSettings::Region::Box, false, "box region"}, Case{SimSettings::Region::Handles, false, "region shaped by the handle"},
                       Case{SimSettings::Region::Box, true, "box region, sliding"}}) {
  SCOPED_TRACE(c.name);
  const auto region = c.region;
  const bool sliding = c.sliding;
  const Inputs& in = inputs();
  SimSettings s = in.settings;
  s.fineMesh = GetParam();
  s.region = region;
  s.interface = sliding ? SimSettings::Interface::Sliding : SimSettings::Interface::Glued;
  if (region == SimSettings::Region::Handles) {  // with held cells: the box's far corners
    s.coarseTets = 1500;
    s.fineTets = 1500 * 8;
    s.paddingMm = 30.0;
  }
  const fs::path dir = tempDir("handson_cache_roundtrip");
  SimScene built;
  CacheOutcome first;
  auto m1 = buildOrLoadSimulation(in.phantom.ct, in.handles, s, built, {dir, &first});
  EXPECT_FALSE(first.hit);
  EXPECT_TRUE(first.note.empty()) << first.note;
  SimScene loaded;
  CacheOutcome second;
  auto m2 = buildOrLoadSimulation(in.phantom.ct, in.handles, s, loaded, {dir, &second});
  EXPECT_TRUE(second.hit) << second.note;
  ASSERT_EQ(loaded.meshes.fine.nodes, built.meshes.fine.nodes);
  ASSERT_EQ(loaded.meshes.fine.tets, built.meshes.fine.tets);
  EXPECT_EQ(loaded.meshes.regularFine, built.meshes.regularFine);
  EXPECT_EQ(loaded.youngs, built.youngs);
  EXPECT_EQ(loaded.constraints.handleOf, built.constraints.handleOf);
  EXPECT_EQ(loaded.constraints.fixed, built.constraints.fixed);
  ASSERT_EQ(loaded.constraints.slide.size(), built.constraints.slide.size());
  EXPECT_EQ(built.constraints.slide.empty(), !sliding);
  for (std::size_t i = 0; i < built.constraints.slide.size(); ++i) {
    EXPECT_EQ(loaded.constraints.slide[i].node, built.constraints.slide[i].node);
    EXPECT_EQ(loaded.constraints.slide[i].normal, built.constraints.slide[i].normal);
    EXPECT_EQ(loaded.constraints.slide[i].stiffness, built.constraints.slide[i].stiffness);
  }
  EXPECT_EQ(loaded.regionCell, built.regionCell);
  EXPECT_EQ(built.regionCell.empty(), region == SimSettings::Region::Box);
  if (region == SimSettings::Region::Handles) {
    EXPECT_NE(std::count(built.regionCell.begin(), built.regionCell.end(), 0), 0) << "held cells";
  }
  ASSERT_EQ(loaded.fineK.size(), built.fineK.size());
  for (std::size_t t = 0; t < built.fineK.size(); ++t) ASSERT_EQ(loaded.fineK[t], built.fineK[t]) << "tet " << t;
  EXPECT_EQ(answer(*m2, loaded), answer(*m1, built)) << "the same solve, bit for bit";
  {  // the handle's reaction too (its blocks and rest centroid come from the cache)
    const std::vector<RigidTransform> T = {RigidTransform::about(built.handleCentroid[0], Eigen::Vector3d(0.2, 0, 0), Eigen::Vector3d(0, 4, 0))};
    auto x1 = m1->restState(), x2 = m2->restState();
    m1->solve(T, x1, 5);
    m2->solve(T, x2, 5);
    const HandleReaction r1 = m1->handleReactions(T, x1)[0], r2 = m2->handleReactions(T, x2)[0];
    EXPECT_EQ(r1.forceN, r2.forceN);
    EXPECT_EQ(r1.torqueNmm, r2.torqueNmm);
    EXPECT_EQ(r1.centreMm, r2.centreMm);
    EXPECT_GT(r1.forceN.norm(), 0.0);
  }
  const auto d1 = m1->interpolationData(), d2 = m2->interpolationData();
  EXPECT_EQ(d1.node, d2.node);
  EXPECT_EQ(d1.blocks, d2.blocks);
  EXPECT_EQ(d1.elementCorners, d2.elementCorners);
  fs::remove_all(dir);
  }
}

TEST(SceneCache, AnyChangedInputMissesAndBadFilesAreRebuilt) {
  const Inputs& in = inputs();
  const std::string key = simulationCacheKey(in.phantom.ct, in.handles, in.settings);
  EXPECT_EQ(key.size(), 32u);
  EXPECT_EQ(simulationCacheKey(in.phantom.ct, in.handles, in.settings), key) << "deterministic";
  Volume other = in.phantom.ct;
  other.data<std::int16_t>()[12345] += 1;
  EXPECT_NE(simulationCacheKey(other, in.handles, in.settings), key) << "one voxel";
  auto fewer = in.handles;
  fewer[0].voxels.pop_back();
  EXPECT_NE(simulationCacheKey(in.phantom.ct, fewer, in.settings), key) << "one handle voxel";
  SimSettings s = in.settings;
  s.paddingMm += 1;
  EXPECT_NE(simulationCacheKey(in.phantom.ct, in.handles, s), key) << "padding";
  s = in.settings;
  s.element = CoarseElement::Tet;
  EXPECT_NE(simulationCacheKey(in.phantom.ct, in.handles, s), key) << "element kind";
  s = in.settings;
  s.region = SimSettings::Region::Handles;
  EXPECT_NE(simulationCacheKey(in.phantom.ct, in.handles, s), key) << "region shape";
  s = in.settings;
  s.materials = MaterialTable::parse("units,hu\nname,lower,upper,youngs_kpa,poisson\nsoft,-inf,inf,6,0.45\n", "test");
  EXPECT_NE(simulationCacheKey(in.phantom.ct, in.handles, s), key) << "material table";

  const fs::path dir = tempDir("handson_cache_bad");
  SimScene sc;
  CacheOutcome o;
  auto reference = answer(*buildOrLoadSimulation(in.phantom.ct, in.handles, in.settings, sc, {dir, &o}), sc);
  const fs::path file = dir / (key + ".hsim");
  ASSERT_TRUE(fs::exists(file));
  const auto size = fs::file_size(file);
  // Truncated, then one flipped byte in the middle: both rebuilt with a note, same answer, and the
  // entry replaced by a good one.
  for (int damage = 0; damage < 2; ++damage) {
    if (damage == 0) {
      fs::resize_file(file, size / 2);
    } else {
      std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
      f.seekg(std::streamoff(size / 2));
      char c = 0;
      f.read(&c, 1);
      c = char(c ^ 0x5a);
      f.seekp(std::streamoff(size / 2));
      f.write(&c, 1);
    }
    SimScene again;
    auto m = buildOrLoadSimulation(in.phantom.ct, in.handles, in.settings, again, {dir, &o});
    EXPECT_FALSE(o.hit);
    EXPECT_NE(o.note.find("unreadable"), std::string::npos) << o.note;
    EXPECT_EQ(answer(*m, again), reference);
    EXPECT_EQ(fs::file_size(file), size) << "replaced by a complete entry";
  }
  EXPECT_THROW(loadSimulation(dir / "missing.hsim", sc), Error);
  // An unwritable cache directory: built anyway, with a note.
  SimScene nowhere;
  buildOrLoadSimulation(in.phantom.ct, in.handles, in.settings, nowhere, {"/proc/handson-no-such-dir", &o});
  EXPECT_FALSE(o.hit);
  EXPECT_NE(o.note.find("not cached"), std::string::npos) << o.note;
  fs::remove_all(dir);
}
