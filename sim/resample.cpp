#include "resample.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <thread>
#include <vector>

#include "sim/base/error.h"

namespace handson {

VolumeGeometry resampledGeometry(const VolumeGeometry& g, std::size_t targetVoxels) {
  g.validate();
  if (targetVoxels == 0) throw Error("target voxel count must be positive");
  if (targetVoxels > kMaxVoxels) throw Error("target voxel count is larger than the supported maximum");
  const double factor = std::cbrt(double(targetVoxels) / double(g.voxelCount()));
  VolumeGeometry out = g;
  for (int a = 0; a < 3; ++a) {
    out.dims[a] = std::max(1, int(std::lround(g.dims[a] * factor)));
    // Same box: dims * spacing preserved.
    out.spacing[a] = g.spacing[a] * double(g.dims[a]) / double(out.dims[a]);
  }
  // The box's corner (edge of voxel 0) stays put: origin moves by half the spacing change.
  const Eigen::Vector3d corner = g.toWorld(Eigen::Vector3d::Constant(-0.5));
  out.origin = corner + out.direction * (0.5 * out.spacing);
  return out;
}

Volume resample(const Volume& v, const VolumeGeometry& target, const ProgressFn& progress) {
  if (v.empty()) throw Error("cannot resample an empty volume");
  target.validate();
  Volume out(target, v.type());
  const bool nearest = v.type() == ScalarType::UInt8;  // labels: never blend codes
  // Input index of output index: a (affine).
  const Eigen::Matrix4d m = v.geometry().worldToIndex() * target.indexToWorld();
  const Eigen::Matrix3d lin = m.block<3, 3>(0, 0);
  const Eigen::Vector3d off = m.block<3, 1>(0, 3);
  // Footprint of one output voxel in input voxels along each output axis.
  int samples[3];
  for (int a = 0; a < 3; ++a) {
    const double len = lin.col(a).norm();
    samples[a] = nearest ? 1 : std::clamp(int(std::ceil(len - 1e-9)), 1, 8);
  }
  const int nz = target.dims.z();
  std::atomic<int> done{0};
  auto work = [&](int k0, int k1) {
    for (int k = k0; k < k1; ++k) {
      for (int j = 0; j < target.dims.y(); ++j)
        for (int i = 0; i < target.dims.x(); ++i) {
          const Eigen::Vector3d c = lin * Eigen::Vector3d(i, j, k) + off;
          float value;
          if (nearest) {
            const Eigen::Vector3i n = c.array().round().cast<int>();
            value = v.valueClamped(n.x(), n.y(), n.z());
          } else {
            double acc = 0.0;
            for (int sz = 0; sz < samples[2]; ++sz)
              for (int sy = 0; sy < samples[1]; ++sy)
                for (int sx = 0; sx < samples[0]; ++sx) {
                  const Eigen::Vector3d f((sx + 0.5) / samples[0] - 0.5, (sy + 0.5) / samples[1] - 0.5, (sz + 0.5) / samples[2] - 0.5);
                  acc += v.sampleLinear(c + lin * f);
                }
            value = float(acc / (samples[0] * samples[1] * samples[2]));
          }
          out.setValue(i, j, k, value);
        }
      const int d = ++done;
      if (progress && k0 == 0) reportProgress(progress, double(d) / nz, "resampling");
    }
  };
  const int threads = int(std::max(1u, std::min(8u, std::thread::hardware_concurrency())));
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) pool.emplace_back(work, nz * t / threads, nz * (t + 1) / threads);
  for (auto& th : pool) th.join();
  reportProgress(progress, 1.0, "resampling");
  return out;
}

Volume resampleToVoxelCount(const Volume& v, std::size_t targetVoxels, const ProgressFn& progress) {
  return resample(v, resampledGeometry(v.geometry(), targetVoxels), progress);
}

}  // namespace handson
