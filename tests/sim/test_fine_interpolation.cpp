// The packed fine reconstruction (the GPU interpolation pass's input) against CoarseModel::reconstruct.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>

#include "sim/coarsening.h"
#include "sim/base/error.h"
#include "sim/fine_interpolation.h"
#include "sim/phantom.h"
#include "sim/sim_scene.h"

using namespace handson;

namespace {

struct Scene {
  Phantom phantom;
  SimScene scene;
};

Scene kidneyScene(SimSettings::Interface interface = SimSettings::Interface::Sliding) {
  PhantomOptions po;
  po.spacingMm = 4.0;
  Scene s{makePhantom(po), {}};
  SimHandle h;
  const auto* lab = s.phantom.labels.data<std::uint8_t>();
  for (std::size_t i = 0; i < s.phantom.labels.voxelCount(); ++i)
    if (lab[i] == label::kKidneyRight) h.voxels.push_back(std::uint32_t(i));
  SimSettings set;
  set.coarseTets = 300;
  set.fineTets = 300 * 64;
  set.interface = interface;
  s.scene = buildSimScene(s.phantom.ct, {h}, set);
  return s;
}

}  // namespace

class FineInterpolationKinds : public ::testing::TestWithParam<CoarseElement> {};
INSTANTIATE_TEST_SUITE_P(BothElementKinds, FineInterpolationKinds, ::testing::Values(CoarseElement::Cell, CoarseElement::Tet),
                         [](const auto& p) { return std::string(coarseElementName(p.param)); });

namespace {

// The packed float reference (what the GPU pass computes) against the model's own reconstruction.
void expectPackedEqualsReconstruction(const Scene& s, CoarseModel& model, std::size_t maxFrameBytes) {
  const std::vector<RigidTransform> T = {
      RigidTransform::about(s.scene.handleCentroid[0], Eigen::Vector3d(0.1, 0.2, 30.0 * M_PI / 180), Eigen::Vector3d(10, -4, 3))};
  auto xc = model.restState();
  model.solve(T, xc, 10);
  const auto expect = model.reconstruct(T, xc);
  const FineInterpolationData d = model.interpolationData();
  ASSERT_EQ(d.node.size(), expect.size());
  // Every kind the model emits occurs (4 fine cells per coarse edge: each coarse element has interior
  // nodes). Fixed fine nodes are corners or face nodes of fixed coarse nodes, never Rest records (an
  // anchored skeleton's nodes inside elements would be: this scene has none).
  std::array<int, 5> kinds{};
  for (const auto& n : d.node) ++kinds[n[0]];
  EXPECT_EQ(kinds[FineInterpolationData::Rest], 0);
  for (int k = 1; k < 5; ++k) EXPECT_GT(kinds[std::size_t(k)], 0) << "kind " << k;
  const CoarseFrameState st = packFrameState(xc, model.elementRotations(xc), T);
  EXPECT_LT(st.bytes(), maxFrameBytes) << "a frame's upload is kilobytes";
  const auto got = interpolateFineReference(d, st, Eigen::Matrix4f::Identity());
  double worst = 0;
  for (std::size_t f = 0; f < expect.size(); ++f) worst = std::max(worst, (got[f].head<3>().cast<double>() - expect[f]).norm());
  // Float arithmetic on coordinates of ~200 mm (ulp 1.5e-5 mm) through a dozen terms, and the
  // rotations rounded to float quaternions (1e-7 relative on ~50 mm lever arms).
  EXPECT_LT(worst, 2e-3) << "mm";
  std::printf("packed reconstruction: %zu fine nodes, %.1f MB static, %zu bytes a frame, worst %.2e mm\n", d.node.size(), d.staticBytes() / 1e6,
              st.bytes(), worst);
}

}  // namespace

TEST_P(FineInterpolationKinds, PackedFloatReferenceEqualsTheModelsReconstruction) {
  const Scene s = kidneyScene();
  CoarseModel model(s.scene.meshes, s.scene.fineK, s.scene.constraints, {}, GetParam());
  expectPackedEqualsReconstruction(s, model, 16u * 1024u);
}

TEST(FineInterpolation, GradedCellsPackLikeTheirReconstruction) {
  // Hanging nodes are coarse nodes like any other (their positions in the state), never face records.
  // (Glued: with a sliding interface the cells at the handle split too, and fewer nodes hang.)
  const Scene s = kidneyScene(SimSettings::Interface::Glued);
  CoarseModel model(s.scene.meshes, s.scene.fineK, s.scene.constraints, {}, CoarseElement::Cell, CoarseGrading{0.0});
  ASSERT_GT(model.hangingNodeCount(), 0u);
  expectPackedEqualsReconstruction(s, model, 64u * 1024u);
}

TEST(FineInterpolation, RestStateGivesRestPositionsInIndexSpace) {
  const Scene s = kidneyScene();
  CoarseModel model(s.scene.meshes, s.scene.fineK, s.scene.constraints);
  const auto xc = model.restState();
  const FineInterpolationData d = model.interpolationData();
  const Eigen::Matrix4d w2i = s.phantom.ct.geometry().worldToIndex();
  const auto got = interpolateFineReference(d, packFrameState(xc, model.elementRotations(xc), {RigidTransform{}}), w2i.cast<float>());
  double worst = 0;
  for (std::size_t f = 0; f < got.size(); ++f)
    worst = std::max(worst, (got[f].head<3>().cast<double>() - (w2i * s.scene.meshes.fine.nodes[f].homogeneous()).head<3>()).norm());
  EXPECT_LT(worst, 1e-4) << "voxels";
}

TEST(FineInterpolation, MismatchedOrNonFiniteStateIsRefused) {
  const Scene s = kidneyScene();
  CoarseModel model(s.scene.meshes, s.scene.fineK, s.scene.constraints);
  auto xc = model.restState();
  const FineInterpolationData d = model.interpolationData();
  EXPECT_THROW(interpolateFineReference(d, packFrameState(xc, model.elementRotations(xc), {}), Eigen::Matrix4f::Identity()), Error);
  xc.pop_back();
  EXPECT_THROW(interpolateFineReference(d, packFrameState(xc, model.elementRotations(model.restState()), {RigidTransform{}}), Eigen::Matrix4f::Identity()),
               Error);
  xc = model.restState();
  xc[3].x() = std::nan("");
  EXPECT_THROW(packFrameState(xc, model.elementRotations(model.restState()), {RigidTransform{}}), Error);
}

TEST(FineInterpolation, QuaternionMatrixIsTheRotation) {
  const Eigen::Matrix3d R = Eigen::AngleAxisd(2.5, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
  const Eigen::Quaterniond q(R);
  const Eigen::Matrix3f M = quaternionMatrix(Eigen::Vector4f(float(q.x()), float(q.y()), float(q.z()), float(q.w())));
  EXPECT_LT((M.cast<double>() - R).norm(), 1e-6);
  // Not normalized: the same rotation.
  const Eigen::Matrix3f M2 = quaternionMatrix(2.0f * Eigen::Vector4f(float(q.x()), float(q.y()), float(q.z()), float(q.w())));
  EXPECT_LT((M2 - M).norm(), 1e-6);
}
