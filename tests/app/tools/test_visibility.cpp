// The visibility measures (app/tools/visibility.h): CIELAB against published values, the label's
// box and the nearest side against constructed volumes.
#include <gtest/gtest.h>

#include <cmath>

#include "app/tools/visibility.h"

using namespace handson;

TEST(Visibility, SrgbToLabMatchesPublishedValues) {
  // D65 white is L* 100 with no chroma; sRGB red is (53.24, 80.09, 67.20) and blue (32.30, 79.19,
  // -107.86) (Lindbloom's calculator; the tolerance covers the published rounding).
  const auto white = srgbToLab(255, 255, 255), black = srgbToLab(0, 0, 0), red = srgbToLab(255, 0, 0), blue = srgbToLab(0, 0, 255);
  EXPECT_NEAR(white[0], 100.0, 1e-3);
  EXPECT_NEAR(white[1], 0.0, 1e-2);
  EXPECT_NEAR(white[2], 0.0, 1e-2);
  for (double c : black) EXPECT_NEAR(c, 0.0, 1e-9);
  EXPECT_NEAR(red[0], 53.24, 0.02);
  EXPECT_NEAR(red[1], 80.09, 0.05);
  EXPECT_NEAR(red[2], 67.20, 0.05);
  EXPECT_NEAR(blue[0], 32.30, 0.02);
  EXPECT_NEAR(blue[1], 79.19, 0.05);
  EXPECT_NEAR(blue[2], -107.86, 0.05);
  EXPECT_NEAR(deltaE76(white, black), 100.0, 1e-3);
  // The mean over pairs, by hand: {white, black} against {white}: (0 + 100) / 2.
  EXPECT_NEAR(meanPairwiseDeltaE({white, black}, {white}), 50.0, 1e-3);
  EXPECT_EQ(meanPairwiseDeltaE({}, {white}), 0.0);
}

TEST(Visibility, TheLabelsBoxHoldsItsVoxelsEdges) {
  VolumeGeometry g;
  g.dims = {10, 8, 6};
  g.spacing = {2.0, 1.0, 3.0};
  g.origin = {-10, 0, 5};
  Volume labels(g, ScalarType::UInt8);
  labels.setValue(labels.linearIndex(2, 3, 1), 4.0f);
  labels.setValue(labels.linearIndex(5, 3, 4), 4.0f);
  labels.setValue(labels.linearIndex(9, 7, 5), 2.0f);
  const auto box = labelBox(labels, 4);
  ASSERT_TRUE(box.has_value());
  // Voxel centres at origin + index * spacing; edges half a spacing out.
  EXPECT_NEAR(box->lo.x(), -10 + 2 * 2 - 1.0, 1e-9);
  EXPECT_NEAR(box->hi.x(), -10 + 5 * 2 + 1.0, 1e-9);
  EXPECT_NEAR(box->lo.y(), 3 - 0.5, 1e-9);
  EXPECT_NEAR(box->hi.y(), 3 + 0.5, 1e-9);
  EXPECT_NEAR(box->lo.z(), 5 + 3 - 1.5, 1e-9);
  EXPECT_NEAR(box->hi.z(), 5 + 12 + 1.5, 1e-9);
  EXPECT_FALSE(labelBox(labels, 7).has_value());
}

TEST(Visibility, TheNearestSideIsWhereTheSkinIsClosest) {
  // A body of soft tissue (40 HU) filling x, y in [10, 50] mm of a 60 mm square of air (1 mm
  // voxels): a point 4 mm inside the right (+x) side is nearest it, one 6 mm inside the front
  // (+y) the front, one 3 mm inside the back the back, one 5 mm inside the left (-x) the left.
  VolumeGeometry g;
  g.dims = {61, 61, 5};
  Volume ct(g, ScalarType::Int16);
  for (int k = 0; k < 5; ++k)
    for (int j = 0; j <= 60; ++j)
      for (int i = 0; i <= 60; ++i) ct.setValue(ct.linearIndex(i, j, k), (i >= 10 && i <= 50 && j >= 10 && j <= 50) ? 40.0f : -1000.0f);
  EXPECT_EQ(nearestSideAzimuth(ct, Eigen::Vector3d(46, 30, 2)), 90.0);
  EXPECT_EQ(nearestSideAzimuth(ct, Eigen::Vector3d(30, 44, 2)), 0.0);
  EXPECT_EQ(nearestSideAzimuth(ct, Eigen::Vector3d(30, 13, 2)), 180.0);
  EXPECT_EQ(nearestSideAzimuth(ct, Eigen::Vector3d(15, 30, 2)), -90.0);
}

TEST(Visibility, TheLabelAtAWorldPointIsOnTheLabelMapsOwnGrid) {
  // A label map on a coarser, shifted grid than the image: the label of the nearest of its own
  // voxels, -1 outside it.
  VolumeGeometry g;
  g.dims = {4, 4, 4};
  g.spacing = {3.0, 3.0, 3.0};
  g.origin = {10, 20, 30};
  Volume labels(g, ScalarType::UInt8);
  labels.setValue(labels.linearIndex(1, 2, 3), 5.0f);
  EXPECT_EQ(labelAt(labels, Eigen::Vector3d(13.0, 26.0, 39.0)), 5);
  EXPECT_EQ(labelAt(labels, Eigen::Vector3d(14.4, 27.4, 40.4)), 5);  // within half a voxel
  EXPECT_EQ(labelAt(labels, Eigen::Vector3d(10.0, 20.0, 30.0)), 0);
  EXPECT_EQ(labelAt(labels, Eigen::Vector3d(-50.0, 20.0, 30.0)), -1);
  EXPECT_EQ(labelAt(labels, Eigen::Vector3d(std::nan(""), 20.0, 30.0)), -1);
}
