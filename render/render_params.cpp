#include "render_params.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <sstream>

#include "sim/base/error.h"
#include "volume_texture.h"

namespace handson {

glm::mat4 toGlm(const Eigen::Matrix4d& m) {
  glm::mat4 out;
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) out[c][r] = float(m(r, c));
  return out;
}

namespace {

/// Comma-separated finite numbers, exactly n of them (double, then float: both must be finite).
bool clipNumbers(const std::string& text, std::size_t n, std::vector<float>& out) {
  out.clear();
  std::istringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    char* end = nullptr;
    const double v = std::strtod(item.c_str(), &end);
    if (item.empty() || end == item.c_str() || *end != '\0' || !std::isfinite(v) || !std::isfinite(float(v))) return false;
    out.push_back(float(v));
  }
  return out.size() == n && !text.empty() && text.back() != ',';
}

}  // namespace

std::string parseClipBox(const std::string& text, ClipRegion& clip) {
  std::vector<float> v;
  if (!clipNumbers(text, 6, v)) return "a clip box takes six finite numbers X0,Y0,Z0,X1,Y1,Z1 (RAS mm)";
  if (!(v[0] < v[3] && v[1] < v[4] && v[2] < v[5])) return "a clip box's low corner must be below its high corner on every axis";
  clip.box = true;
  clip.lo = {v[0], v[1], v[2]};
  clip.hi = {v[3], v[4], v[5]};
  return "";
}

std::string parseClipPlane(const std::string& text, ClipRegion& clip) {
  std::vector<float> v;
  if (!clipNumbers(text, 4, v)) return "a clip plane takes four finite numbers NX,NY,NZ,D (keeps n.x >= D, RAS mm)";
  const glm::vec3 n(v[0], v[1], v[2]);
  if (!(glm::length(n) > 1e-6f) || !std::isfinite(glm::length(n))) return "a clip plane's normal NX,NY,NZ must not be zero";
  clip.plane = true;
  clip.normal = n;
  clip.offset = v[3];
  return "";
}

std::string formatClipBox(const ClipRegion& c) {
  std::ostringstream s;
  s << std::setprecision(9) << c.lo.x << "," << c.lo.y << "," << c.lo.z << "," << c.hi.x << "," << c.hi.y << "," << c.hi.z;
  return s.str();
}

std::string formatClipPlane(const ClipRegion& c) {
  std::ostringstream s;
  s << std::setprecision(9) << c.normal.x << "," << c.normal.y << "," << c.normal.z << "," << c.offset;
  return s.str();
}

gpu::RenderParams makeRenderParams(const VolumeGeometry& geometry, const glm::mat4& view, const glm::mat4& proj,
                                   const glm::vec3& eye, const RenderSettings& s, std::uint32_t pickCount) {
  if (s.width <= 0 || s.height <= 0 || s.width > 16384 || s.height > 16384)
    throw Error("image size must be between 1x1 and 16384x16384");
  if (!(s.stepFactor > 0.0f) || !std::isfinite(s.stepFactor)) throw Error("ray step factor must be > 0");
  gpu::RenderParams p{};
  const glm::mat4 viewProj = proj * view;
  p.invViewProj = glm::inverse(viewProj);
  p.worldToIndex = toGlm(geometry.worldToIndex());
  p.indexToWorld = toGlm(geometry.indexToWorld());
  p.eye = eye;
  int bx, by, bz;
  brickDims(geometry.dims, bx, by, bz);
  p.volumeDims = glm::ivec3(geometry.dims.x(), geometry.dims.y(), geometry.dims.z());
  p.outputWidth = s.width;
  p.brickCount = glm::ivec3(bx, by, bz);
  p.outputHeight = s.height;
  const float step = float(geometry.spacing.minCoeff()) * s.stepFactor;
  p.stepMm = step;
  p.opacityStepMm = 1.0f;
  p.earlyStopAlpha = s.terminationAlpha;
  p.pickAlpha = s.pickThreshold;
  p.pickFaintAlpha = std::min(s.pickFaintThreshold, s.pickThreshold);
  p.background = s.background;
  p.ambient = s.light.x;
  p.diffuse = s.light.y;
  p.specular = s.light.z;
  p.shininess = s.light.w;
  std::uint32_t flags = 0;
  if (s.emptySpaceSkipping) flags |= gpu::kFlagEmptySpaceSkipping;
  if (s.earlyTermination) flags |= gpu::kFlagEarlyTermination;
  if (s.shading) flags |= gpu::kFlagShading;
  if (s.strainOverlay) flags |= gpu::kFlagStrainOverlay;
  if (s.limitHighlight) flags |= gpu::kFlagLimitHighlight;
  if (s.labelTint) flags |= gpu::kFlagLabelTint;
  if (s.jitter) flags |= gpu::kFlagJitter;
  if (s.clip.box) {
    flags |= gpu::kFlagClipBox;
    p.clipMin = glm::vec4(glm::min(s.clip.lo, s.clip.hi), 0.0f);
    p.clipMax = glm::vec4(glm::max(s.clip.lo, s.clip.hi), 0.0f);
  }
  const float nlen = glm::length(s.clip.normal);
  if (s.clip.plane && nlen > 0.0f && std::isfinite(nlen)) {
    flags |= gpu::kFlagClipPlane;
    p.clipPlane = glm::vec4(s.clip.normal / nlen, s.clip.offset / nlen);
  }
  p.strainFrom = s.strainFrom;
  p.strainTo = s.strainTo;
  p.strainWeight = s.strainWeight;
  p.stepScale = std::isfinite(s.raymarchStepScale) && s.raymarchStepScale >= 1.0f ? s.raymarchStepScale : 1.0f;
  p.jitterPhase = std::uint32_t(std::clamp(s.jitterPhase, 0, int(gpu::kJitterTile * gpu::kJitterTile) - 1));
  const double diag = geometry.diagonalMm();
  p.flags = flags;
  p.pickCount = pickCount;
  p.maxSteps = std::uint32_t(std::ceil(diag / step)) * 2u + 64u;
  p.movingCount = 0;
  return p;
}

void setMovingHandles(gpu::RenderParams& params, const VolumeGeometry& geometry, const std::vector<MovingHandlePose>& handles) {
  std::uint32_t n = 0;
  const Eigen::Matrix4d i2w = geometry.indexToWorld(), w2i = geometry.worldToIndex();
  for (const auto& h : handles) {
    if (n >= gpu::kMaxMovingHandles) break;
    if (h.pose.isIdentity()) continue;
    Eigen::Matrix4d inv = Eigen::Matrix4d::Identity();  // world now -> world at rest
    inv.block<3, 3>(0, 0) = h.pose.R.transpose();
    inv.block<3, 1>(0, 3) = -h.pose.R.transpose() * h.pose.t;
    params.moving[n].currentToRest = toGlm(w2i * inv * i2w);
    params.moving[n].id = glm::uvec4(h.id, 0, 0, 0);
    // Where the handle is now: its rest bounds' corners moved, with a voxel and a half of margin
    // (trilinear support and rounding); empty-space skipping keeps those bricks.
    Eigen::Matrix4d fwd = Eigen::Matrix4d::Identity();
    fwd.block<3, 3>(0, 0) = h.pose.R;
    fwd.block<3, 1>(0, 3) = h.pose.t;
    const Eigen::Matrix4d restToCurrent = w2i * fwd * i2w;
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e30), hi = Eigen::Vector3d::Constant(-1e30);
    const bool bounded = (h.restMin.array() <= h.restMax.array()).all();
    for (int c = 0; c < 8; ++c) {
      const Eigen::Vector3d corner((c & 1) ? h.restMax.x() : h.restMin.x(), (c & 2) ? h.restMax.y() : h.restMin.y(),
                                   (c & 4) ? h.restMax.z() : h.restMin.z());
      const Eigen::Vector3d p = (restToCurrent * corner.homogeneous()).head<3>();
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    if (!bounded) {  // unknown extent: the whole volume
      lo = Eigen::Vector3d::Constant(-1e30);
      hi = Eigen::Vector3d::Constant(1e30);
    }
    params.moving[n].boxMin = glm::vec4(glm::vec3(lo.x() - 1.5, lo.y() - 1.5, lo.z() - 1.5), 0.0f);
    params.moving[n].boxMax = glm::vec4(glm::vec3(hi.x() + 1.5, hi.y() + 1.5, hi.z() + 1.5), 0.0f);
    ++n;
  }
  params.movingCount = n;
}

void setStillPhase(gpu::RenderParams& params, int before, int phases) {
  if (phases < 1) throw Error("a still frame sums at least one jitter phase");
  params.flags |= gpu::kFlagAccumulate;
  const bool complete = before >= phases;
  params.jitterPhase = std::uint32_t(complete ? 0 : std::max(before, 0));  // unused once complete
  params.summedFrames = std::uint32_t(complete ? phases : std::max(before, 0));
  if (complete) params.flags |= gpu::kFlagShowSum;
  else params.flags &= ~gpu::kFlagShowSum;
}

glm::vec2 pixelToNdc(float x, float y, int width, int height) {
  return glm::vec2((x + 0.5f) / float(width) * 2.0f - 1.0f, (y + 0.5f) / float(height) * 2.0f - 1.0f);
}

}  // namespace handson
