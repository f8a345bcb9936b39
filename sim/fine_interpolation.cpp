#include "fine_interpolation.h"

#include <Eigen/Geometry>
#include <string>

#include "sim/coarsening.h"
#include "sim/base/error.h"

namespace handson {

std::size_t FineInterpolationData::staticBytes() const {
  return node.size() * 16 + rest.size() * 16 + blocks.size() * 16 + elementCorners.size() * 16 + coarseRest.size() * 16;
}

std::size_t CoarseFrameState::bytes() const { return positions.size() * 16 + rotations.size() * 16 + handles.size() * 64; }

CoarseFrameState packFrameState(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Matrix3d>& R, const std::vector<RigidTransform>& handles) {
  CoarseFrameState s;
  s.positions.reserve(x.size());
  for (const auto& p : x) {
    if (!p.allFinite()) throw Error("deformation state: a coarse node position is not finite");
    s.positions.emplace_back(float(p.x()), float(p.y()), float(p.z()), 1.0f);
  }
  s.rotations.reserve(R.size());
  for (const auto& r : R) {
    if (!r.allFinite()) throw Error("deformation state: an element rotation is not finite");
    Eigen::Quaterniond q(r);
    q.normalize();
    s.rotations.emplace_back(float(q.x()), float(q.y()), float(q.z()), float(q.w()));
  }
  for (const auto& h : handles) {
    if (!h.R.allFinite() || !h.t.allFinite()) throw Error("deformation state: a handle transform is not finite");
    s.handles.push_back(h.matrix().cast<float>());
  }
  return s;
}

Eigen::Matrix3f quaternionMatrix(const Eigen::Vector4f& q) {
  // Same expression as quatToMat3 in shaders/deform_interpolate.comp.
  const float n = q.dot(q);
  const float s = n > 0.0f ? 2.0f / n : 0.0f;
  const float x = q.x(), y = q.y(), z = q.z(), w = q.w();
  Eigen::Matrix3f m;
  m << 1.0f - s * (y * y + z * z), s * (x * y - w * z), s * (x * z + w * y),  //
      s * (x * y + w * z), 1.0f - s * (x * x + z * z), s * (y * z - w * x),   //
      s * (x * z - w * y), s * (y * z + w * x), 1.0f - s * (x * x + y * y);
  return m;
}

namespace {
Eigen::Matrix3f block3(const std::vector<Eigen::Vector4f>& b, std::size_t o) {
  Eigen::Matrix3f m;
  for (int c = 0; c < 3; ++c) m.col(c) = b[o + std::size_t(c)].head<3>();
  return m;
}
}  // namespace

std::vector<Eigen::Vector4f> interpolateFineReference(const FineInterpolationData& d, const CoarseFrameState& s, const Eigen::Matrix4f& w2i) {
  if (d.cornersPerElement != 4 && d.cornersPerElement != 8) throw Error("deformation: elements have 4 or 8 corners");
  if (s.positions.size() != d.coarseRest.size() || s.rotations.size() != d.elementCount() || s.handles.size() != d.handleCount)
    throw Error("deformation state: sizes do not match the mesh (" + std::to_string(s.positions.size()) + " coarse nodes, " +
                std::to_string(s.rotations.size()) + " rotations, " + std::to_string(s.handles.size()) + " handles)");
  std::vector<Eigen::Vector4f> out(d.node.size());
  for (std::size_t f = 0; f < d.node.size(); ++f) {
    const auto& n = d.node[f];
    const Eigen::Vector3f X = d.rest[f].head<3>();
    Eigen::Vector3f p = X;
    switch (n[0]) {
      case FineInterpolationData::Handle: p = s.handles[n[1]].topLeftCorner<3, 3>() * X + s.handles[n[1]].topRightCorner<3, 1>(); break;
      case FineInterpolationData::Corner: p = s.positions[n[1]].head<3>(); break;
      case FineInterpolationData::Boundary: {
        p.setZero();
        for (std::uint32_t c = 0; c < d.cornersPerElement; ++c)
          p += d.blocks[n[2] + c / 4][int(c % 4)] * s.positions[d.elementCorners[2 * n[1] + c / 4][c % 4]].head<3>();
        break;
      }
      case FineInterpolationData::Interior: {
        const Eigen::Matrix3f R = quaternionMatrix(s.rotations[n[1]]);
        const Eigen::Matrix3f Rt = R.transpose();
        Eigen::Vector3f q = X;
        std::size_t o = n[2];
        for (std::uint32_t c = 0; c < d.cornersPerElement; ++c, o += 3) {
          const std::uint32_t v = d.elementCorners[2 * n[1] + c / 4][c % 4];
          q += block3(d.blocks, o) * (Rt * s.positions[v].head<3>() - d.coarseRest[v].head<3>());
        }
        for (std::uint32_t g = 0; g < n[3]; ++g) {
          const float hidx = d.blocks[o].x();
          if (!(hidx == -1.0f || (hidx >= 0.0f && hidx < float(s.handles.size())))) throw Error("deformation: a handle block refers to a missing handle");
          const Eigen::Matrix4f T = hidx < 0.0f ? Eigen::Matrix4f::Identity() : s.handles[std::size_t(hidx)];  // -1: the anchor
          ++o;
          const Eigen::Matrix3f M = Rt * T.topLeftCorner<3, 3>() - Eigen::Matrix3f::Identity();
          for (int j = 0; j < 3; ++j, o += 3) q += block3(d.blocks, o) * M.col(j);
          q += block3(d.blocks, o) * (Rt * T.topRightCorner<3, 1>());
          o += 3;
        }
        p = R * q;
        break;
      }
      default: break;
    }
    out[f] << (w2i.topLeftCorner<3, 3>() * p + w2i.topRightCorner<3, 1>()), 1.0f;
  }
  return out;
}

}  // namespace handson
