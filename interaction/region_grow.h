#pragma once
// Seeded region growing (docs/region-growing.md) on the GPU's 16-bit view of the volume
// (sim/quantized_volume.h), as the CPU reference of the region-growing compute pass.
//
// Seed statistics: delta_seed and sigma_seed are the mean and the standard deviation of the 3x3x3
// neighbourhood of the seed voxel (edges clamped), sigma_seed >= a floor so a flat region still
// grows. A candidate is homogeneous if |value - delta_seed| < h_max * sigma_seed.
//
// Three criteria:
//  - Paper: value = the voxel's own value compared with the seed voxel's own value; 6-neighbour
//    breadth-first passes; a voxel's key is its pass number (steps from the seed), and the
//    selection for an extent d is every reached voxel with key <= floor(d / min spacing).
//  - Smoothed: value = the 3x3x3 mean around the voxel, compared with the seed's 3x3x3 mean (noise
//    drops by ~5x, so one noisy sample no longer decides); growth is bounded by the physical
//    distance from the seed: a voxel's key is the smallest radius (squared, mm^2) of a ball about
//    the seed within which a path of homogeneous voxels joins it to the seed. The selection for an
//    extent d is {key <= d^2}: the connected homogeneous region inside the ball of radius d.
//  - Core (default): as Smoothed, but a path may pass only through the organ's core: voxels whose
//    six neighbours are homogeneous too and whose own value lies within the tighter core tolerance
//    (GrowParams::coreFraction of the tolerance). Other homogeneous voxels join the selection when
//    a core neighbour reaches them but pass nothing on. This is growth on the homogeneous set eroded
//    by one voxel, dilated back by one voxel within it: bridges between organs of similar intensity
//    (up to four voxels wide in a noise-free image: two of them are homogeneous 3x3x3 means), and
//    paths along an organ's blurred rim, no longer join them.
//    key(v) = max(|v - seed|^2, min over core 6-neighbours n of key(n)) for homogeneous v; the seed
//    has key 0 and always passes on.
// The smoothed and core criteria take a bound (GrowParams::bound, interaction/grow_setup.h): the ball above
// (Ball), or path keys (Path): key(v) = min over passing neighbours n of key(n) + the step's length
// (26 neighbours, a step across an edge or corner only where face steps through passing voxels join
// them too; interaction/grow_setup.h), the shortest path's length through the region, and the selection
// for an extent d is {key <= d in path units}. The statistics are refined, and the core's thinness
// judged, in the 10 mm probe ball either way.
// In all, shrinking is a threshold on stored keys and growing resumes where the last call stopped.
// The smoothed criteria then refine their statistics from the region they grow near the seed (see
// GrowParams); the paper criterion is the paper's rule, unchanged.
#include <array>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "interaction/radix_queue.h"
#include "interaction/grow_setup.h"
#include "sim/quantized_volume.h"

namespace handson {

/// How the smoothed criteria take their refined statistics from the raw values of the region grown
/// near the seed (GrowParams::refinements):
///  - Robust (default): centre = the median, spread = 1.4826 x the median absolute deviation (the
///    standard deviation for a normal sample). A minority of other tissue in the probe - renal sinus
///    fat beside a kidney's parenchyma, a vessel's wall - moves neither much, so it no longer widens
///    the tolerance enough to let neighbours of another intensity pass.
///  - Moments: mean and standard deviation (the earlier rule, kept to compare; bench selection).
enum class RegionStatistics : std::uint8_t { Moments, Robust };
const char* regionStatisticsName(RegionStatistics s);
bool parseRegionStatistics(const std::string& s, RegionStatistics& out);

struct GrowParams {
  GrowCriterion criterion = GrowCriterion::Core;
  double hMax = 1.1;
  /// Floor of sigma_seed as a fraction of the 16-bit range (0.002 of a CT window of ~4000 HU is ~8 HU).
  double sigmaFloor = 0.002;
  /// Smoothed criterion: refine the statistics this many times from the region grown within
  /// probeRadiusMm (mean and standard deviation of its voxels; tolerance hRegion * sigma, never
  /// below the seed's), then grow afresh. Organs are not uniform (renal cortex and medulla,
  /// vessel walls): the region's own spread says how much variation belongs to the organ.
  int refinements = 2;
  double probeRadiusMm = 10.0;
  double hRegion = 2.0;
  RegionStatistics statistics = RegionStatistics::Robust;
  /// Core criterion: the core tolerance as a fraction of the tolerance, in (0, 1]. Growth passes
  /// only through voxels clearly of the organ, so a rim of partial-volume voxels that is still
  /// within the tolerance carries no path into a neighbour (bench selection: 0.6).
  double coreFraction = 0.6;
  /// Core criterion: if the core region within probeRadiusMm holds fewer than this share of the
  /// voxels the smoothed criterion selects there, the seed lies in a structure too thin for a core
  /// and the smoothed criterion runs instead.
  double thinShare = 0.5;
  /// A finished selection ends with its partial-volume rim (withBoundaryRim; `--selection-rim` in
  /// view and replay, `--rim` in select; on by default since it was measured better on `bench
  /// selection` with no organ lower, docs/region-growing.md, "The boundary rim").
  bool boundaryRim = true;
  /// Smoothed and core criteria: how the extent bounds growth (interaction/grow_setup.h: GrowBound). Path by
  /// default since it was measured better on `bench selection` (docs/region-growing.md, "The path bound").
  GrowBound bound = GrowBound::Path;
};


/// The voxel within `radius` voxels (a cube) of `near` whose 3x3x3 neighbourhood has the smallest
/// standard deviation; the nearest one on ties. For seeds that land on an edge.
Eigen::Vector3i mostHomogeneousNear(const QuantizedVolume& volume, const Eigen::Vector3i& near, int radius);

/// The grower's per-voxel arrays (a key and the cached tests for every voxel of the volume), kept
/// between growers: allocating and clearing them is most of a new grower's cost on a large CT
/// (ircadb1.1, 34 M voxels: ~0.5 s of fresh pages against milliseconds of growth). A grower given a
/// workspace borrows its arrays, and gives them back cleared (only the entries it touched) when it
/// is destroyed - on any thread: a finished pinch's grower is let go where its voxels are gathered
/// (interaction/selection.h, FinishedPinch). One grower at a time per workspace: a grower made
/// while another holds the arrays waits for them (at most lendWait: then it is refused, as a
/// grower that would wait for one its own thread holds would hang). Growers hold their workspace
/// by shared_ptr. `keys` and `tests` may be read only while no grower holds them.
struct GrowWorkspace {
  std::vector<std::uint32_t> keys;  ///< kUnreached everywhere, or empty (lent, or never sized)
  std::vector<std::uint8_t> tests;  ///< 0 everywhere, or empty
  /// Sizes the arrays for a volume now (so the first grower does not pay for it). Not while lent.
  void reserve(std::size_t voxels);
  /// How long a grower waits for the arrays before it is refused.
  std::chrono::milliseconds lendWait{20000};
  /// A grower borrows the arrays (swapped into k and t), waiting while another holds them; throws
  /// handson::Error if they do not come back within lendWait.
  void lend(std::vector<std::uint32_t>& k, std::vector<std::uint8_t>& t);
  /// ... and gives them back (cleared by the grower).
  void giveBack(std::vector<std::uint32_t>& k, std::vector<std::uint8_t>& t);

 private:
  std::mutex mutex_;
  std::condition_variable returned_;
  bool lent_ = false;
};

class RegionGrower {
 public:
  /// Throws handson::Error if the seed lies outside the volume or the parameters are invalid.
  /// `workspace`: arrays to reuse (see GrowWorkspace), kept alive while the grower holds them;
  /// nullptr: the grower's own.
  RegionGrower(const QuantizedVolume& volume, const Eigen::Vector3i& seed, const GrowParams& params = {},
               std::shared_ptr<GrowWorkspace> workspace = nullptr);
  ~RegionGrower();
  RegionGrower(const RegionGrower&) = delete;
  RegionGrower& operator=(const RegionGrower&) = delete;

  const GrowSetup& setup() const { return setup_; }
  const QuantizedVolume& volume() const { return vol_; }
  /// Grows until every voxel with key <= the extent's bound has its final key.
  void growTo(double extentMm);
  /// Is a voxel homogeneous with the seed (the acceptance test alone)?
  bool accepts(std::size_t linear) const;
  /// Does a voxel pass growth on to its neighbours (always, except under the core criterion)?
  bool passesOn(std::size_t linear);

  /// Per-voxel keys (kUnreached where not reached); final for keys <= the grown bound.
  const std::vector<std::uint32_t>& keys() const { return keys_; }
  std::uint32_t bound(double extentMm) const;
  /// Selection for an extent no larger than the grown one: 1 inside, 0 outside.
  std::vector<std::uint8_t> mask(double extentMm) const;
  std::size_t count(double extentMm) const;
  double grownExtent() const { return grown_; }
  /// Voxels that have a key (the only candidates for any selection).
  const std::vector<std::size_t>& touched() const { return touched_; }
  /// The selection for a key bound (keys <= bound, bound(extentMm)): linear indices in the order
  /// they were reached (touched()).
  std::vector<std::uint32_t> selected(std::uint32_t bound) const;

 private:
  float value(int i, int j, int k) const;  // u16 value or 3x3x3 sum, per criterion
  void push(std::size_t v, std::uint32_t key);
  /// Path keys: relaxes the 26 neighbours of a voxel that passes growth on (GrowBound::Path).
  void relaxPathSteps(std::uint32_t key, const Eigen::Vector3i& voxel);
  /// A voxel inside the volume that is homogeneous and passes growth on (or the seed).
  bool passesThrough(const Eigen::Vector3i& voxel);
  void restart();
  /// The constructor's work once the checks passed and the arrays are borrowed.
  void begin(const Eigen::Vector3i& seed);
  /// The arrays back to the workspace, cleared (nothing without one).
  void releaseWorkspace();
  bool homogeneous(std::size_t v, int i, int j, int k);  // accepts(), cached; (i, j, k) = v's voxel
  bool passesOn(std::size_t v, const Eigen::Vector3i& voxel);
  void setTolerance(double tolerance);
  void refine(double seedSum, double seedTolerance);  // statistics from the region near the seed
  /// Centre and spread of the raw values of the voxels with keys <= probe (GrowParams::statistics);
  /// false when fewer than 27.
  bool regionStatistics(std::uint32_t probe, double& centre, double& spread) const;

  const QuantizedVolume& vol_;
  GrowParams params_;
  GrowSetup setup_;
  std::vector<std::uint32_t> keys_;
  std::vector<std::size_t> touched_;  // voxels with a key (to reset and count without a full scan)
  double grown_ = -1.0;
  std::size_t seedLinear_ = 0;
  double tolerance_ = 0.0;  // the tolerance before rounding to float (the core tolerance derives from it)
  // Per-voxel cache of the tests (kKnown, kHomogeneous, kCoreKnown, kCore bits) and the voxels it
  // holds, reset when the statistics change.
  std::vector<std::uint8_t> class_;
  std::vector<std::size_t> classified_;
  // Resumable front: (key, voxel), smallest key first (keys only grow as the search goes on).
  RadixQueue<std::size_t> front_;
  std::shared_ptr<GrowWorkspace> workspace_;  // where keys_ and class_ came from, and go back to
  std::array<std::uint32_t, 8> steps_{};  // Path keys: step lengths by axis mask (growStepCosts)
};

/// The selection's boundary rim (docs/region-growing.md, "The boundary rim"). A voxel on an organ's
/// surface holds part organ, part neighbour (partial volume), so its value and its 3x3x3 mean lie
/// between the two and fail the homogeneity test; the labelled organ runs through that layer. A
/// voxel face-adjacent to the selection joins it when it is not homogeneous with the seed (a
/// homogeneous one was left out by the extent, not by its value) and its own value is nearer the
/// selection's mean (the seed statistics, per voxel) than the value of the voxel one step further
/// out in the same direction: the half-way boundary between the organ and what lies beyond, one
/// voxel deep. `voxels`: linear indices, ascending (a selection of `grower`); returns them with the
/// rim's, ascending. No voxel is added from a direction whose step out leaves the volume. Throws
/// handson::Error for an index outside the volume or voxels out of order.
std::vector<std::uint32_t> withBoundaryRim(const RegionGrower& grower, const std::vector<std::uint32_t>& voxels);

/// What the rim needs of a grower: its volume (kept alive by the caller) and its setup - a copy,
/// so that a finished selection can be rimmed on another thread once its grower is gone.
struct BoundaryRimRule {
  const QuantizedVolume* volume = nullptr;
  GrowSetup setup;
  explicit BoundaryRimRule(const RegionGrower& grower) : volume(&grower.volume()), setup(grower.setup()) {}
  /// Homogeneous with the seed (RegionGrower::accepts).
  bool accepts(std::size_t linear) const;
};
std::vector<std::uint32_t> withBoundaryRim(const BoundaryRimRule& rule, const std::vector<std::uint32_t>& voxels);
/// The value a criterion tests at voxel (i, j, k): the u16 value (Paper) or its 3x3x3 sum, edges clamped.
float growValue(const QuantizedVolume& volume, GrowCriterion criterion, int i, int j, int k);

}  // namespace handson
