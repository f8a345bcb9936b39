#include "phantom.h"

#include <cmath>
#include <thread>
#include <vector>

#include "sim/base/error.h"

namespace handson {

namespace {

constexpr float kAir = -1000.0f;

// Inside an axis-aligned ellipse / ellipsoid scaled inwards by `inset` mm (approximate offset
// surface: radii shrink by inset).
bool inEllipse(double x, double y, double a, double b, double inset = 0.0) {
  const double aa = a - inset, bb = b - inset;
  if (aa <= 0 || bb <= 0) return false;
  return (x * x) / (aa * aa) + (y * y) / (bb * bb) <= 1.0;
}

bool inEllipsoid(const Eigen::Vector3d& p, const Eigen::Vector3d& c, const Eigen::Vector3d& r, double inset = 0.0) {
  const Eigen::Vector3d rr = r.array() - inset;
  if ((rr.array() <= 0).any()) return false;
  return ((p - c).array() / rr.array()).square().sum() <= 1.0;
}

bool inCircle(double x, double y, const Eigen::Vector2d& c, double r) {
  const double dx = x - c.x(), dy = y - c.y();
  return dx * dx + dy * dy <= r * r;
}

// Deterministic standard normal from a voxel index and seed (hash + Box-Muller), so the phantom
// is identical on every platform and thread count.
float gaussian(std::uint64_t index, std::uint32_t seed) {
  auto mix = [](std::uint64_t z) {
    z += 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  };
  const std::uint64_t h1 = mix(index * 2 + (std::uint64_t(seed) << 40));
  const std::uint64_t h2 = mix(index * 2 + 1 + (std::uint64_t(seed) << 40));
  const double u1 = (double(h1 >> 11) + 1.0) / 9007199254740993.0;  // (0, 1]
  const double u2 = double(h2 >> 11) / 9007199254740992.0;
  return float(std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * 3.14159265358979323846 * u2));
}

// Smallest t >= 0 where origin + t*dir enters the quadric region q(t) = A t^2 + B t + C <= 0.
std::optional<double> firstEntry(double A, double B, double C) {
  if (C <= 0.0) return 0.0;  // starts inside
  if (A <= 0.0) return std::nullopt;
  const double disc = B * B - 4 * A * C;
  if (disc < 0.0) return std::nullopt;
  const double t = (-B - std::sqrt(disc)) / (2 * A);
  if (t < 0.0) return std::nullopt;
  return t;
}

}  // namespace

float PhantomGeometry::huAt(const Eigen::Vector3d& p) const {
  const double x = p.x(), y = p.y(), z = p.z();
  if (!inEllipse(x, y, bodyA, bodyB)) return kAir;
  float hu = -100.0f;  // subcutaneous fat
  if (inEllipse(x, y, bodyA, bodyB, fatThickness)) hu = 50.0f;                      // muscle wall
  if (inEllipse(x, y, bodyA, bodyB, fatThickness + muscleThickness)) hu = 10.0f;    // cavity
  if (inEllipsoid(p, liverCenter, liverRadii) && inEllipse(x, y, bodyA, bodyB, fatThickness + muscleThickness)) hu = 60.0f;
  for (const Eigen::Vector3d& c : {kidneyLeftCenter, kidneyRightCenter})
    if (inEllipsoid(p, c, kidneyRadii)) hu = inEllipsoid(p, c, kidneyRadii, cortexThickness) ? 45.0f : 170.0f;
  if (inCircle(x, y, cavaCenter, cavaRadius)) hu = 160.0f;
  if (inCircle(x, y, aortaCenter, aortaRadius)) hu = 280.0f;
  // Spine: vertebral body with discs, posterior arch around the canal.
  if (inCircle(x, y, vertebraCenter, vertebraRadius)) {
    const double phase = std::fmod(std::fmod(z, discPeriod) + discPeriod, discPeriod);
    if (phase < discThickness) hu = 90.0f;
    else hu = inCircle(x, y, vertebraCenter, vertebraRadius - corticalThickness) ? 250.0f : 900.0f;
  }
  if (inCircle(x, y, canalCenter, archRadius)) hu = inCircle(x, y, canalCenter, canalRadius) ? 10.0f : 700.0f;
  return hu;
}

std::uint8_t PhantomGeometry::labelAt(const Eigen::Vector3d& p) const {
  const double x = p.x(), y = p.y();
  if (!inEllipse(x, y, bodyA, bodyB)) return label::kBackground;
  std::uint8_t l = label::kBody;
  if (inEllipsoid(p, liverCenter, liverRadii) && inEllipse(x, y, bodyA, bodyB, fatThickness + muscleThickness)) l = label::kLiver;
  if (inEllipsoid(p, kidneyLeftCenter, kidneyRadii)) l = label::kKidneyLeft;
  if (inEllipsoid(p, kidneyRightCenter, kidneyRadii)) l = label::kKidneyRight;
  if (inCircle(x, y, cavaCenter, cavaRadius)) l = label::kVenous;
  if (inCircle(x, y, aortaCenter, aortaRadius)) l = label::kArtery;
  if (inCircle(x, y, vertebraCenter, vertebraRadius)) l = label::kBone;
  if (inCircle(x, y, canalCenter, archRadius) && !inCircle(x, y, canalCenter, canalRadius)) l = label::kBone;
  if (inCircle(x, y, canalCenter, canalRadius)) l = label::kBody;
  return l;
}

std::optional<double> PhantomGeometry::intersectBody(const Eigen::Vector3d& o, const Eigen::Vector3d& d) const {
  // (ox + t dx)^2 / a^2 + (oy + t dy)^2 / b^2 - 1 <= 0
  const double ia = 1.0 / (bodyA * bodyA), ib = 1.0 / (bodyB * bodyB);
  const double A = d.x() * d.x() * ia + d.y() * d.y() * ib;
  const double B = 2 * (o.x() * d.x() * ia + o.y() * d.y() * ib);
  const double C = o.x() * o.x() * ia + o.y() * o.y() * ib - 1.0;
  auto t = firstEntry(A, B, C);
  if (t && std::abs(o.z() + *t * d.z()) > 0.5 * fov.z()) return std::nullopt;
  return t;
}

std::optional<double> PhantomGeometry::intersectAorta(const Eigen::Vector3d& o, const Eigen::Vector3d& d) const {
  const double ox = o.x() - aortaCenter.x(), oy = o.y() - aortaCenter.y();
  const double A = d.x() * d.x() + d.y() * d.y();
  const double B = 2 * (ox * d.x() + oy * d.y());
  const double C = ox * ox + oy * oy - aortaRadius * aortaRadius;
  auto t = firstEntry(A, B, C);
  if (t && std::abs(o.z() + *t * d.z()) > 0.5 * fov.z()) return std::nullopt;
  return t;
}

Phantom makePhantom(const PhantomOptions& options, const PhantomGeometry& geometry) {
  if (!(options.spacingMm >= 0.25 && options.spacingMm <= 50.0))
    throw Error("phantom spacing must be between 0.25 and 50 mm");
  if (!(options.noiseHu >= 0.0 && options.noiseHu <= 500.0)) throw Error("phantom noise must be between 0 and 500 HU");
  VolumeGeometry g;
  for (int a = 0; a < 3; ++a) g.dims[a] = std::max(1, int(std::lround(geometry.fov[a] / options.spacingMm)));
  g.spacing = Eigen::Vector3d::Constant(options.spacingMm);
  g.direction = Eigen::Matrix3d::Identity();
  // Centre the grid on the origin: voxel centres at origin + spacing * index.
  g.origin = -0.5 * (g.dims.cast<double>() - Eigen::Vector3d::Ones()) * options.spacingMm;
  Phantom ph{Volume(g, ScalarType::Int16), Volume(g, ScalarType::UInt8), geometry};
  std::int16_t* ct = ph.ct.data<std::int16_t>();
  std::uint8_t* lab = ph.labels.data<std::uint8_t>();
  const int nz = g.dims.z();
  auto slab = [&](int k0, int k1) {
    for (int k = k0; k < k1; ++k)
      for (int j = 0; j < g.dims.y(); ++j)
        for (int i = 0; i < g.dims.x(); ++i) {
          const Eigen::Vector3d p = g.toWorld(Eigen::Vector3d(i, j, k));
          const std::size_t idx = ph.ct.linearIndex(i, j, k);
          const float hu = geometry.huAt(p) + float(options.noiseHu) * gaussian(idx, options.seed);
          ct[idx] = std::int16_t(std::lround(std::clamp(hu, -1024.0f, 3071.0f)));
          lab[idx] = geometry.labelAt(p);
        }
  };
  const int threads = int(std::max(1u, std::min(8u, std::thread::hardware_concurrency())));
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) pool.emplace_back(slab, nz * t / threads, nz * (t + 1) / threads);
  for (auto& th : pool) th.join();
  return ph;
}

}  // namespace handson
