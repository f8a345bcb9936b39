// GPU passes against their CPU references on whatever Vulkan device is present (lavapipe in CI),
// with the validation layer on; and GPU depth picking against the phantom's analytic surfaces.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "gpu_test_env.h"
#include "interaction/camera.h"
#include "render/raymarch_reference.h"
#include "render/render_params.h"
#include "render/transfer_function.h"
#include "render/volume_renderer.h"
#include "sim/base/error.h"
#include "sim/phantom.h"

using namespace handson;

namespace {

struct Scene {
  Phantom phantom;
  QuantizedVolume q;
  std::unique_ptr<VolumeRenderer> renderer;
  TfTable lut;
};

// A coarse phantom (4 mm voxels, 96x72x60) keeps lavapipe fast.
Scene& scene() {
  static Scene s = [] {
    Scene sc;
    PhantomOptions o;
    o.spacingMm = 4.0;
    sc.phantom = makePhantom(o);
    sc.q = quantizeVolume(sc.phantom.ct);
    sc.renderer = std::make_unique<VolumeRenderer>(test::gpuContext());
    sc.renderer->setVolume(sc.q);
    return sc;
  }();
  return s;
}

void useTf(Scene& s, const TransferFunction& tf) {
  s.lut = tf.lookupTable(s.q);
  s.renderer->setTransferFunction(s.lut);
}

gpu::RenderParams paramsFor(const Scene& s, const OrbitCamera& cam, RenderSettings rs, std::uint32_t picks = 0) {
  return makeRenderParams(s.phantom.ct.geometry(), cam.view(), cam.projection(double(rs.width) / rs.height), glm::vec3(cam.eye()), rs, picks);
}

FrameResult renderGpu(Scene& s, const gpu::RenderParams& p, const std::vector<glm::vec2>& picks = {}) {
  FrameRequest req;
  req.params = p;
  req.pickPoints = picks;
  s.renderer->submit(req);
  return s.renderer->waitLast();
}

struct ImageDiff {
  int maxDiff = 0;
  double meanDiff = 0.0;
  double fractionOver2 = 0.0;  // pixels with any channel differing by more than 2/255
};

ImageDiff compare(const std::vector<std::uint8_t>& a, const std::vector<std::uint8_t>& b) {
  ImageDiff d;
  EXPECT_EQ(a.size(), b.size());
  std::size_t over = 0;
  double sum = 0;
  for (std::size_t p = 0; p + 3 < std::min(a.size(), b.size()); p += 4) {
    int m = 0;
    for (int c = 0; c < 3; ++c) {
      const int diff = std::abs(int(a[p + c]) - int(b[p + c]));
      m = std::max(m, diff);
      sum += diff;
    }
    d.maxDiff = std::max(d.maxDiff, m);
    over += m > 2;
  }
  d.meanDiff = sum / double(a.size() / 4 * 3);
  d.fractionOver2 = double(over) / double(a.size() / 4);
  return d;
}

class GpuPasses : public test::GpuTest {};

}  // namespace

TEST_F(GpuPasses, BrickRangesMatchCpuReferenceExactly) {
  Scene& s = scene();
  const BrickGrid cpu = computeBrickGrid(s.q);
  const BrickGrid& gpu = s.renderer->bricks();
  ASSERT_EQ(gpu.bx, cpu.bx);
  ASSERT_EQ(gpu.by, cpu.by);
  ASSERT_EQ(gpu.bz, cpu.bz);
  EXPECT_EQ(gpu.ranges, cpu.ranges);
}

TEST_F(GpuPasses, RaymarchMatchesCpuReference) {
  Scene& s = scene();
  useTf(s, transferFunctionPreset("ct-abdomen"));
  RenderSettings rs;
  rs.width = rs.height = 96;
  const OrbitCamera cam = OrbitCamera::framing(s.phantom.ct.geometry(), glm::radians(25.0), glm::radians(15.0));
  const gpu::RenderParams p = paramsFor(s, cam, rs);
  const FrameResult r = renderGpu(s, p);
  const ReferenceScene ref{&s.q, &s.lut, &s.renderer->occupancy()};
  const auto cpu = raymarchReference(ref, p);
  const ImageDiff d = compare(r.rgba, cpu);
  // Tolerance: the GPU's texture unit filters with its own weight precision and the shader's
  // float operations may be fused or reordered, so a few samples of a ray differ in the last
  // bits; that moves a channel by at most a few 1/255 steps on a small fraction of pixels.
  EXPECT_LE(d.meanDiff, 0.5) << "mean |GPU - CPU| in 1/255 units";
  EXPECT_LE(d.fractionOver2, 0.01) << "fraction of pixels off by more than 2/255";
  EXPECT_LE(d.maxDiff, 24);
  // Not a blank image: the phantom covers a good part of the frame.
  int lit = 0;
  for (std::size_t i = 0; i < r.rgba.size(); i += 4) lit += r.rgba[i] > 40;
  EXPECT_GT(lit, int(r.rgba.size() / 4 / 10));
}

TEST_F(GpuPasses, EmptySpaceSkippingChangesNothingButWork) {
  Scene& s = scene();
  // Over value and gradient magnitude too: the bricks' occupancy takes each value's largest opacity
  // over the rows, and a sample transparent at every gradient is skipped before its gradient.
  useTf(s, transferFunctionPreset("ct-organs"));
  {
    RenderSettings rs;
    rs.width = rs.height = 64;
    rs.earlyTermination = false;
    const OrbitCamera cam = OrbitCamera::framing(s.phantom.ct.geometry(), glm::radians(60.0), glm::radians(-20.0));
    rs.emptySpaceSkipping = false;
    const FrameResult plain = renderGpu(s, paramsFor(s, cam, rs));
    rs.emptySpaceSkipping = true;
    EXPECT_EQ(compare(plain.rgba, renderGpu(s, paramsFor(s, cam, rs)).rgba).maxDiff, 0) << "ct-organs";
  }
  useTf(s, transferFunctionPreset("ct-bone"));
  RenderSettings rs;
  rs.width = rs.height = 80;
  rs.earlyTermination = false;
  const OrbitCamera cam = OrbitCamera::framing(s.phantom.ct.geometry(), glm::radians(-40.0), glm::radians(30.0));
  rs.emptySpaceSkipping = false;
  const FrameResult plain = renderGpu(s, paramsFor(s, cam, rs));
  rs.emptySpaceSkipping = true;
  const FrameResult skip = renderGpu(s, paramsFor(s, cam, rs));
  // Same sample positions, and skipped samples have exactly zero opacity: identical images.
  EXPECT_EQ(compare(plain.rgba, skip.rgba).maxDiff, 0);
  // Early termination stops at 99 % opacity: what it leaves out weighs at most 1 % (2.55/255).
  rs.earlyTermination = true;
  const FrameResult ert = renderGpu(s, paramsFor(s, cam, rs));
  EXPECT_LE(compare(plain.rgba, ert.rgba).maxDiff, 4);
}

TEST_F(GpuPasses, PickMatchesCpuReference) {
  Scene& s = scene();
  useTf(s, transferFunctionPreset("ct-abdomen"));
  RenderSettings rs;
  rs.width = rs.height = 64;
  const OrbitCamera cam = OrbitCamera::framing(s.phantom.ct.geometry(), glm::radians(10.0), glm::radians(5.0));
  std::vector<glm::vec2> pts;
  for (int y = 0; y < 64; y += 4)
    for (int x = 0; x < 64; x += 4) pts.push_back(pixelToNdc(float(x), float(y), 64, 64));
  pts.push_back(glm::vec2(std::nanf(""), 0.0f));  // bad input: a miss, not a crash
  const gpu::RenderParams p = paramsFor(s, cam, rs, std::uint32_t(pts.size()));
  const FrameResult r = renderGpu(s, p, pts);
  const auto cpu = pickReference({&s.q, &s.lut, &s.renderer->occupancy()}, p, pts);
  ASSERT_EQ(r.picks.size(), cpu.size());
  int hits = 0, agree = 0;
  const float step = p.stepMm;
  for (std::size_t i = 0; i < cpu.size(); ++i) {
    const bool hg = r.picks[i].world.w > 0.5f, hc = cpu[i].world.w > 0.5f;
    hits += hc;
    if (hg != hc) continue;
    // Same hit/miss, and the same sample or its neighbour (threshold crossings may move by one
    // step when filtering differs in the last bits).
    if (!hg || glm::distance(glm::vec3(r.picks[i].world), glm::vec3(cpu[i].world)) <= 1.01f * step) ++agree;
  }
  EXPECT_GT(hits, 15);
  EXPECT_GE(agree, int(cpu.size()) - 2);
  EXPECT_EQ(r.picks.back().world.w, 0.0f);
}

TEST_F(GpuPasses, ATransferFunctionOverValueAndGradientMagnitudeMatchesCpuReference) {
  // ct-organs: a table of kTfGradientRows rows (value x gradient magnitude), sampled bilinearly by
  // the raymarch and picking with the gradient they compute (with shading, once for both).
  Scene& s = scene();
  s.renderer->clearMask();
  const TransferFunction organs = transferFunctionPreset("ct-organs");
  useTf(s, organs);
  ASSERT_EQ(s.lut.rows, gpu::kTfGradientRows);
  RenderSettings rs;
  rs.width = rs.height = 96;
  const OrbitCamera cam = OrbitCamera::framing(s.phantom.ct.geometry(), glm::radians(-30.0), glm::radians(20.0));
  std::vector<glm::vec2> pts;
  for (int y = 0; y < 96; y += 6)
    for (int x = 0; x < 96; x += 6) pts.push_back(pixelToNdc(float(x), float(y), 96, 96));
  const gpu::RenderParams p = paramsFor(s, cam, rs, std::uint32_t(pts.size()));
  const FrameResult r = renderGpu(s, p, pts);
  const ReferenceScene ref{&s.q, &s.lut, &s.renderer->occupancy()};
  const ImageDiff d = compare(r.rgba, raymarchReference(ref, p));
  // Tolerances as in RaymarchMatchesCpuReference: the gradient's six samples are filtered by the
  // texture unit too, so a row coordinate may differ in its last bits as a value does.
  EXPECT_LE(d.meanDiff, 0.5);
  EXPECT_LE(d.fractionOver2, 0.01);
  EXPECT_LE(d.maxDiff, 24);
  const auto cpu = pickReference(ref, p, pts);
  ASSERT_EQ(r.picks.size(), cpu.size());
  int hits = 0, agree = 0;
  for (std::size_t i = 0; i < cpu.size(); ++i) {
    const bool hg = r.picks[i].world.w > 0.5f, hc = cpu[i].world.w > 0.5f;
    hits += hc;
    if (hg == hc && (!hg || glm::distance(glm::vec3(r.picks[i].world), glm::vec3(cpu[i].world)) <= 1.01f * p.stepMm)) ++agree;
  }
  EXPECT_GT(hits, 40);
  EXPECT_GE(agree, int(cpu.size()) - 3);
  // The gradient axis shows: the same function over value alone draws another picture.
  TransferFunction valueOnly = organs;
  valueOnly.gradient.clear();
  useTf(s, valueOnly);
  EXPECT_GT(compare(r.rgba, renderGpu(s, paramsFor(s, cam, rs)).rgba).meanDiff, 2.0);
}

TEST_F(GpuPasses, ClippingMatchesCpuAndPicksLandBehindTheCut) {
  // From the patient's right (+x): a plane keeping x <= 60 mm cuts the right kidney (centre x = 78)
  // and the body wall away; then a box around the spine. Drawn as the CPU reference draws it, and
  // every pick lands on the kept side, on the first visible point behind the cut.
  Scene& s = scene();
  useTf(s, transferFunctionPreset("ct-abdomen"));
  s.renderer->clearMask();
  const OrbitCamera cam = OrbitCamera::framing(s.phantom.ct.geometry(), glm::radians(90.0), glm::radians(5.0));
  std::vector<glm::vec2> pts;
  for (int y = 4; y < 64; y += 6)
    for (int x = 4; x < 64; x += 6) pts.push_back(pixelToNdc(float(x), float(y), 64, 64));
  RenderSettings plain;
  plain.width = plain.height = 64;
  const auto unclipped = raymarchReference({&s.q, &s.lut, &s.renderer->occupancy()}, paramsFor(s, cam, plain));
  RenderSettings byPlane = plain;
  byPlane.clip.plane = true;
  byPlane.clip.normal = glm::vec3(-2.0f, 0.0f, 0.0f);  // not unit: -2x >= -120, i.e. x <= 60
  byPlane.clip.offset = -120.0f;
  RenderSettings byBox = plain;
  byBox.clip.box = true;
  byBox.clip.lo = glm::vec3(-40.0f, -120.0f, -200.0f);
  byBox.clip.hi = glm::vec3(40.0f, -30.0f, 200.0f);
  for (const RenderSettings& rs : {byPlane, byBox}) {
    const gpu::RenderParams p = paramsFor(s, cam, rs, std::uint32_t(pts.size()));
    const FrameResult r = renderGpu(s, p, pts);
    const ReferenceScene ref{&s.q, &s.lut, &s.renderer->occupancy()};
    const ImageDiff d = compare(r.rgba, raymarchReference(ref, p));
    EXPECT_LE(d.meanDiff, 0.5);  // tolerances as in RaymarchMatchesCpuReference
    EXPECT_LE(d.fractionOver2, 0.01);
    EXPECT_GT(compare(r.rgba, unclipped).meanDiff, 2.0) << "the cut shows";
    const auto cpu = pickReference(ref, p, pts);
    const float step = p.stepMm;
    int hits = 0, agree = 0;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const bool hg = r.picks[i].world.w > 0.5f;
      if (hg != (cpu[i].world.w > 0.5f)) continue;
      if (!hg || glm::distance(glm::vec3(r.picks[i].world), glm::vec3(cpu[i].world)) <= 1.01f * step) ++agree;
      if (!hg) continue;
      ++hits;
      const glm::vec3 w(r.picks[i].world);
      if (rs.clip.plane) {
        EXPECT_LE(w.x, 60.0f + step) << "a pick in clipped space";
      }
      if (rs.clip.box) {
        EXPECT_TRUE(glm::all(glm::greaterThanEqual(w, rs.clip.lo - step)) && glm::all(glm::lessThanEqual(w, rs.clip.hi + step)));
      }
    }
    EXPECT_GE(hits, 5) << "the kept anatomy covers a few of the 100 points (the default framing leaves a margin)";
    EXPECT_GE(agree, int(pts.size()) - 2);
  }
}

namespace {
// Five points on the aorta's front line (its anterior surface at five heights), in NDC of `cam`.
std::vector<glm::vec2> aortaFrontPoints(const OrbitCamera& cam, const PhantomGeometry& geo) {
  const glm::mat4 vp = cam.projection(1.0) * cam.view();
  std::vector<glm::vec2> pts;
  for (double dz : {-60.0, -20.0, 0.0, 30.0, 70.0}) {
    const glm::vec4 c = vp * glm::vec4(float(geo.aortaCenter.x()), float(geo.aortaCenter.y() + geo.aortaRadius), float(dz), 1.0f);
    pts.push_back(glm::vec2(c) / c.w);
  }
  return pts;
}
}  // namespace

TEST_F(GpuPasses, PickLandsOnAnalyticSurfacesWithinOneVoxel) {
  Scene& s = scene();
  const double voxel = s.phantom.ct.geometry().spacing.x();
  const PhantomGeometry& geo = s.phantom.geometry;
  RenderSettings rs;
  rs.width = rs.height = 128;
  // Body surface: fat (-100 HU) against air (-1000 HU); an opaque step at -500 HU.
  useTf(s, thresholdTransferFunction(-500.0f));
  for (double az : {0.0, 37.0, 90.0, 200.0}) {
    const OrbitCamera cam = OrbitCamera::framing(s.phantom.ct.geometry(), glm::radians(az), glm::radians(12.0));
    std::vector<glm::vec2> pts;
    for (int y = 8; y < 128; y += 12)
      for (int x = 8; x < 128; x += 12) pts.push_back(pixelToNdc(float(x), float(y), 128, 128));
    const FrameResult r = renderGpu(s, paramsFor(s, cam, rs, std::uint32_t(pts.size())), pts);
    const glm::dvec3 eye = cam.eye();
    int checked = 0;
    for (const auto& pk : r.picks) {
      if (pk.world.w < 0.5f) continue;
      const Eigen::Vector3d o(eye.x, eye.y, eye.z);
      const Eigen::Vector3d dir = Eigen::Vector3d(pk.world.x, pk.world.y, pk.world.z) - o;
      if (!geo.intersectBody(o, dir.normalized())) continue;  // an end cap of the cylinder: no analytic answer here
      // Distance from the picked point to the elliptic cylinder x^2/a^2 + y^2/b^2 = 1, to first
      // order |F| / |grad F| (exact enough within a voxel of the surface).
      const double x = pk.world.x, y = pk.world.y, a2 = geo.bodyA * geo.bodyA, b2 = geo.bodyB * geo.bodyB;
      const double dist = std::abs(x * x / a2 + y * y / b2 - 1.0) / std::hypot(2 * x / a2, 2 * y / b2);
      EXPECT_LE(dist, voxel) << "azimuth " << az;
      ++checked;
    }
    EXPECT_GT(checked, 15) << "azimuth " << az;
  }
  // Aorta (+280 HU) seen from the front, through fat, muscle and cavity (all below 200 HU).
  useTf(s, thresholdTransferFunction(200.0f));
  const OrbitCamera cam = OrbitCamera::framing(s.phantom.ct.geometry(), 0.0, 0.0);
  const std::vector<glm::vec2> pts = aortaFrontPoints(cam, geo);
  const FrameResult r = renderGpu(s, paramsFor(s, cam, rs, std::uint32_t(pts.size())), pts);
  const glm::dvec3 eye = cam.eye();
  for (const auto& pk : r.picks) {
    ASSERT_GT(pk.world.w, 0.5f);
    const Eigen::Vector3d o(eye.x, eye.y, eye.z);
    const Eigen::Vector3d dir = (Eigen::Vector3d(pk.world.x, pk.world.y, pk.world.z) - o).normalized();
    const auto t = geo.intersectAorta(o, dir);
    ASSERT_TRUE(t.has_value());
    EXPECT_LE(std::abs(std::hypot(pk.world.x - geo.aortaCenter.x(), pk.world.y - geo.aortaCenter.y()) - geo.aortaRadius), voxel);
    // The voxel index names a voxel of the aorta or right at its surface.
    const Eigen::Vector3d vw = s.phantom.ct.geometry().toWorld(Eigen::Vector3d(pk.voxel.x, pk.voxel.y, pk.voxel.z));
    EXPECT_LE(std::abs(std::hypot(vw.x() - geo.aortaCenter.x(), vw.y() - geo.aortaCenter.y()) - geo.aortaRadius), voxel);
  }
}

TEST_F(GpuPasses, AFaintRayIsPickedAtItsMostVisibleSampleAndAFainterOneMisses) {
  // The aorta (+280 HU, radius 11 mm) from the front, with a translucent preset: opacity `perMm` for
  // 240-330 HU (the aorta, and the vertebral body's cancellous bone behind it), none elsewhere. At
  // 0.02 per mm the rays through the aorta's axis end between 0.2 and 0.5 opaque (at 0.04 they pass
  // 0.5 in the bone behind; at 0.005 they stay under 0.2 - measured on the CPU reference): under the
  // pick threshold, over what a ray that is seen reaches. The sample that gives the pixel most of its
  // colour is the first one in the aorta (its share (1 - alpha) a falls along a uniform run), so the
  // pick lands on the aorta's front surface (within a voxel, as the opaque aorta's does in
  // PickLandsOnAnalyticSurfacesWithinOneVoxel), GPU and CPU alike; without the faint rule (the
  // default, RenderSettings::pickFaintThreshold) these rays miss, and at a quarter the opacity too.
  Scene& s = scene();
  const PhantomGeometry& geo = s.phantom.geometry;
  const double voxel = s.phantom.ct.geometry().spacing.x();
  auto translucent = [](float perMm) {
    TransferFunction tf;
    tf.name = "translucent";
    tf.points = {{239.9f, {1, 1, 1, 0}}, {240.0f, {1, 1, 1, perMm}}, {330.0f, {1, 1, 1, perMm}}, {330.1f, {1, 1, 1, 0}}};
    return tf;
  };
  RenderSettings rs;
  rs.width = rs.height = 128;
  rs.pickFaintThreshold = 0.2f;
  const OrbitCamera cam = OrbitCamera::framing(s.phantom.ct.geometry(), 0.0, 0.0);
  const std::vector<glm::vec2> pts = aortaFrontPoints(cam, geo);
  const glm::dvec3 eye = cam.eye();
  useTf(s, translucent(0.02f));
  const gpu::RenderParams p = paramsFor(s, cam, rs, std::uint32_t(pts.size()));
  const FrameResult r = renderGpu(s, p, pts);
  const auto cpu = pickReference({&s.q, &s.lut, &s.renderer->occupancy()}, p, pts);
  ASSERT_EQ(r.picks.size(), pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const auto& pk = r.picks[i];
    ASSERT_GT(pk.world.w, 0.5f) << i;
    ASSERT_GT(cpu[i].world.w, 0.5f) << i;
    EXPECT_LE(glm::distance(glm::vec3(pk.world), glm::vec3(cpu[i].world)), 1.01f * p.stepMm) << i;
    const Eigen::Vector3d o(eye.x, eye.y, eye.z);
    const Eigen::Vector3d dir = (Eigen::Vector3d(pk.world.x, pk.world.y, pk.world.z) - o).normalized();
    ASSERT_TRUE(geo.intersectAorta(o, dir).has_value()) << i;
    EXPECT_LE(std::abs(std::hypot(pk.world.x - geo.aortaCenter.x(), pk.world.y - geo.aortaCenter.y()) - geo.aortaRadius), voxel) << i;
  }
  // The default rule (no faint rays) misses them all, and so does a ray four times fainter.
  auto expectAllMiss = [&](const RenderSettings& settings) {
    const gpu::RenderParams q = paramsFor(s, cam, settings, std::uint32_t(pts.size()));
    for (const auto& pk : renderGpu(s, q, pts).picks) EXPECT_EQ(pk.world.w, 0.0f);
    for (const auto& pk : pickReference({&s.q, &s.lut, &s.renderer->occupancy()}, q, pts)) EXPECT_EQ(pk.world.w, 0.0f);
  };
  RenderSettings off = rs;
  off.pickFaintThreshold = RenderSettings{}.pickFaintThreshold;
  expectAllMiss(off);
  useTf(s, translucent(0.005f));
  expectAllMiss(rs);
  useTf(s, transferFunctionPreset("ct-abdomen"));
}

TEST_F(GpuPasses, FramesInFlightDoNotStallAndArriveInOrder) {
  Scene& s = scene();
  useTf(s, transferFunctionPreset("ct-abdomen"));
  RenderSettings rs;
  rs.width = rs.height = 32;
  const OrbitCamera cam = OrbitCamera::framing(s.phantom.ct.geometry());
  std::vector<std::uint64_t> ids;
  FrameRequest req;
  req.params = paramsFor(s, cam, rs, 1);
  req.pickPoints = {glm::vec2(0.0f)};
  for (int i = 0; i < 4; ++i) ids.push_back(s.renderer->submit(req));
  // With two slots, submitting frame n+2 harvested frame n: two results are already waiting.
  auto done = s.renderer->takeCompleted();
  ASSERT_EQ(done.size(), 2u);
  EXPECT_EQ(done[0].frame, ids[0]);
  EXPECT_EQ(done[1].frame, ids[1]);
  const FrameResult last = s.renderer->waitLast();
  EXPECT_EQ(last.frame, ids[3]);
  auto rest = s.renderer->takeCompleted();
  ASSERT_EQ(rest.size(), 1u);
  EXPECT_EQ(rest[0].frame, ids[2]);
  EXPECT_EQ(last.picks.size(), 1u);
  EXPECT_GT(last.picks[0].world.w, 0.5f);  // the centre ray hits the phantom
  EXPECT_FALSE(last.timings.empty());
}

TEST_F(GpuPasses, LabelTintMatchesCpuAndIsOffWithoutLabels) {
  Scene& s = scene();
  useTf(s, transferFunctionPreset("ct-abdomen"));
  s.renderer->clearMask();
  s.renderer->setHandleTints(std::vector<glm::vec4>(gpu::kMaxHandleIds, glm::vec4(0.0f)));
  std::vector<std::uint16_t> labels(s.phantom.labels.voxelCount());
  for (std::size_t i = 0; i < labels.size(); ++i) labels[i] = std::uint16_t(s.phantom.labels.value(i));
  labels[0] = 40000;  // a label beyond 8 bits goes through the 16-bit image
  s.renderer->setLabels(labels);
  EXPECT_TRUE(s.renderer->hasLabels());
  RenderSettings rs;
  rs.width = rs.height = 96;
  rs.labelTint = true;
  const OrbitCamera cam = OrbitCamera::framing(s.phantom.ct.geometry(), glm::radians(60.0), glm::radians(10.0));
  const gpu::RenderParams p = paramsFor(s, cam, rs);
  const FrameResult tinted = renderGpu(s, p);
  ReferenceScene ref{&s.q, &s.lut, &s.renderer->occupancy()};
  ref.labels = &labels;
  const ImageDiff d = compare(tinted.rgba, raymarchReference(ref, p));
  EXPECT_LE(d.meanDiff, 0.5);  // tolerances as in RaymarchMatchesCpuReference
  EXPECT_LE(d.fractionOver2, 0.01);
  EXPECT_LE(d.maxDiff, 24);
  // The tint shows: against the untinted reference a good share of the pixels change.
  ref.labels = nullptr;
  const auto plain = raymarchReference(ref, p);
  std::size_t changed = 0;
  for (std::size_t i = 0; i < plain.size(); i += 4) changed += std::abs(int(plain[i]) - int(tinted.rgba[i])) + std::abs(int(plain[i + 2]) - int(tinted.rgba[i + 2])) > 20;
  EXPECT_GT(changed, plain.size() / 4 / 20);
  // Without labels the flag draws nothing: the untinted frame.
  s.renderer->setLabels({});
  EXPECT_FALSE(s.renderer->hasLabels());
  const FrameResult off = renderGpu(s, p);
  const ImageDiff o = compare(off.rgba, plain);
  EXPECT_LE(o.meanDiff, 0.5);
  EXPECT_LE(o.fractionOver2, 0.01);
  EXPECT_THROW(s.renderer->setLabels(std::vector<std::uint16_t>(7, 1)), Error);
}

TEST_F(GpuPasses, HandleTintMatchesCpuAndPicksReportTheHandleId) {
  Scene& s = scene();
  useTf(s, transferFunctionPreset("ct-abdomen"));
  // Handle 1: the right kidney (label 4), tinted green.
  MaskUpload up;
  up.dims = s.phantom.ct.dims();
  up.ids.resize(s.phantom.ct.voxelCount());
  for (std::size_t i = 0; i < up.ids.size(); ++i) up.ids[i] = s.phantom.labels.value(i) == float(label::kKidneyRight) ? 1 : 0;
  std::vector<glm::vec4> tints(gpu::kMaxHandleIds, glm::vec4(0.0f));
  tints[1] = glm::vec4(0.1f, 0.9f, 0.2f, 0.8f);
  s.renderer->setHandleTints(tints);
  RenderSettings rs;
  rs.width = rs.height = 96;
  const OrbitCamera cam = OrbitCamera::framing(s.phantom.ct.geometry(), glm::radians(90.0), 0.0);  // from the patient's right (+x)
  const glm::mat4 vp = cam.projection(1.0) * cam.view();
  const Eigen::Vector3d kc = s.phantom.geometry.kidneyRightCenter;
  const glm::vec4 c = vp * glm::vec4(float(kc.x()), float(kc.y()), float(kc.z()), 1.0f);
  const std::vector<glm::vec2> picks = {glm::vec2(c) / c.w};
  FrameRequest req;
  req.params = paramsFor(s, cam, rs, 1);
  req.pickPoints = picks;
  req.maskUpload = &up;
  s.renderer->submit(req);
  const FrameResult r = s.renderer->waitLast();
  const ReferenceScene ref{&s.q, &s.lut, &s.renderer->occupancy(), &up.ids, &tints};
  const auto cpu = raymarchReference(ref, req.params);
  const ImageDiff d = compare(r.rgba, cpu);
  EXPECT_LE(d.meanDiff, 0.5);
  EXPECT_LE(d.fractionOver2, 0.01);
  // The tint is visible: greenish pixels exist where the untinted image has none.
  std::size_t green = 0;
  for (std::size_t i = 0; i < r.rgba.size(); i += 4) green += r.rgba[i + 1] > r.rgba[i] + 20;
  EXPECT_GT(green, 20u);
  // With threshold picking through the skin the kidney may not be the first surface; use bone-free
  // opacity: the kidney cortex (+170 HU) is the first thing above 120 HU from the right.
  useTf(s, thresholdTransferFunction(120.0f));
  req.maskUpload = nullptr;  // the mask stays on the GPU between frames
  req.params = paramsFor(s, cam, rs, 1);
  s.renderer->submit(req);
  const FrameResult p = s.renderer->waitLast();
  ASSERT_GT(p.picks[0].world.w, 0.5f);
  EXPECT_EQ(p.picks[0].voxel.w, 1);
  const auto cpuPick = pickReference({&s.q, &s.lut, &s.renderer->occupancy(), &up.ids, &tints}, req.params, picks);
  EXPECT_EQ(cpuPick[0].voxel.w, 1);
  // Move the handle rigidly by 30 mm anterior (+y): drawn at its new place, its old place empty.
  useTf(s, transferFunctionPreset("ct-abdomen"));
  MovingHandlePose moved;
  moved.id = 1;
  moved.pose.t = Eigen::Vector3d(0, 30, 0);
  moved.restMin = s.phantom.ct.dims();
  for (std::size_t i = 0; i < up.ids.size(); ++i)
    if (up.ids[i]) {
      const auto& dd = s.phantom.ct.dims();
      const Eigen::Vector3i vox(int(i % std::size_t(dd.x())), int((i / std::size_t(dd.x())) % std::size_t(dd.y())), int(i / (std::size_t(dd.x()) * dd.y())));
      moved.restMin = moved.restMin.cwiseMin(vox);
      moved.restMax = moved.restMax.cwiseMax(vox);
    }
  req.params = paramsFor(s, cam, rs, 2);
  setMovingHandles(req.params, s.phantom.ct.geometry(), {moved});
  ASSERT_EQ(req.params.movingCount, 1u);
  const glm::vec4 c2 = vp * glm::vec4(float(kc.x()), float(kc.y() + 30.0), float(kc.z()), 1.0f);
  req.pickPoints = {glm::vec2(c) / c.w, glm::vec2(c2) / c2.w};
  s.renderer->submit(req);
  const FrameResult mv = s.renderer->waitLast();
  const auto cpuMoved = raymarchReference(ref, req.params);
  const ImageDiff dm = compare(mv.rgba, cpuMoved);
  EXPECT_LE(dm.meanDiff, 0.5);
  EXPECT_LE(dm.fractionOver2, 0.01);
  EXPECT_GT(compare(mv.rgba, r.rgba).meanDiff, 0.2);  // the picture changed
  // Empty-space skipping stays exact with the handle moved out of the body into air, where every
  // brick is empty by the transfer function.
  {
    MovingHandlePose far = moved;
    far.pose.t = Eigen::Vector3d(90, 0, 0);  // toward the camera, partly past the skin
    RenderSettings plain = rs;
    plain.emptySpaceSkipping = false;
    plain.earlyTermination = false;
    RenderSettings fast = plain;
    fast.emptySpaceSkipping = true;
    gpu::RenderParams pp = paramsFor(s, cam, plain), pf = paramsFor(s, cam, fast);
    setMovingHandles(pp, s.phantom.ct.geometry(), {far});
    setMovingHandles(pf, s.phantom.ct.geometry(), {far});
    const auto a = raymarchReference(ref, pp), b = raymarchReference(ref, pf);
    EXPECT_EQ(compare(a, b).maxDiff, 0);
    FrameRequest fr;
    fr.params = pf;
    s.renderer->submit(fr);
    EXPECT_EQ(compare(s.renderer->waitLast().rgba, b).maxDiff <= 24, true);
    // Without the moved handle's bounds the skipping would lose it: the image would equal the
    // one with the handle simply removed.
    gpu::RenderParams noBounds = pf;
    noBounds.moving[0].boxMin = glm::vec4(1e9f);
    noBounds.moving[0].boxMax = glm::vec4(1e9f);
    EXPECT_GT(compare(raymarchReference(ref, noBounds), b).maxDiff, 20);
  }
  const auto cpuMovedPicks = pickReference(ref, req.params, req.pickPoints);
  ASSERT_EQ(mv.picks.size(), 2u);
  EXPECT_NE(mv.picks[0].voxel.w, 1);  // the old place shows no handle
  EXPECT_EQ(mv.picks[1].voxel.w, 1);  // the new place does
  EXPECT_EQ(cpuMovedPicks[0].voxel.w, mv.picks[0].voxel.w);
  EXPECT_EQ(cpuMovedPicks[1].voxel.w, mv.picks[1].voxel.w);
  // Leave the shared scene as it was.
  s.renderer->clearMask();
  s.renderer->setHandleTints(std::vector<glm::vec4>(gpu::kMaxHandleIds, glm::vec4(0.0f)));
}

TEST_F(GpuPasses, APickOnAThinLayerOverAHandleReportsTheHandleWithinReachAndNotBeyond) {
  // The kidney seen from the patient's right (+x) with threshold opacity (120 HU: its cortex is the
  // first thing above it). Handle 1 is the kidney minus its outermost `layer` voxels on the camera's
  // side, so the picks stop on unmasked cortex in front of it. One 4 mm voxel in front: within the
  // pick's handle reach (shared.h: 2 voxels, 8 mm here) the handle is reported behind the surface
  // point; five voxels (20 mm): beyond it, nothing. GPU and CPU reference agree on every ray but
  // at most one.
  Scene& s = scene();
  useTf(s, thresholdTransferFunction(120.0f));
  std::vector<glm::vec4> tints(gpu::kMaxHandleIds, glm::vec4(0.0f));
  tints[1] = glm::vec4(0.1f, 0.9f, 0.2f, 0.8f);
  s.renderer->setHandleTints(tints);
  RenderSettings rs;
  rs.width = rs.height = 64;
  const OrbitCamera cam = OrbitCamera::framing(s.phantom.ct.geometry(), glm::radians(90.0), 0.0);
  const glm::mat4 vp = cam.projection(1.0) * cam.view();
  const Eigen::Vector3d kc = s.phantom.geometry.kidneyRightCenter;
  std::vector<glm::vec2> picks;
  for (int dy = -3; dy <= 3; ++dy)
    for (int dz = -3; dz <= 3; ++dz) {
      const glm::vec4 c = vp * glm::vec4(float(kc.x()), float(kc.y() + 3.0 * dy), float(kc.z() + 3.0 * dz), 1.0f);
      picks.push_back(glm::vec2(c) / c.w);
    }
  const auto& d = s.phantom.ct.dims();
  auto kidney = [&](int i, int j, int k) { return i < d.x() && s.phantom.labels.value(i, j, k) == float(label::kKidneyRight); };
  for (const int layer : {1, 5}) {
    MaskUpload up;
    up.dims = d;
    up.ids.assign(s.phantom.ct.voxelCount(), 0);
    for (int k = 0; k < d.z(); ++k)
      for (int j = 0; j < d.y(); ++j)
        for (int i = 0; i < d.x(); ++i) {
          bool deep = kidney(i, j, k);
          for (int t = 1; t <= layer && deep; ++t) deep = kidney(i + t, j, k);  // `layer` kidney voxels toward the camera
          up.ids[std::size_t(i) + std::size_t(d.x()) * (std::size_t(j) + std::size_t(d.y()) * std::size_t(k))] = deep ? 1 : 0;
        }
    FrameRequest req;
    req.params = paramsFor(s, cam, rs, std::uint32_t(picks.size()));
    req.pickPoints = picks;
    req.maskUpload = &up;
    s.renderer->submit(req);
    const FrameResult r = s.renderer->waitLast();
    const auto cpu = pickReference({&s.q, &s.lut, &s.renderer->occupancy(), &up.ids, &tints}, req.params, picks);
    ASSERT_EQ(r.picks.size(), picks.size());
    int handle = 0, gpuCpuSame = 0, reached = 0;
    for (std::size_t i = 0; i < picks.size(); ++i) {
      ASSERT_GT(r.picks[i].world.w, 0.5f) << i;
      handle += r.picks[i].voxel.w == 1;
      gpuCpuSame += r.picks[i].voxel.w == cpu[i].voxel.w;
      // Reached: the surface voxel itself is not the handle's, the handle behind it is reported.
      const Eigen::Vector3i v(r.picks[i].voxel.x, r.picks[i].voxel.y, r.picks[i].voxel.z);
      reached += r.picks[i].voxel.w == 1 && s.phantom.ct.geometry().contains(v) &&
                 up.ids[std::size_t(v.x()) + std::size_t(d.x()) * (std::size_t(v.y()) + std::size_t(d.y()) * std::size_t(v.z()))] == 0;
    }
    std::printf("layer %d: %d of %zu rays report the handle (%d reached behind the surface), GPU = CPU on %d\n", layer, handle, picks.size(), reached,
                gpuCpuSame);
    // All 49 rays agree but for at most one whose surface lies at the reach's very edge (GPU
    // filtering precision, see raymarch_reference.h).
    EXPECT_GE(gpuCpuSame, int(picks.size()) - 1) << "layer " << layer;
    if (layer == 1) {
      // Measured: 29 of 49. Rays toward the kidney's rim cross the layer obliquely, over more than
      // the reach; the central ones meet it head on.
      EXPECT_GE(reached, 20) << "the handle one voxel behind the surface is what the finger touches";
    }
    else
      EXPECT_EQ(handle, 0) << "a handle 20 mm behind the surface is out of reach";
  }
  s.renderer->clearMask();
  s.renderer->setHandleTints(std::vector<glm::vec4>(gpu::kMaxHandleIds, glm::vec4(0.0f)));
  useTf(s, transferFunctionPreset("ct-abdomen"));
}

namespace {
// The jitter tests' view: the bone preset at a long step (3x the default: where the jitter matters).
struct JitterView {
  RenderSettings rs;
  OrbitCamera cam;
};
JitterView jitterView(Scene& s, int size) {
  useTf(s, transferFunctionPreset("ct-bone"));
  JitterView v{RenderSettings{}, OrbitCamera::framing(s.phantom.ct.geometry(), glm::radians(35.0), glm::radians(20.0))};
  v.rs.width = v.rs.height = size;
  v.rs.stepFactor = 1.5f;
  return v;
}
}  // namespace

TEST_F(GpuPasses, AJitteredStillFrameSumsItsPhasesAsTheCpuReferenceDoesAndSettles) {
  // Phases 0..7 summed one a frame, then the complete sum shown: the GPU's running means against
  // the CPU reference's (the same blue-noise tile and phase shifts), and the settled frame against
  // the last mean.
  Scene& s = scene();
  const JitterView v = jitterView(s, 72);
  const RenderSettings& rs = v.rs;
  const OrbitCamera& cam = v.cam;
  const gpu::RenderParams base = paramsFor(s, cam, rs);
  ASSERT_TRUE(base.flags & gpu::kFlagJitter) << "jitter is on by default";
  const ReferenceScene ref{&s.q, &s.lut, &s.renderer->occupancy()};
  std::vector<glm::vec3> cpuSum;
  std::vector<std::uint8_t> last;
  for (int k = 0; k <= kStillJitterPhases; ++k) {
    gpu::RenderParams p = base;
    setStillPhase(p, k);
    const FrameResult r = renderGpu(s, p);
    const auto cpu = raymarchReference(ref, p, &cpuSum);
    const ImageDiff d = compare(r.rgba, cpu);
    // Tolerance: RaymarchMatchesCpuReference's, for each phase and for their mean.
    EXPECT_LE(d.meanDiff, 0.5) << "phase " << k;
    EXPECT_LE(d.fractionOver2, 0.01) << "phase " << k;
    if (k == 1) {
      EXPECT_GT(compare(r.rgba, last).maxDiff, 0) << "a second phase changes the mean";
    }
    if (k == kStillJitterPhases) {
      EXPECT_TRUE(r.rgba == last) << "the complete sum is shown unchanged, bit for bit";
    }
    last = r.rgba;
  }
  // One jittered phase alone, without a sum, is the phase-0 term: the same as the first mean.
  gpu::RenderParams single = base;
  const FrameResult one = renderGpu(s, single);
  gpu::RenderParams first = base;
  setStillPhase(first, 0);
  EXPECT_TRUE(renderGpu(s, first).rgba == one.rgba);
  // And without jitter every ray samples at the middle of each step: a different picture.
  gpu::RenderParams plain = base;
  plain.flags &= ~gpu::kFlagJitter;
  EXPECT_GT(compare(renderGpu(s, plain).rgba, one.rgba).fractionOver2, 0.01);
}

TEST_F(GpuPasses, TheJitteredStillFrameHasNoWoodGrain) {
  // Wood grain: rays whose samples sit at the same fractions of the step cross a surface at the
  // same phase, in bands a few pixels across. Against a reference with a 12x finer step (no
  // jitter), the error's band-scale structure must fall to under half with jitter and the phase
  // sum (measured on lavapipe: 2.8 -> 0.9 in 1/255 units; the shader without jitter: unchanged).
  Scene& s = scene();
  JitterView v = jitterView(s, 96);
  RenderSettings& rs = v.rs;
  const OrbitCamera& cam = v.cam;
  rs.jitter = false;
  rs.stepFactor = 0.125f;
  const auto truth = renderGpu(s, paramsFor(s, cam, rs)).rgba;
  rs.stepFactor = 1.5f;
  const auto banded = renderGpu(s, paramsFor(s, cam, rs)).rgba;
  rs.jitter = true;
  const gpu::RenderParams jittered = paramsFor(s, cam, rs);
  std::vector<std::uint8_t> settled;
  for (int k = 0; k < kStillJitterPhases; ++k) {
    gpu::RenderParams p = jittered;
    setStillPhase(p, k);
    settled = renderGpu(s, p).rgba;
  }
  // The error (grey: the mean of the channels, 1/255 units), box-blurred over radius r.
  const int w = rs.width, h = rs.height;
  auto blurred = [&](const std::vector<std::uint8_t>& img, int r) {
    std::vector<double> out(std::size_t(w) * h, 0.0);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        double e = 0.0;
        int n = 0;
        for (int dy = -r; dy <= r; ++dy)
          for (int dx = -r; dx <= r; ++dx) {
            const int yy = std::clamp(y + dy, 0, h - 1), xx = std::clamp(x + dx, 0, w - 1);
            const std::size_t i = (std::size_t(yy) * w + std::size_t(xx)) * 4;
            for (int c = 0; c < 3; ++c) e += double(img[i + c]) - double(truth[i + c]);
            ++n;
          }
        out[std::size_t(y) * w + x] = e / (3.0 * n);
      }
    return out;
  };
  // Bands: the error's structure between 2 and 8 pixels across (blur radius 1 minus radius 4);
  // finer is noise, coarser is the long step's smooth bias, which jitter does not claim to remove.
  auto bandError = [&](const std::vector<std::uint8_t>& img) {
    const auto fine = blurred(img, 1), coarse = blurred(img, 4);
    double sum = 0.0;
    for (std::size_t i = 0; i < fine.size(); ++i) sum += (fine[i] - coarse[i]) * (fine[i] - coarse[i]);
    return std::sqrt(sum / double(fine.size()));
  };
  const double bands = bandError(banded), after = bandError(settled);
  EXPECT_GT(bands, 1.0) << "the long fixed step does band (1/255 units)";
  EXPECT_LT(after, 0.5 * bands) << "banded " << bands << ", jittered and summed " << after;
  EXPECT_LT(after, 1.5);
}

TEST_F(GpuPasses, TheRendererSumsAStillPictureAndStartsAnewWhenItChanges) {
  // FrameRequest::stillPhases: the renderer counts the phases itself. The same picture frame after
  // frame: 1, 2, ... 8 phases, then the complete sum (the manual sum's image); a change outside the
  // parameters (the handle tints) or of them (the camera) starts a new sum: one phase, the image of
  // a first phase of the new picture.
  Scene& s = scene();
  const JitterView v = jitterView(s, 64);
  const RenderSettings& rs = v.rs;
  const OrbitCamera& cam = v.cam;
  FrameRequest req;
  req.params = paramsFor(s, cam, rs);
  req.stillPhases = kStillJitterPhases;
  std::vector<std::uint8_t> img;
  for (int k = 1; k <= kStillJitterPhases + 2; ++k) {
    s.renderer->submit(req);
    EXPECT_EQ(s.renderer->stillPhasesShown(), std::min(k, kStillJitterPhases));
    const FrameResult r = s.renderer->waitLast();
    img = r.rgba;
    // A frame that only shows the complete sum marches nothing and is timed as "still-frame", so a
    // frame budget never takes its time for a raymarch's (app/session/frame_driver.cpp).
    bool marched = false, shown = false;
    for (const auto& t : r.timings) {
      marched = marched || t.id == PassId::Raymarch;
      shown = shown || t.name == "still-frame";
    }
    if (!r.timings.empty()) {
      EXPECT_EQ(marched, k <= kStillJitterPhases) << k;
      EXPECT_EQ(shown, k > kStillJitterPhases) << k;
    }
  }
  std::vector<std::uint8_t> manual;
  for (int k = 0; k < kStillJitterPhases; ++k) {
    gpu::RenderParams p = paramsFor(s, cam, rs);
    setStillPhase(p, k);
    manual = renderGpu(s, p).rgba;
  }
  EXPECT_TRUE(img == manual) << "the renderer's sum is the manual one";
  auto firstPhase = [&](const gpu::RenderParams& base) {
    gpu::RenderParams p = base;
    setStillPhase(p, 0);
    return renderGpu(s, p).rgba;
  };
  // The tints change (the same values: a setter is a change all the same).
  for (int k = 0; k < 3; ++k) {
    s.renderer->submit(req);
    s.renderer->waitLast();
  }
  EXPECT_EQ(s.renderer->stillPhasesShown(), 3) << "a new sum after the manual frames";
  s.renderer->setHandleTints(std::vector<glm::vec4>(gpu::kMaxHandleIds, glm::vec4(0.0f)));
  s.renderer->submit(req);
  EXPECT_EQ(s.renderer->stillPhasesShown(), 1);
  const auto afterTints = s.renderer->waitLast().rgba;
  EXPECT_TRUE(afterTints == firstPhase(req.params));
  // The camera moves.
  const OrbitCamera moved = OrbitCamera::framing(s.phantom.ct.geometry(), glm::radians(50.0), glm::radians(20.0));
  for (int k = 0; k < 3; ++k) {
    s.renderer->submit(req);
    s.renderer->waitLast();
  }
  EXPECT_EQ(s.renderer->stillPhasesShown(), 3);
  req.params = paramsFor(s, moved, rs);
  s.renderer->submit(req);
  EXPECT_EQ(s.renderer->stillPhasesShown(), 1);
  const auto afterMove = s.renderer->waitLast().rgba;
  EXPECT_TRUE(afterMove == firstPhase(req.params));
  // Fewer phases asked for mid-sum: a new sum, never a mean over the wrong count.
  for (int k = 0; k < 5; ++k) {
    s.renderer->submit(req);
    s.renderer->waitLast();
  }
  req.stillPhases = 4;
  s.renderer->submit(req);
  EXPECT_EQ(s.renderer->stillPhasesShown(), 1);
  const auto fewer = s.renderer->waitLast().rgba;
  EXPECT_TRUE(fewer == firstPhase(req.params));
  // No sum asked for: none.
  req.stillPhases = 0;
  s.renderer->submit(req);
  EXPECT_EQ(s.renderer->stillPhasesShown(), 0);
  s.renderer->waitLast();
}

TEST_F(GpuPasses, AnImportIsBoundWhereItIsDeclaredAndOneThatNamesNothingMustBeBound) {
  // vk::importBuffer declares a resource owned outside the graph and binds it in the same call:
  // the executor finds it from the graph (no bindBuffer), here through a copy read back.
  const vk::Context& ctx = test::gpuContext();
  vk::Buffer source(ctx, 64, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, vk::Buffer::Memory::HostVisible);
  vk::Buffer target(ctx, 64, VK_BUFFER_USAGE_TRANSFER_DST_BIT, vk::Buffer::Memory::HostVisible);
  auto* in = static_cast<std::uint32_t*>(source.mapped());
  for (std::uint32_t i = 0; i < 16; ++i) in[i] = 1000u + i * i;
  source.flush();
  vk::GraphExecutor x(ctx, 1);
  x.beginFrame();
  fg::FrameGraph g;
  const fg::ResourceHandle from = vk::importBuffer(g, "source", source, fg::Access::HostWrite);
  const fg::ResourceHandle to = vk::importBuffer(g, "target", target, fg::Access::None);
  vk::addReadbackPass(g, PassId::ImageReadback, from, to);
  g.compile();
  x.setGraph(&g);
  EXPECT_EQ(&x.buffer(from), &source);
  EXPECT_EQ(&x.buffer(to), &target);
  g.execute(x);
  x.setGraph(nullptr);
  x.submit();
  x.waitLastFrame();
  target.invalidate();
  const auto* out = static_cast<const std::uint32_t*>(target.mapped());
  for (std::uint32_t i = 0; i < 16; ++i) EXPECT_EQ(out[i], 1000u + i * i) << i;
  // An import by description alone names nothing: unbound, asking for it is a clear error; bound,
  // it is what was bound.
  x.beginFrame();
  fg::FrameGraph h;
  const fg::ResourceHandle unnamed = h.importBuffer("unnamed", {64}, fg::Access::None);
  x.setGraph(&h);
  EXPECT_THROW(x.buffer(unnamed), Error);
  EXPECT_THROW(x.image(unnamed), Error);
  x.bindBuffer(unnamed, target);
  EXPECT_EQ(&x.buffer(unnamed), &target);
  x.setGraph(nullptr);
  x.submit();
  x.waitLastFrame();
}
