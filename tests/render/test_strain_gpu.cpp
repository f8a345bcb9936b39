// The strain passes (deform_strain.comp and deform_strain_raster.comp, GpuDeformer::addStrainPass)
// against their CPU references, tetStrain and strainVolume (sim/strain.h), and against exact answers: homogeneous deformations of the whole fine
// mesh (a rigid turn: 0; a 10 % stretch: 0.1 in every tet), the kidney dragged and turned by the
// coarse model; a non-finite position refused; the raymarch's strain overlay against its CPU
// reference; and the strain-over-limit volume and its highlight against theirs (strainOverLimitVolume,
// raymarchReference), with bad limits refused. Lavapipe with the validation layer.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "deform_fixture.h"
#include "gpu_test_env.h"
#include "interaction/camera.h"
#include "render/deform_pass.h"
#include "render/raymarch_reference.h"
#include "render/render_params.h"
#include "render/transfer_function.h"
#include "render/volume_renderer.h"
#include "render/vk_resources.h"
#include "sim/coarsening.h"
#include "sim/base/error.h"
#include "sim/phantom.h"
#include "sim/quantized_volume.h"
#include "sim/sim_scene.h"
#include "sim/strain.h"
#include "sim/tet_raster.h"
#include "sim/tissue_limits.h"

using namespace handson;

namespace {

using Fixture = test::DeformFixture;
const Fixture& fixture() { return test::deformFixture(); }

class StrainGpu : public test::GpuTest {
 protected:
  // The GPU's strain for world positions x, and the CPU reference on the same (float, index-space)
  // positions taken back to world.
  void run(const std::vector<Eigen::Vector3d>& x, std::vector<float>& gpu, std::vector<float>& cpu, std::vector<float>* gpuVolume = nullptr,
           Volume* cpuVolume = nullptr) {
    const Fixture& f = fixture();
    const test::Images im = test::upload(f.q, f.mask);
    const vk::DeformSetup s = test::setupFor(f, f.data, f.scene.meshes.fine.tets, f.scene.lo, f.scene.hi);
    vk::GpuDeformer deformer(test::gpuContext(), im.volume, im.mask, s);
    const Eigen::Matrix4d w2i = s.worldToIndex, i2w = w2i.inverse();
    std::vector<Eigen::Vector4f> idx(x.size());
    std::vector<Eigen::Vector3d> back(x.size());
    for (std::size_t i = 0; i < x.size(); ++i) {
      idx[i] = (w2i * x[i].homogeneous()).cast<float>();
      idx[i].w() = 1.0f;
      back[i] = (i2w * idx[i].cast<double>()).head<3>();
    }
    gpu = deformer.runStrain(idx);
    cpu = tetStrain(f.scene.meshes.fine, back);
    if (gpuVolume) *gpuVolume = deformer.readStrainVolume();
    if (cpuVolume) {
      Volume deformed;
      std::vector<std::int32_t> tetOf;
      rasterizeDeformed(f.phantom.ct, f.scene.meshes.fine, back, {f.scene.lo, f.scene.hi, f.backgroundHu}, deformed, {nullptr, nullptr, UINT64_MAX, &tetOf, {}});
      *cpuVolume = strainVolume(f.phantom.ct.geometry(), tetOf, cpu);
    }
  }
};

// The fine positions of the kidney dragged 10 mm and turned 30 degrees by the coarse model (20 iterations).
std::vector<Eigen::Vector3d> kidneyDrag(const Fixture& f) {
  const std::vector<RigidTransform> T = {
      RigidTransform::about(f.scene.handleCentroid[0], Eigen::Vector3d(0, 0, 30 * M_PI / 180), Eigen::Vector3d(10, 0, 0))};
  auto xc = f.model->restState();
  f.model->solve(T, xc, 20);
  return f.model->reconstruct(T, xc);
}

// Pixels of a tinted frame off its CPU reference by more than 2/255, and pixels the tint changed
// by more than 8/255 from the plain frame (RGBA8, alpha ignored).
std::pair<std::size_t, std::size_t> offAndColoured(const std::vector<std::uint8_t>& cpu, const std::vector<std::uint8_t>& tinted,
                                                   const std::vector<std::uint8_t>& plain) {
  std::size_t over = 0, coloured = 0;
  for (std::size_t i = 0; i + 3 < cpu.size(); i += 4) {
    int d = 0, c = 0;
    for (int k = 0; k < 3; ++k) {
      d = std::max(d, std::abs(int(cpu[i + k]) - int(tinted[i + k])));
      c = std::max(c, std::abs(int(plain[i + k]) - int(tinted[i + k])));
    }
    over += d > 2;
    coloured += c > 8;
  }
  return {over, coloured};
}

// Worst |gpu - cpu| over tets where both are finite; the count where exactly one is NaN.
std::pair<double, int> compare(const std::vector<float>& gpu, const std::vector<float>& cpu) {
  double worst = 0;
  int mismatchedNaN = 0;
  for (std::size_t t = 0; t < cpu.size(); ++t) {
    if (std::isnan(gpu[t]) != std::isnan(cpu[t])) ++mismatchedNaN;
    else if (!std::isnan(cpu[t])) worst = std::max(worst, double(std::abs(gpu[t] - cpu[t])));
  }
  return {worst, mismatchedNaN};
}

}  // namespace

// Single precision on edges of a few voxels at coordinates up to ~100 voxels (rest positions ~200
// mm): ~1e-6 relative per coordinate, up to ~1e-5 relative per edge. Measured on lavapipe: 3.6e-6
// (rigid turn), 2.6e-6 (the stretch, against 0.1 exactly), 1.6e-5 (the kidney drag, against the
// CPU). 1e-4 (a stretch of 0.01 %) leaves room for another device's arithmetic, and is far below
// what an overlay resolves.
constexpr double kTolerance = 1e-4;

TEST_F(StrainGpu, HomogeneousDeformationsExactly) {
  const Fixture& f = fixture();
  const auto& X = f.scene.meshes.fine.nodes;
  const Eigen::Vector3d c = f.scene.handleCentroid[0];
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.6, Eigen::Vector3d(1, 2, -0.5).normalized()).toRotationMatrix();
  const Eigen::Matrix3d stretch = turn * Eigen::Vector3d(1.1, 1.0, 0.97).asDiagonal();
  for (const auto& [A, expected] : {std::pair{turn, 0.0}, std::pair{stretch, 0.1}}) {
    std::vector<Eigen::Vector3d> x(X.size());
    for (std::size_t i = 0; i < X.size(); ++i) x[i] = c + A * (X[i] - c) + Eigen::Vector3d(3, -2, 5);
    std::vector<float> gpu, cpu;
    run(x, gpu, cpu);
    ASSERT_EQ(gpu.size(), f.scene.meshes.fine.tets.size());
    double worst = 0;
    for (float s : gpu) worst = std::max(worst, std::abs(double(s) - expected));
    EXPECT_LT(worst, kTolerance) << "expected " << expected;
    EXPECT_LT(compare(gpu, cpu).first, kTolerance);
  }
}

TEST_F(StrainGpu, KidneyDragMatchesTheCpuReference) {
  const Fixture& f = fixture();
  const std::vector<Eigen::Vector3d> x = kidneyDrag(f);
  std::vector<float> gpu, cpu, gpuVolume;
  Volume cpuVolume;
  run(x, gpu, cpu, &gpuVolume, &cpuVolume);
  const auto [worst, nanMismatch] = compare(gpu, cpu);
  EXPECT_LT(worst, kTolerance);
  EXPECT_EQ(nanMismatch, 0);
  // The strain volume: each voxel the strain of the tet that covers it, 0 outside the region. A
  // voxel on a face shared by two tets may go to either side in single precision (the deformed
  // image's own test allows 0.1 % such voxels), so: 99.9 % within the tolerance.
  ASSERT_EQ(gpuVolume.size(), cpuVolume.voxelCount());
  std::size_t same = 0, nonzero = 0;
  for (std::size_t i = 0; i < gpuVolume.size(); ++i) {
    same += std::abs(gpuVolume[i] - cpuVolume.value(i)) <= kTolerance ? 1 : 0;
    nonzero += cpuVolume.value(i) != 0.0f ? 1 : 0;
  }
  EXPECT_GE(double(same) / double(gpuVolume.size()), 0.999);
  EXPECT_GT(nonzero, gpuVolume.size() / 100) << "the region covers part of the volume";
  float largest = 0;
  for (float s : cpu) largest = std::max(largest, s);
  EXPECT_GT(largest, 0.05f) << "the drag stretches some tissue";
}

// A non-finite position never reaches the pass: the upload refuses it with a clear error.
TEST_F(StrainGpu, ANonFinitePositionIsRefused) {
  const Fixture& f = fixture();
  std::vector<Eigen::Vector3d> x = f.scene.meshes.fine.nodes;
  x[x.size() / 2] = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  std::vector<float> gpu, cpu;
  try {
    run(x, gpu, cpu);
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("not finite"), std::string::npos) << e.what();
  }
}

// The overlay in the frame: the renderer deforms (refined positions of the kidney drag), computes
// the strain and raymarches with it in one graph; the frame equals the CPU raymarch of the GPU's
// deformed volume, mask and strain volume, and the overlay visibly colours the stretched tissue.
TEST_F(StrainGpu, TheRaymarchOverlayMatchesItsCpuReference) {
  const Fixture& f = fixture();
  VolumeRenderer renderer(test::gpuContext());
  renderer.setVolume(f.q);
  const auto lut = transferFunctionPreset("ct-abdomen").lookupTable(f.q);
  renderer.setTransferFunction(lut);
  renderer.beginDeformation(test::setupFor(f, f.data, f.scene.meshes.fine.tets, f.scene.lo, f.scene.hi));
  const auto fine = kidneyDrag(f);
  const Eigen::Matrix4d w2i = f.q.geometry.worldToIndex();
  std::vector<Eigen::Vector4f> idx(fine.size());
  for (std::size_t i = 0; i < fine.size(); ++i) idx[i] = (w2i * fine[i].homogeneous()).cast<float>();
  RenderSettings rs;
  rs.width = rs.height = 96;
  rs.strainTo = 0.1f;  // the drag's strains are a few per cent to tens of per cent
  const OrbitCamera cam = OrbitCamera::framing(f.q.geometry, glm::radians(0.0), glm::radians(-90.0));
  auto frame = [&](bool overlay) {
    rs.strainOverlay = overlay;
    FrameRequest req;
    req.params = makeRenderParams(f.q.geometry, cam.view(), cam.projection(1.0), glm::vec3(cam.eye()), rs);
    req.deformFine = &idx;
    renderer.submit(req);
    return std::pair{renderer.waitLast(), req.params};
  };
  const auto [plain, plainParams] = frame(false);
  const auto [tinted, params] = frame(true);
  QuantizedVolume dq = f.q;
  dq.data = renderer.deformer()->readVolume();
  const auto dmask = renderer.deformer()->readMask();
  const std::vector<float> strain = renderer.deformer()->readStrainVolume();
  ReferenceScene ref{&dq, &lut, &renderer.occupancy(), &dmask, nullptr, &strain};
  const auto cpu = raymarchReference(ref, params);
  const auto [over, coloured] = offAndColoured(cpu, tinted.rgba, plain.rgba);
  // As the deformed frame's own test: filtering precision moves a few pixels by more than 2/255.
  EXPECT_LE(double(over) / double(cpu.size() / 4), 0.01) << "pixels off the CPU reference by more than 2/255";
  EXPECT_GT(coloured, 20u) << "the overlay colours the stretched tissue";
  // Off again: the frame without the overlay comes back.
  const auto [again, againParams] = frame(false);
  EXPECT_EQ(again.rgba, plain.rgba);
}

// The limit highlight: with per-tet strain limits (5 % on two tets of three, none on the third) the
// strain passes also write each voxel's strain over its limit, equal to the CPU reference
// (strainOverLimitVolume on the CPU's rasterization of the same positions); the raymarch colours
// the voxels past 1 as its CPU reference does, and the frame without the highlight comes back.
TEST_F(StrainGpu, TheStrainOverLimitVolumeAndItsHighlightMatchTheirCpuReferences) {
  const Fixture& f = fixture();
  const std::size_t nt = f.scene.meshes.fine.tets.size();
  std::vector<float> limits(nt, 0.05f);
  for (std::size_t t = 0; t < nt; t += 3) limits[t] = std::numeric_limits<float>::infinity();
  for (std::size_t t = 1; t < nt; t += 7) limits[t] = kRigidStrainLimit;  // as a sliding handle's own: strain hidden
  VolumeRenderer renderer(test::gpuContext());
  renderer.setVolume(f.q);
  const auto lut = transferFunctionPreset("ct-abdomen").lookupTable(f.q);
  renderer.setTransferFunction(lut);
  vk::DeformSetup setup = test::setupFor(f, f.data, f.scene.meshes.fine.tets, f.scene.lo, f.scene.hi);
  setup.strainLimits = &limits;
  renderer.beginDeformation(setup);
  ASSERT_TRUE(renderer.deformer()->hasStrainLimits());
  const auto fine = kidneyDrag(f);
  const Eigen::Matrix4d w2i = f.q.geometry.worldToIndex(), i2w = w2i.inverse();
  std::vector<Eigen::Vector4f> idx(fine.size());
  std::vector<Eigen::Vector3d> back(fine.size());
  for (std::size_t i = 0; i < fine.size(); ++i) {
    idx[i] = (w2i * fine[i].homogeneous()).cast<float>();
    idx[i].w() = 1.0f;
    back[i] = (i2w * idx[i].cast<double>()).head<3>();
  }
  RenderSettings rs;
  rs.width = rs.height = 96;
  const OrbitCamera cam = OrbitCamera::framing(f.q.geometry, glm::radians(0.0), glm::radians(-90.0));
  auto frame = [&](bool highlight) {
    rs.limitHighlight = highlight;
    FrameRequest req;
    req.params = makeRenderParams(f.q.geometry, cam.view(), cam.projection(1.0), glm::vec3(cam.eye()), rs);
    req.deformFine = &idx;
    renderer.submit(req);
    return std::pair{renderer.waitLast(), req.params};
  };
  const auto [plain, plainParams] = frame(false);
  const auto [lit, params] = frame(true);

  // The volume: as the strain volume's check, 99.9 % of voxels within the strain tolerance over the
  // smallest limit (a face voxel may go to either neighbouring tet in single precision).
  const std::vector<float> gpuRatio = renderer.deformer()->readStrainOverLimitVolume();
  Volume deformed;
  std::vector<std::int32_t> tetOf;
  rasterizeDeformed(f.phantom.ct, f.scene.meshes.fine, back, {f.scene.lo, f.scene.hi, f.backgroundHu}, deformed, {nullptr, nullptr, UINT64_MAX, &tetOf, {}});
  const std::vector<float> cpuStrain = tetStrain(f.scene.meshes.fine, back);
  const Volume cpuRatio = strainOverLimitVolume(f.phantom.ct.geometry(), tetOf, cpuStrain, limits);
  const Volume cpuStrainVolume = strainVolume(f.phantom.ct.geometry(), tetOf, cpuStrain);
  {  // the strain volume as shown: the rigid tets' strain hidden, as hideRigidStrain on the CPU
    std::vector<float> shown = cpuStrain;
    hideRigidStrain(shown, limits);
    const Volume cpuShown = strainVolume(f.phantom.ct.geometry(), tetOf, shown);
    const std::vector<float> gpuShown = renderer.deformer()->readStrainVolume();
    ASSERT_EQ(gpuShown.size(), cpuShown.voxelCount());
    std::size_t agree = 0, hidden = 0, shownAnyway = 0;
    for (std::size_t i = 0; i < gpuShown.size(); ++i) {
      agree += std::abs(gpuShown[i] - cpuShown.value(i)) <= kTolerance ? 1 : 0;
      if (tetOf[i] >= 0 && limits[std::size_t(tetOf[i])] == kRigidStrainLimit && cpuStrain[std::size_t(tetOf[i])] > 0.01f) {
        ++hidden;
        shownAnyway += gpuShown[i] > 0.005f ? 1 : 0;  // a face voxel may go to the neighbouring tet
      }
    }
    EXPECT_GE(double(agree) / double(gpuShown.size()), 0.999);
    EXPECT_GT(hidden, 100u) << "strained voxels of hidden tets";
    EXPECT_LE(double(shownAnyway), 0.02 * double(hidden)) << "the GPU hides them too";
  }
  ASSERT_EQ(gpuRatio.size(), cpuRatio.voxelCount());
  std::size_t same = 0, past = 0, unlimited = 0;
  for (std::size_t i = 0; i < gpuRatio.size(); ++i) {
    same += std::abs(gpuRatio[i] - cpuRatio.value(i)) <= kTolerance / 0.05 ? 1 : 0;
    past += cpuRatio.value(i) > 1.0f ? 1 : 0;
    unlimited += cpuStrainVolume.value(i) > 0.05f && cpuRatio.value(i) == 0.0f ? 1 : 0;
  }
  EXPECT_GE(double(same) / double(gpuRatio.size()), 0.999);
  EXPECT_GT(past, 100u) << "the drag stretches tissue past 5 %";
  EXPECT_GT(unlimited, 100u) << "tissue without a limit is never past it, however stretched";

  // The frame: the CPU raymarch of the GPU's deformed volume, mask and ratio volume.
  QuantizedVolume dq = f.q;
  dq.data = renderer.deformer()->readVolume();
  const auto dmask = renderer.deformer()->readMask();
  ReferenceScene ref{&dq, &lut, &renderer.occupancy(), &dmask, nullptr, nullptr, nullptr, &gpuRatio};
  const auto cpu = raymarchReference(ref, params);
  const auto [over, coloured] = offAndColoured(cpu, lit.rgba, plain.rgba);
  EXPECT_LE(double(over) / double(cpu.size() / 4), 0.01) << "pixels off the CPU reference by more than 2/255";
  EXPECT_GT(coloured, 20u) << "the highlight colours the tissue past its limit";
  const auto [again, againParams] = frame(false);
  EXPECT_EQ(again.rgba, plain.rgba);
}

// Limits that are not one positive number (or inf) per fine tet are refused before any upload.
TEST_F(StrainGpu, StrainLimitsAreChecked) {
  const Fixture& f = fixture();
  const test::Images im = test::upload(f.q, f.mask);
  vk::DeformSetup s = test::setupFor(f, f.data, f.scene.meshes.fine.tets, f.scene.lo, f.scene.hi);
  const std::size_t nt = f.scene.meshes.fine.tets.size();
  for (const std::vector<float>& bad : {std::vector<float>(nt - 1, 0.2f), std::vector<float>(nt, 0.0f),
                                        std::vector<float>(nt, std::numeric_limits<float>::quiet_NaN())}) {
    s.strainLimits = &bad;
    EXPECT_THROW(vk::GpuDeformer(test::gpuContext(), im.volume, im.mask, s), Error);
  }
}
