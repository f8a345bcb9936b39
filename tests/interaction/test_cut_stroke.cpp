// A finger's stroke turned into a cut (interaction/cut_stroke.h): the ruled surface of the view rays
// between the picked surface and a depth below the stroke's start, one planar convex quad per
// segment, checked against the rays' own geometry; and the cut it makes in a block of tets.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "interaction/cut_stroke.h"
#include "sim/base/error.h"
#include "sim/tet_mesh.h"

using namespace handson;

namespace {

// Rays from one eye at (0, 0, 200) looking down -z at points (x, y, 0), the surface z = h(x).
StrokeSample fromEye(double x, double y, double surfaceZ) {
  const Eigen::Vector3d eye(0, 0, 200), at(x, y, surfaceZ);
  StrokeSample s;
  s.origin = eye;
  s.direction = (at - eye).normalized();
  s.surfaceMm = (at - eye).norm();
  return s;
}

}  // namespace

TEST(CutStroke, EachSegmentIsThePlanarQuadOfItsTwoRaysFromTheSurfaceToTheDepth) {
  // A stroke along x from -20 to 20 mm over a surface sloping from z = 0 to z = -4, sampled every
  // 1 mm: with segments of at least 4 mm, ten quads; each passes checkCutQuad (planar, convex), its
  // top corners are the picked surface points, its bottom ones lie on the same rays at the start's
  // distance plus 15 mm, and consecutive quads share an edge (the ruled surface is continuous).
  std::vector<StrokeSample> stroke;
  for (int i = 0; i <= 40; ++i) stroke.push_back(fromEye(-20.0 + i, 5.0, -0.1 * i));
  const CutStroke cut = cutAlongStroke(stroke);
  ASSERT_EQ(cut.quads.size(), 10u);
  EXPECT_EQ(cut.skipped, 0u);
  const double bottom = stroke.front().surfaceMm + 15.0;
  for (std::size_t k = 0; k < cut.quads.size(); ++k) {
    const auto& c = cut.quads[k].corners;
    EXPECT_NO_THROW(checkCutQuad(cut.quads[k]));
    for (int e : {0, 1}) {
      const Eigen::Vector3d ray = c[std::size_t(e)] - stroke.front().origin;  // the top corner's ray
      EXPECT_NEAR((c[std::size_t(3 - e)] - stroke.front().origin).norm(), bottom, 1e-9) << "the bottom at the start's depth + 15";
      EXPECT_LT((c[std::size_t(3 - e)] - stroke.front().origin).normalized().cross(ray.normalized()).norm(), 1e-12) << "on the same ray";
      EXPECT_NEAR(c[std::size_t(e)].y(), 5.0, 1e-9);
    }
    if (k > 0) {
      EXPECT_LT((c[0] - cut.quads[k - 1].corners[1]).norm(), 1e-12);
      EXPECT_LT((c[3] - cut.quads[k - 1].corners[2]).norm(), 1e-12);
    }
  }
  EXPECT_NEAR(cut.quads.front().corners[0].x(), -20.0, 1e-9);
  EXPECT_NEAR(cut.quads.back().corners[1].x(), 20.0, 1e-9);
}

TEST(CutStroke, WhereThePickMissesOrTheSurfaceFallsBelowTheCutTheCutBreaks) {
  // Samples 10-14 miss (NaN) and 25-29 lie on a surface 20 mm down, below the cut's bottom: no cut
  // beneath them; the cut resumes after each gap (its quads never span one).
  std::vector<StrokeSample> stroke;
  for (int i = 0; i <= 40; ++i) {
    StrokeSample s = fromEye(-20.0 + i, 0.0, (i >= 25 && i < 30) ? -20.0 : 0.0);
    if (i >= 10 && i < 15) s.surfaceMm = std::numeric_limits<double>::quiet_NaN();
    stroke.push_back(s);
  }
  const CutStroke cut = cutAlongStroke(stroke);
  EXPECT_EQ(cut.skipped, 10u);
  for (const CutQuad& q : cut.quads) {
    const double x0 = q.corners[0].x(), x1 = q.corners[1].x();
    EXPECT_FALSE(x0 < -10.0 + 1e-9 && x1 > -6.0 - 1e-9) << "spans the missed picks: " << x0 << " .. " << x1;
    EXPECT_FALSE(x0 < 5.0 + 1e-9 && x1 > 9.0 - 1e-9) << "spans the fallen surface: " << x0 << " .. " << x1;
  }
  EXPECT_GE(cut.quads.size(), 6u);
}

TEST(CutStroke, AStrokeDrawnAcrossABlockCutsItThrough) {
  // A 40 x 20 x 20 mm block of 2 mm Kuhn cells (top face z = 20) and a straight stroke across it at
  // x = 11.3 from y = -5 to 25, the eye 200 mm above: its quads cut at once (cutMeshAlong) separate
  // the block into two pieces down to 15 mm below the top (the faces within a cell of the cut's
  // bottom aside): no tet on one side shares a node above z = 6 with one on the other.
  const TetMesh block = KuhnGrid({0, 0, 0}, {2, 2, 2}, {20, 10, 10}).mesh();
  std::vector<StrokeSample> stroke;
  for (int i = 0; i <= 30; ++i) {
    const Eigen::Vector3d eye(11.3, 10, 220), at(11.3, -5.0 + i, 20);
    StrokeSample s;
    s.origin = eye;
    s.direction = (at - eye).normalized();
    s.surfaceMm = (at - eye).norm();
    stroke.push_back(s);
  }
  const CutStroke cut = cutAlongStroke(stroke);
  const MeshCut c = cutMeshAlong(block, cut.quads);
  const TetMesh& m = c.mesh;
  const CutPlane plane = cutPlane(cut.quads.front());
  std::vector<int> side(m.nodes.size(), 0);
  bool shared = false;
  for (const auto& t : m.tets) {
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (int n : t) centroid += 0.25 * m.nodes[std::size_t(n)];
    if (centroid.z() < 6.0) continue;
    const int s = plane.height(centroid) >= 0.0 ? 1 : -1;  // cutMesh's sides
    for (int n : t) {
      if (side[std::size_t(n)] == -s && m.nodes[std::size_t(n)].z() > 6.0) shared = true;
      side[std::size_t(n)] = s;
    }
  }
  std::printf("%zu quads, %zu faces separated, %zu nodes copied\n", cut.quads.size(), c.cutFaces, m.nodes.size() - block.nodes.size());
  EXPECT_GT(c.cutFaces, 0u);
  EXPECT_FALSE(shared) << "the block is still joined across the stroke above the cut's bottom";
}

TEST(CutStroke, BadStrokesAreRefused) {
  // One sample, a first pick that missed, no depth, a NaN depth, a direction that is not unit, a
  // surface behind the eye, a stroke that never moves 4 mm: refused with a message, never a quad.
  const StrokeSample a = fromEye(0, 0, 0), b = fromEye(10, 0, 0);
  EXPECT_THROW(cutAlongStroke({a}), Error);
  StrokeSample missed = a;
  missed.surfaceMm = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(cutAlongStroke({missed, b}), Error);
  EXPECT_THROW(cutAlongStroke({a, b}, {0.0, 4.0}), Error);
  EXPECT_THROW(cutAlongStroke({a, b}, {std::numeric_limits<double>::quiet_NaN(), 4.0}), Error);
  StrokeSample skewed = b;
  skewed.direction *= 2.0;
  EXPECT_THROW(cutAlongStroke({a, skewed}), Error);
  StrokeSample behind = b;
  behind.surfaceMm = -1.0;
  EXPECT_THROW(cutAlongStroke({a, behind}), Error);
  EXPECT_THROW(cutAlongStroke({a, fromEye(1, 0, 0), fromEye(2, 0, 0)}), Error);
  EXPECT_EQ(cutAlongStroke({a, b}).quads.size(), 1u);
}

TEST(CutStroke, ACutsQuadsAsAScriptRecordsThemReadBackExactly) {
  // The "cut" action's value: twelve numbers a quad, quads by semicolons, each number in its
  // shortest exact form, so a replay cuts along the very same quads.
  const std::vector<CutQuad> quads{{{Eigen::Vector3d(0.1, -2.0 / 3.0, 1e-7), Eigen::Vector3d(10.25, -2.0 / 3.0, 1e-7), Eigen::Vector3d(10.25, 30, 1e-7),
                                     Eigen::Vector3d(0.1, 30, 1e-7)}},
                                   {{Eigen::Vector3d(5, 5, 5), Eigen::Vector3d(5, 6, 5), Eigen::Vector3d(5, 6, 6), Eigen::Vector3d(5, 5, 6)}}};
  const std::string text = formatCutQuads(quads);
  EXPECT_EQ(text.find(' '), std::string::npos) << text;
  EXPECT_EQ(std::count(text.begin(), text.end(), ';'), 1) << text;
  const std::vector<CutQuad> back = parseCutQuads(text);
  ASSERT_EQ(back.size(), 2u);
  for (std::size_t q = 0; q < 2; ++q)
    for (std::size_t c = 0; c < 4; ++c) EXPECT_EQ(back[q].corners[c], quads[q].corners[c]) << text;
  for (const char* bad : {"", "1,2,3", "0,0,0,1,0,0,1,1,0,0,1,0;", "0,0,0,1,0,0,1,1,0,0,1,x", "0,0,0,1,0,0,1,1,0,0,1,0,7", "0,0,0,1,0,0,1,1,0,0,1,5",
                          "0,0,0,0,0,0,0,0,0,0,0,0", "nan,0,0,1,0,0,1,1,0,0,1,0"})
    EXPECT_THROW(parseCutQuads(bad), Error) << bad;
}
