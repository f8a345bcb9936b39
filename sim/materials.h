#pragma once
// Materials from image values (docs/simulation-model.md, "Materials"): an editable table of value
// bands, each a tissue class with a Young's modulus and a Poisson ratio. CT tables are in
// Hounsfield units; tables for uncalibrated images (MRI) give their bands as percentiles of the
// image's values and are resolved against the image before use. The optional skeleton column
// (no|yes|joined, SkeletonRole) says which bands are bone anchored to the skeleton.
//
// Text format (CSV, '#' comments): a line "units,hu" or "units,percentile", a header line
// "name,lower,upper,youngs_kpa,poisson[,strain_limit[,skeleton]]", then one band per line with half-open bounds
// [lower, upper) ("-inf"/"inf" allowed). Bands must be sorted and must not overlap; a value in a
// gap or outside every band takes the nearest band. The optional strain limit is the largest
// principal stretch - 1 (sim/strain.h) past which the tissue is at risk of failing, a fraction
// ("inf": none; a table without the column has none).
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "sim/volume.h"

namespace handson {

/// The band of a simulation's fine tet in the exterior layer (sim/sim_scene.h, SimSettings::Outer): it
/// stands for tissue beyond the region, so it has no band of the table and no strain limit.
constexpr int kExteriorBand = -1;
/// The band of a handle's own fine tets under a sliding interface (sim/sliding_interface.h): they move
/// rigidly with the handle, carry no stiffness and have no strain limit.
constexpr int kRigidBand = -2;

/// Linear tetrahedra lock as nu -> 0.5; Poisson ratios above this are capped (and reported).
constexpr double kMaxPoisson = 0.45;

/// A band's part in the skeleton (sim/skeleton.h), the optional column "skeleton": no; yes (bone
/// wherever its values are: compact bone); joined (bone only where joined, through bone voxels, to a
/// "yes" voxel within the reach: spongy bone, whose values contrast-enhanced blood and organs share -
/// elsewhere its voxels take the material of the band below it).
enum class SkeletonRole : std::uint8_t { No, Yes, Joined };

struct MaterialBand {
  std::string name;
  double lower = 0.0, upper = 0.0;  ///< image units (or percentiles before resolve())
  double youngs = 0.0;              ///< Pa
  double poisson = 0.0;
  double strainLimit = std::numeric_limits<double>::infinity();  ///< fraction (0.3: 30 %); inf: none
  SkeletonRole skeleton = SkeletonRole::No;
};

enum class MaterialUnits : std::uint8_t { Hounsfield, Percentile };

class MaterialTable {
 public:
  /// The CT defaults (the same as assets/materials/ct-default.csv).
  static MaterialTable ctDefault();
  /// Parses the text format. Throws handson::Error naming `source` and the line on bad input.
  static MaterialTable parse(const std::string& text, const std::string& source = "material table");
  static MaterialTable load(const std::string& path);

  MaterialUnits units() const { return units_; }
  const std::vector<MaterialBand>& bands() const { return bands_; }
  /// Names of bands whose Poisson ratio was capped at kMaxPoisson when parsed.
  const std::vector<std::string>& capped() const { return capped_; }

  /// A percentile table turned into image units using the values of `image` above its background
  /// (voxels above the 2nd percentile of all values); a Hounsfield table is returned unchanged.
  MaterialTable resolve(const Volume& image) const;
  /// Index of the band of an image value (the nearest band outside all of them). Throws
  /// handson::Error for a percentile table that was not resolved.
  int classify(double value) const;
  const MaterialBand& band(int i) const { return bands_[std::size_t(i)]; }

 private:
  MaterialUnits units_ = MaterialUnits::Hounsfield;
  bool resolved_ = true;
  std::vector<MaterialBand> bands_;
  std::vector<std::string> capped_;
};

}  // namespace handson
