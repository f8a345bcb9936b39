#pragma once
// The GPU deformation tests' scene (test_deform_gpu.cpp, test_strain_gpu.cpp): the phantom at 4 mm
// with its right kidney as the handle (mask id kKidneyId) and a small coarse/fine scene around it,
// built once; its images on the GPU; the deformer's set-up for it.
#include <Eigen/Core>
#include <Eigen/LU>
#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "gpu_test_env.h"
#include "render/deform_pass.h"
#include "render/vk_resources.h"
#include "sim/coarsening.h"
#include "sim/phantom.h"
#include "sim/quantized_volume.h"
#include "sim/sim_scene.h"
#include "sim/tet_raster.h"

namespace handson::test {

inline constexpr std::uint8_t kKidneyId = 3;

// The phantom at 4 mm, the right kidney as the handle (mask id kKidneyId), a small coarse/fine
// scene around it; built once.
struct DeformFixture {
  Phantom phantom;
  QuantizedVolume q;
  std::vector<std::uint8_t> mask;
  SimScene scene;
  std::unique_ptr<CoarseModel> model;
  FineInterpolationData data;
  float backgroundHu = -1000.0f;
};

inline const DeformFixture& deformFixture() {
  static const DeformFixture* f = [] {
    auto* x = new DeformFixture;
    PhantomOptions po;
    po.spacingMm = 4.0;
    x->phantom = makePhantom(po);
    x->q = quantizeVolume(x->phantom.ct);
    SimHandle h;
    const auto* lab = x->phantom.labels.data<std::uint8_t>();
    x->mask.assign(x->phantom.labels.voxelCount(), 0);
    for (std::size_t i = 0; i < x->phantom.labels.voxelCount(); ++i)
      if (lab[i] == label::kKidneyRight) {
        h.voxels.push_back(std::uint32_t(i));
        x->mask[i] = kKidneyId;
      }
    SimSettings s;
    s.coarseTets = 300;
    s.fineTets = 300 * 64;
    s.interface = SimSettings::Interface::Glued;  // the tets draw the handle (a sliding one drawn rigidly: test_deform_rigid_gpu.cpp)
    x->scene = buildSimScene(x->phantom.ct, {h}, s);
    x->model = std::make_unique<CoarseModel>(x->scene.meshes, x->scene.fineK, x->scene.constraints);
    x->data = x->model->interpolationData();
    return x;
  }();
  return *f;
}

// The deform fixture's kidney with a sliding interface (its own scene and coarse model).
struct SlidingScene {
  SimScene scene;
  std::unique_ptr<CoarseModel> model;
  FineInterpolationData data;
  std::array<Eigen::Vector3i, 2> kidneyBox;  ///< the kidney's voxels' index box (DeformSetup::rigidRestBoxes)
};

inline const SlidingScene& slidingScene() {
  static const SlidingScene* s = [] {
    const auto& f = deformFixture();
    auto* x = new SlidingScene;
    SimHandle h;
    for (std::size_t i = 0; i < f.mask.size(); ++i)
      if (f.mask[i] == kKidneyId) h.voxels.push_back(std::uint32_t(i));
    SimSettings st;
    st.coarseTets = 300;
    st.fineTets = 300 * 64;
    st.interface = SimSettings::Interface::Sliding;
    x->scene = buildSimScene(f.phantom.ct, {h}, st);
    x->model = std::make_unique<CoarseModel>(x->scene.meshes, x->scene.fineK, x->scene.constraints);
    x->data = x->model->interpolationData();
    x->kidneyBox = voxelIndexBox(f.phantom.ct.geometry(), h.voxels);
    return x;
  }();
  return *s;
}

struct Images {
  vk::Image volume, mask;
};

inline Images upload(const QuantizedVolume& q, const std::vector<std::uint8_t>& mask) {
  auto& ctx = test::gpuContext();
  const auto& d = q.geometry.dims;
  const VkImageUsageFlags usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  Images im{vk::Image(ctx, {std::uint32_t(d.x()), std::uint32_t(d.y()), std::uint32_t(d.z()), fg::Format::R16Unorm}, usage, true),
            vk::Image(ctx, {std::uint32_t(d.x()), std::uint32_t(d.y()), std::uint32_t(d.z()), fg::Format::R8Unorm}, usage, true)};
  vk::uploadToImage(ctx, im.volume, q.data.data(), q.data.size() * 2, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  vk::uploadToImage(ctx, im.mask, mask.data(), mask.size(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  return im;
}

inline vk::DeformSetup setupFor(const DeformFixture& f, const FineInterpolationData& data, const std::vector<std::array<int, 4>>& tets, const Eigen::Vector3d& lo,
                         const Eigen::Vector3d& hi) {
  vk::DeformSetup s;
  s.interpolation = &data;
  s.fineTets = &tets;
  s.regionLo = lo;
  s.regionHi = hi;
  s.background = f.q.toNormalized(f.backgroundHu);
  s.worldToIndex = f.q.geometry.worldToIndex();
  return s;
}

// The deformer's fine node positions read back, in world space (for the CPU references).
inline std::vector<Eigen::Vector3d> worldPositions(const DeformFixture& f, const vk::GpuDeformer& gpu) {
  const auto pos = gpu.readPositions();
  const Eigen::Matrix4d i2w = f.q.geometry.worldToIndex().inverse();
  std::vector<Eigen::Vector3d> world(pos.size());
  for (std::size_t i = 0; i < pos.size(); ++i) world[i] = (i2w * pos[i].cast<double>()).head<3>();
  return world;
}

}  // namespace handson::test
