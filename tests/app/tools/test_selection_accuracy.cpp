// Region growing against the organ labels of ../shared/data: the thresholds issue #4 sets.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include "app/io/nifti_io.h"
#include "app/tools/selection_eval.h"

using namespace handson;

namespace {

struct Case {
  const char* dir;
  std::vector<OrganLabel> organs;
};

void check(const Case& c) {
  const std::string dir = std::string(HANDSON_SHARED_DATA_DIR) + "/" + c.dir;
  if (!std::filesystem::exists(dir + "/ct.nii.gz")) GTEST_SKIP() << "no " << dir;
  const Volume ct = readNifti(dir + "/ct.nii.gz");
  const Volume labels = readNifti(dir + "/labels.nii.gz");
  const auto rows = evaluateSelection({c.dir, ct, labels, c.organs}, {20.0}, {GrowCriterion::Paper, GrowCriterion::Smoothed});
  ASSERT_EQ(rows.size(), 2 * c.organs.size());
  double recall = 0;
  int n = 0;
  for (const auto& r : rows) {
    // Precision >= 0.9 for every organ, both criteria.
    EXPECT_GE(r.precision, 0.9) << r.organ << " " << growCriterionName(r.criterion);
    if (r.criterion == GrowCriterion::Smoothed) {
      recall += r.recall;
      ++n;
      // The default criterion is much more complete than the paper's on every organ.
      for (const auto& q : rows)
        if (q.criterion == GrowCriterion::Paper && q.organ == r.organ) {
          EXPECT_GT(r.recall, q.recall + 0.2) << r.organ;
        }
    }
  }
  EXPECT_GE(recall / n, 0.8) << "mean recall of the default criterion at 20 mm";
}

}  // namespace

TEST(SelectionAccuracy, Ircadb) {
  check({"ircadb1.1", {{3, "kidney_left"}, {4, "kidney_right"}, {9, "artery"}, {10, "portal_vein"}, {8, "liver"}}});
}

TEST(SelectionAccuracy, TotalsegSmallKidneys) { check({"totalseg-small", {{2, "kidney_right"}, {3, "kidney_left"}}}); }

namespace {

// Whole-organ Dice as the extent sweeps (0.5-1.2x each organ's radius): the core criterion
// against the smoothed one it refines, on every labelled organ of the file. Thresholds are what
// was measured (bench selection, docs/region-growing.md) less a margin for rounding: a regression
// guard, the targets stated in the README.
void checkSweep(const char* dir, const std::vector<OrganLabel>& organs, double medianGain, double medianRimGain) {
  const std::string path = std::string(HANDSON_SHARED_DATA_DIR) + "/" + dir;
  if (!std::filesystem::exists(path + "/ct.nii.gz")) GTEST_SKIP() << "no " << path;
  const Volume ct = readNifti(path + "/ct.nii.gz");
  const Volume labels = readNifti(path + "/labels.nii.gz");
  const auto sweeps = sweepSelection({dir, ct, labels, organs}, {{0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.2}, {GrowCriterion::Smoothed, GrowCriterion::Core}});
  ASSERT_EQ(sweeps.size(), 4 * organs.size()) << "each criterion with and without the boundary rim";
  std::vector<double> gain, rimGain;
  for (const auto& core : sweeps) {
    if (core.criterion != GrowCriterion::Core || core.rim) continue;
    // The boundary rim, from the same growth: never worse at the best extent (measured +0.003 to
    // +0.11, median +0.012 on ircadb1.1 and +0.02 on totalseg-small).
    for (const auto& withRim : sweeps)
      if (withRim.criterion == GrowCriterion::Core && withRim.rim && withRim.organ == core.organ) {
        EXPECT_GE(withRim.best().dice, core.best().dice - 0.002) << core.organ;
        rimGain.push_back(withRim.best().dice - core.best().dice);
        for (std::size_t i = 0; i < core.points.size(); ++i) EXPECT_GE(withRim.points[i].selected, core.points[i].selected);
      }
    for (const auto& smoothed : sweeps)
      if (smoothed.criterion == GrowCriterion::Smoothed && !smoothed.rim && smoothed.organ == core.organ) {
        // Never much worse than smoothed, at its best or at the largest extent (the artery and the
        // portal vein, thin branches that lose their core, are 0.058 and 0.059 below: measured
        // 0.62 against 0.68 and 0.56 against 0.62).
        EXPECT_GE(core.best().dice, smoothed.best().dice - 0.06) << core.organ;
        EXPECT_GE(core.points.back().dice, smoothed.points.back().dice - 0.06) << core.organ;
        gain.push_back(core.best().dice - smoothed.best().dice);
      }
    for (const auto& p : core.points) {
      EXPECT_GE(p.dice, 0.0);
      EXPECT_LE(p.dice, 1.0);
    }
  }
  std::sort(gain.begin(), gain.end());
  EXPECT_GE(gain[gain.size() / 2], medianGain) << "median gain in best Dice over the smoothed criterion";
  ASSERT_EQ(rimGain.size(), organs.size());
  std::sort(rimGain.begin(), rimGain.end());
  EXPECT_GE(rimGain[rimGain.size() / 2], medianRimGain) << "median gain in best Dice from the boundary rim";
}

// The core criterion's best Dice per organ with the region's robust statistics (the default) and
// with its moments (the earlier rule), from the same seeds and extents, under `bound`: the median
// and the lowest organ's best may not fall, and the median must gain `medianGain` (measured,
// docs/region-growing.md).
void checkRobustStatistics(const char* dir, const std::vector<OrganLabel>& organs, double medianGain, GrowBound bound) {
  const std::string path = std::string(HANDSON_SHARED_DATA_DIR) + "/" + dir;
  if (!std::filesystem::exists(path + "/ct.nii.gz")) GTEST_SKIP() << "no " << path;
  const Volume ct = readNifti(path + "/ct.nii.gz");
  const Volume labels = readNifti(path + "/labels.nii.gz");
  const std::vector<double> fractions{0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.2};
  std::vector<double> best[2];
  for (RegionStatistics st : {RegionStatistics::Moments, RegionStatistics::Robust}) {
    const auto sweeps = sweepSelection({dir, ct, labels, organs}, {fractions, {GrowCriterion::Core}, false, st, bound});
    ASSERT_EQ(sweeps.size(), organs.size());
    for (const auto& w : sweeps) best[int(st == RegionStatistics::Robust)].push_back(w.best().dice);
  }
  for (auto& b : best) std::sort(b.begin(), b.end());
  const std::size_t mid = organs.size() / 2;
  EXPECT_GE(best[1][mid], best[0][mid] + medianGain) << "median best Dice, robust against moments";
  EXPECT_GE(best[1].front(), best[0].front()) << "lowest best Dice, robust against moments";
}

}  // namespace

TEST(SelectionAccuracy, CoreCriterionSelectsMoreOfTheWholeOrganOnIrcadb) {
#if defined(HANDSON_TEST_SANITIZED)
  GTEST_SKIP() << "34 M voxels: too slow under the sanitizers";
#endif
  checkSweep("ircadb1.1", {{3, "kidney_left"}, {4, "kidney_right"}, {9, "artery"}, {10, "portal_vein"}, {8, "liver"}, {11, "venous_system"}, {7, "spleen"}},
             0.02, 0.008);
}

TEST(SelectionAccuracy, RobustRegionStatisticsSelectMoreOfTheWholeOrganOnIrcadb) {
#if defined(HANDSON_TEST_SANITIZED)
  GTEST_SKIP() << "34 M voxels: too slow under the sanitizers";
#endif
  // Measured under the ball bound: median 0.73 -> 0.81, lowest 0.49 -> 0.55 (the left kidney 0.73 ->
  // 0.85, the venous system 0.49 -> 0.55; the portal vein, the one that loses, 0.62 -> 0.56). Under
  // the path bound the left kidney no longer leaks with either, and on this contrast scan the
  // moments' median is 0.01 above (0.852 against 0.840): the robust statistics' gain there is the
  // non-contrast kidney's (below) and the lowest organ's (docs/region-growing.md).
  checkRobustStatistics("ircadb1.1", {{3, "kidney_left"}, {4, "kidney_right"}, {9, "artery"}, {10, "portal_vein"}, {8, "liver"}, {11, "venous_system"}, {7, "spleen"}},
                        0.05, GrowBound::Ball);
}

TEST(SelectionAccuracy, RobustRegionStatisticsSelectMoreOfTheWholeOrganOnTotalsegSmall) {
  // Measured under the ball bound: the right kidney 0.59 -> 0.69 (renal sinus fat beside the seed no
  // longer widens the tolerance to 130 HU), the others within 0.01; median 0.84 -> 0.85. Under the
  // path bound (the default): the right kidney 0.59 -> 0.75, median 0.853 -> 0.855.
  checkRobustStatistics("totalseg-small", {{2, "kidney_right"}, {3, "kidney_left"}, {5, "liver"}, {1, "spleen"}}, 0.0, GrowBound::Path);
}

TEST(SelectionAccuracy, ThePathBoundSelectsTheWholeOrganWithoutLeakingPastIt) {
#if defined(HANDSON_TEST_SANITIZED)
  GTEST_SKIP() << "34 M voxels: too slow under the sanitizers";
#endif
  // The default (core criterion, robust statistics, rim) under the path bound against the ball
  // bound, from the same seeds, over every organ of both files (bench selection's sweep).
  // Measured: median best 0.845 -> 0.884, lowest 0.574 -> 0.572 (the venous system), the lowest
  // Dice at 1.2x as a share of the organ's best 0.71 (totalseg-small's right kidney, leaking past
  // its radius) -> 0.90. Thresholds: those, less 0.01 for the gain and 0.005 for the lowest.
  const std::string root = std::string(HANDSON_SHARED_DATA_DIR);
  if (!std::filesystem::exists(root + "/ircadb1.1/ct.nii.gz") || !std::filesystem::exists(root + "/totalseg-small/ct.nii.gz"))
    GTEST_SKIP() << "no ircadb1.1 or totalseg-small under " << root;
  const std::vector<std::pair<const char*, std::vector<OrganLabel>>> sets = {
      {"ircadb1.1", {{3, "kidney_left"}, {4, "kidney_right"}, {9, "artery"}, {10, "portal_vein"}, {8, "liver"}, {11, "venous_system"}, {7, "spleen"}}},
      {"totalseg-small", {{2, "kidney_right"}, {3, "kidney_left"}, {5, "liver"}, {1, "spleen"}}}};
  const std::vector<double> fractions{0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.1, 1.2};
  std::vector<double> best[2], kept[2];  // [0] ball, [1] path
  for (const auto& [dir, organs] : sets) {
    const Volume ct = readNifti(root + "/" + dir + "/ct.nii.gz");
    const Volume labels = readNifti(root + "/" + dir + "/labels.nii.gz");
    for (GrowBound b : {GrowBound::Ball, GrowBound::Path})
      for (const auto& w : sweepSelection({dir, ct, labels, organs}, {fractions, {GrowCriterion::Core}, true, RegionStatistics::Robust, b})) {
        if (!w.rim) continue;
        best[int(b == GrowBound::Path)].push_back(w.best().dice);
        kept[int(b == GrowBound::Path)].push_back(w.points.back().dice / w.best().dice);
      }
  }
  for (int i = 0; i < 2; ++i) {
    ASSERT_EQ(best[i].size(), 11u);
    std::sort(best[i].begin(), best[i].end());
    std::sort(kept[i].begin(), kept[i].end());
  }
  EXPECT_GE(best[1][5], best[0][5] + 0.03) << "median best Dice, path against ball";
  EXPECT_GE(best[1][5], 0.875) << "median best Dice under the path bound";
  EXPECT_GE(best[1][0], best[0][0] - 0.005) << "lowest best Dice, path against ball";
  EXPECT_GE(kept[1][0], 0.85) << "every organ keeps most of its best at 1.2x its radius under the path bound";
  EXPECT_LT(kept[0][0], 0.8) << "the ball bound lets an organ leak past its radius (what the test would miss otherwise)";
}

TEST(SelectionAccuracy, CoreCriterionSelectsMoreOfTheWholeOrganOnTotalsegSmall) {
  checkSweep("totalseg-small", {{2, "kidney_right"}, {3, "kidney_left"}, {5, "liver"}, {1, "spleen"}}, 0.0, 0.008);
}
