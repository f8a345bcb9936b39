#pragma once
// The default scene: a procedural abdominal CT phantom with its label map, built from analytic
// shapes so that tests have exact answers. World coordinates are RAS+ mm (x toward the patient's
// right, y anterior, z superior), centred on the origin.
//
// Structures (label codes follow ../shared/data's ircadb convention):
//   body (1): elliptic cylinder, subcutaneous fat layer (-100 HU), muscle wall (+50 HU), cavity (+10 HU)
//   bone (2): vertebral body (cortical +900 HU shell, cancellous +250 HU), discs (+90 HU), posterior arch (+700 HU)
//   kidney_left (3) at -x, kidney_right (4) at +x: ellipsoids, enhanced cortex (+170 HU), medulla (+45 HU)
//   liver (8): ellipsoid on the patient's right (+60 HU); artery (9): aorta (+280 HU); venous_system (11): vena cava (+160 HU)
// Air is -1000 HU. Gaussian noise (deterministic per voxel) is added to the CT values.
#include <cstdint>
#include <optional>

#include <Eigen/Core>

#include "volume.h"

namespace handson {

namespace label {
constexpr std::uint8_t kBackground = 0, kBody = 1, kBone = 2, kKidneyLeft = 3, kKidneyRight = 4, kLiver = 8, kArtery = 9,
                       kVenous = 11;
}

struct PhantomOptions {
  double spacingMm = 2.0;   ///< isotropic voxel size
  double noiseHu = 12.0;    ///< standard deviation of the added noise
  std::uint32_t seed = 1;
};

struct PhantomGeometry {
  // Field of view (mm), centred on the origin.
  Eigen::Vector3d fov{384.0, 288.0, 240.0};
  // Body: elliptic cylinder along z.
  double bodyA = 165.0, bodyB = 120.0, fatThickness = 18.0, muscleThickness = 12.0;
  // Vertebral body: cylinder along z.
  Eigen::Vector2d vertebraCenter{0.0, -75.0};
  double vertebraRadius = 22.0, corticalThickness = 2.5;
  double discPeriod = 34.0, discThickness = 7.0;
  Eigen::Vector2d canalCenter{0.0, -108.0};
  double canalRadius = 9.0, archRadius = 16.0;
  // Kidneys: ellipsoids.
  Eigen::Vector3d kidneyLeftCenter{-78.0, -55.0, -10.0}, kidneyRightCenter{78.0, -55.0, -14.0};
  Eigen::Vector3d kidneyRadii{28.0, 24.0, 55.0};
  double cortexThickness = 7.0;
  // Vessels: cylinders along z.
  Eigen::Vector2d aortaCenter{-18.0, -42.0};
  double aortaRadius = 11.0;
  Eigen::Vector2d cavaCenter{22.0, -40.0};
  double cavaRadius = 13.0;
  // Liver: ellipsoid.
  Eigen::Vector3d liverCenter{70.0, 20.0, 55.0}, liverRadii{80.0, 70.0, 65.0};

  /// Noise-free CT value and label at a world point.
  float huAt(const Eigen::Vector3d& p) const;
  std::uint8_t labelAt(const Eigen::Vector3d& p) const;
  /// First intersection (ray parameter, origin + t*dir, dir need not be unit) of a ray with the
  /// body's outer surface (the elliptic cylinder) within |z| <= fov.z/2; nullopt on a miss.
  std::optional<double> intersectBody(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir) const;
  /// First intersection with the aorta's surface (a cylinder), same conventions.
  std::optional<double> intersectAorta(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir) const;
};

struct Phantom {
  Volume ct;      ///< int16 HU
  Volume labels;  ///< uint8
  PhantomGeometry geometry;
};

/// Builds the phantom on a grid covering geometry.fov at the requested spacing.
Phantom makePhantom(const PhantomOptions& options = {}, const PhantomGeometry& geometry = {});

}  // namespace handson
