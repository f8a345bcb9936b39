#include "raymarch_reference.h"

#include <algorithm>
#include <cmath>
#include <thread>

#include "blue_noise.h"
#include "sim/base/error.h"

namespace handson {

namespace {

static_assert(gpu::kJitterTile == kBlueNoiseSize, "the raymarch's jitter tile is the blue-noise tile");

// Where, as a fraction of the step, pixel (x, y)'s first sample lies (shaders/raymarch.comp,
// sampleOffset): the middle of the first step, or its blue-noise rank shifted by the jitter phase.
float sampleOffset(const gpu::RenderParams& P, int x, int y) {
  if (!(P.flags & gpu::kFlagJitter)) return 0.5f;
  const std::uint32_t tile = std::uint32_t(gpu::kJitterTile);
  const std::uint32_t rank = blueNoiseRanks()[(std::uint32_t(y) % tile) * tile + std::uint32_t(x) % tile];
  const std::uint32_t shifted = (rank + std::uint32_t(P.jitterPhase) * std::uint32_t(gpu::kJitterPhaseStep)) % (tile * tile);
  return (float(shifted) + 0.5f) / float(tile * tile);
}

struct Sampler {
  const QuantizedVolume& v;
  const TfTable& lut;
  const std::vector<std::uint32_t>& occ;
  const gpu::RenderParams& P;
  const std::vector<std::uint8_t>* mask;
  const std::vector<glm::vec4>* tints;
  const std::vector<float>* strain;
  const std::vector<std::uint16_t>* labels;
  const std::vector<float>* overLimit;

  // As raymarch.comp's labelTint.
  glm::vec3 labelTint(glm::vec3 c, glm::vec3 idx) const {
    static constexpr float kPalette[3 * gpu::kLabelPaletteSize] = {HANDSON_LABEL_PALETTE};
    if (!labels) return c;
    const auto& d = v.geometry.dims;
    const glm::ivec3 q = glm::clamp(glm::ivec3(glm::floor(idx + 0.5f)), glm::ivec3(0), glm::ivec3(d.x(), d.y(), d.z()) - 1);
    const std::uint32_t l = (*labels)[std::size_t(q.x) + std::size_t(d.x()) * (std::size_t(q.y) + std::size_t(d.y()) * std::size_t(q.z))];
    if (l == 0) return c;
    const std::uint32_t k = 3 * (l % gpu::kLabelPaletteSize);
    return glm::mix(c, glm::vec3(kPalette[k], kPalette[k + 1], kPalette[k + 2]), float(HANDSON_LABEL_TINT_WEIGHT));
  }

  // As raymarch.comp's strainTint.
  glm::vec3 strainTint(glm::vec3 c, glm::vec3 idx) const {
    if (!strain) return c;
    const auto& d = v.geometry.dims;
    const glm::ivec3 q = glm::clamp(glm::ivec3(glm::floor(idx + 0.5f)), glm::ivec3(0), glm::ivec3(d.x(), d.y(), d.z()) - 1);
    const float e = (*strain)[std::size_t(q.x) + std::size_t(d.x()) * (std::size_t(q.y) + std::size_t(d.y()) * std::size_t(q.z))];
    if (!(e > P.strainFrom)) return c;
    const float w = glm::clamp((e - P.strainFrom) / std::max(P.strainTo - P.strainFrom, 1e-6f), 0.0f, 1.0f);
    const glm::vec3 ramp = glm::mix(glm::vec3(1.0f, 0.85f, 0.1f), glm::vec3(0.9f, 0.05f, 0.05f), w);
    return glm::mix(c, ramp, P.strainWeight * (0.25f + 0.75f * w));
  }

  // As raymarch.comp's limitTint.
  glm::vec3 limitTint(glm::vec3 c, glm::vec3 idx) const {
    if (!overLimit) return c;
    const auto& d = v.geometry.dims;
    const glm::ivec3 q = glm::clamp(glm::ivec3(glm::floor(idx + 0.5f)), glm::ivec3(0), glm::ivec3(d.x(), d.y(), d.z()) - 1);
    if (!((*overLimit)[std::size_t(q.x) + std::size_t(d.x()) * (std::size_t(q.y) + std::size_t(d.y()) * std::size_t(q.z))] > 1.0f)) return c;
    return glm::mix(c, glm::vec3(HANDSON_LIMIT_COLOUR), float(HANDSON_LIMIT_WEIGHT));
  }

  std::uint32_t handleAt(glm::vec3 idx) const {
    if (!mask) return 0;
    const auto& d = v.geometry.dims;
    const glm::ivec3 c = glm::clamp(glm::ivec3(glm::floor(idx + 0.5f)), glm::ivec3(0), glm::ivec3(d.x(), d.y(), d.z()) - 1);
    return (*mask)[std::size_t(c.x) + std::size_t(d.x()) * (std::size_t(c.y) + std::size_t(d.y()) * std::size_t(c.z))];
  }

  float texel(int i, int j, int k) const {
    const auto& d = v.geometry.dims;
    i = std::clamp(i, 0, d.x() - 1);
    j = std::clamp(j, 0, d.y() - 1);
    k = std::clamp(k, 0, d.z() - 1);
    return float(v.data[std::size_t(i) + std::size_t(d.x()) * (std::size_t(j) + std::size_t(d.y()) * std::size_t(k))]) / 65535.0f;
  }
  // Vulkan linear filtering at texture coordinate (idx + 0.5) / dims: texel space x = idx.
  bool isMoving(std::uint32_t id) const {
    for (std::uint32_t m = 0; m < P.movingCount; ++m)
      if (P.moving[m].id.x == id) return true;
    return false;
  }
  // As march_common.glsl's materialAt: moved handles leave their place empty and bring their
  // material along. Negative: nothing here.
  float materialAt(glm::vec3 idx, std::uint32_t& id) const {
    id = handleAt(idx);
    float val = sample(idx);
    if (P.movingCount == 0) return val;
    if (id != 0 && isMoving(id)) {
      id = 0;
      val = -1.0f;
    }
    for (std::uint32_t m = 0; m < P.movingCount; ++m) {
      const glm::vec3 rest = glm::vec3(P.moving[m].currentToRest * glm::vec4(idx, 1.0f));
      if (handleAt(rest) == P.moving[m].id.x) {
        id = P.moving[m].id.x;
        val = sample(rest);
      }
    }
    return val;
  }
  float sample(glm::vec3 idx) const {
    const glm::vec3 f0 = glm::floor(idx);
    const glm::vec3 f = idx - f0;
    const int i = int(f0.x), j = int(f0.y), k = int(f0.z);
    float acc = 0.0f;
    for (int dz = 0; dz < 2; ++dz)
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
          const float w = (dx ? f.x : 1 - f.x) * (dy ? f.y : 1 - f.y) * (dz ? f.z : 1 - f.z);
          acc += w * texel(i + dx, j + dy, k + dz);
        }
    return acc;
  }
  // As march_common.glsl's transferRow, transfer, transfer2 and transferAt (the table's gradient
  // axis, gradientTop, is what the renderer puts in RenderParams.tfRowGradient).
  glm::vec4 transferRow(std::uint32_t row, float val) const {
    const float x = std::clamp(val, 0.0f, 1.0f) * float(gpu::kTfEntries - 1);
    const int i0 = int(std::floor(x));
    const int i1 = std::min(i0 + 1, int(gpu::kTfEntries) - 1);
    const std::size_t base = std::size_t(row) * gpu::kTfEntries;
    return glm::mix(lut.entries[base + std::size_t(i0)], lut.entries[base + std::size_t(i1)], x - float(i0));
  }
  glm::vec4 transfer(float val) const { return transferRow(0, val); }
  glm::vec4 transfer2(float val, float g) const {
    const float y = std::clamp(g / lut.gradientTop, 0.0f, 1.0f) * float(gpu::kTfGradientRows - 1);
    const std::uint32_t r0 = std::uint32_t(std::floor(y));
    const std::uint32_t r1 = std::min(r0 + 1u, gpu::kTfGradientRows - 1u);
    return glm::mix(transferRow(r0, val), transferRow(r1, val), y - float(r0));
  }
  glm::vec3 worldGradient(glm::vec3 idx) const { return glm::transpose(glm::mat3(P.worldToIndex)) * gradientIndex(idx); }
  bool transparentAtAnyGradient(float val) const { return transferRow(gpu::kTfGradientRows, val).a <= 0.0f; }
  glm::vec4 transferAt(glm::vec3 idx, float val) const {
    if (!(lut.gradientTop > 0.0f)) return transfer(val);
    if (transparentAtAnyGradient(val)) return glm::vec4(0.0f);
    return transfer2(val, glm::length(worldGradient(idx)));
  }
  bool setupRay(glm::vec2 ndc, glm::vec3& originW, glm::vec3& dirW, float& t0, float& t1) const {
    const glm::vec4 nearH = P.invViewProj * glm::vec4(ndc, 0.0f, 1.0f);
    const glm::vec4 farH = P.invViewProj * glm::vec4(ndc, 1.0f, 1.0f);
    originW = P.eye;
    dirW = glm::normalize(glm::vec3(farH) / farH.w - glm::vec3(nearH) / nearH.w);
    const glm::vec3 o = glm::vec3(P.worldToIndex * glm::vec4(originW, 1.0f));
    const glm::vec3 d = glm::mat3(P.worldToIndex) * dirW;
    const glm::vec3 lo(-0.5f), hi = glm::vec3(P.volumeDims) - 0.5f;
    const glm::vec3 inv = 1.0f / d;
    const glm::vec3 ta = (lo - o) * inv, tb = (hi - o) * inv;
    const glm::vec3 tmin = glm::min(ta, tb), tmax = glm::max(ta, tb);
    t0 = std::max(std::max(std::max(tmin.x, tmin.y), tmin.z), 0.0f);
    t1 = std::min(std::min(tmax.x, tmax.y), tmax.z);
    clipRay(originW, dirW, t0, t1);
    return t1 > t0;
  }
  // As march_common.glsl's clipRay.
  void clipRay(glm::vec3 originW, glm::vec3 dirW, float& t0, float& t1) const {
    const std::uint32_t flags = P.flags;
    if (flags & gpu::kFlagClipBox) {
      const glm::vec3 inv = 1.0f / dirW;
      const glm::vec3 ca = (glm::vec3(P.clipMin) - originW) * inv, cb = (glm::vec3(P.clipMax) - originW) * inv;
      const glm::vec3 cmin = glm::min(ca, cb), cmax = glm::max(ca, cb);
      t0 = std::max(t0, std::max(std::max(cmin.x, cmin.y), cmin.z));
      t1 = std::min(t1, std::min(std::min(cmax.x, cmax.y), cmax.z));
    }
    if (flags & gpu::kFlagClipPlane) {
      const float nd = glm::dot(glm::vec3(P.clipPlane), dirW), no = glm::dot(glm::vec3(P.clipPlane), originW);
      if (nd > 1e-12f) t0 = std::max(t0, (P.clipPlane.w - no) / nd);
      else if (nd < -1e-12f) t1 = std::min(t1, (P.clipPlane.w - no) / nd);
      else if (no < P.clipPlane.w) t1 = t0;
    }
  }
  bool brickOccupied(glm::vec3 idx, glm::ivec3& brick) const {
    brick = glm::clamp(glm::ivec3(glm::floor((idx + 0.5f) / float(gpu::kBrickSize))), glm::ivec3(0), P.brickCount - 1);
    if (occ[std::size_t((brick.z * P.brickCount.y + brick.y) * P.brickCount.x + brick.x)] != 0u) return true;
    const glm::vec3 lo = glm::vec3(brick) * float(gpu::kBrickSize) - 0.5f, hi = lo + float(gpu::kBrickSize);
    for (std::uint32_t m = 0; m < P.movingCount; ++m)
      if (glm::all(glm::lessThanEqual(glm::vec3(P.moving[m].boxMin), hi)) && glm::all(glm::greaterThanEqual(glm::vec3(P.moving[m].boxMax), lo)))
        return true;
    return false;
  }
  float brickExit(glm::vec3 o, glm::vec3 d, glm::ivec3 brick) const {
    const glm::vec3 lo = glm::vec3(brick) * float(gpu::kBrickSize) - 0.5f;
    const glm::vec3 hi = lo + float(gpu::kBrickSize);
    const glm::vec3 inv = 1.0f / d;
    const glm::vec3 tmax = glm::max((lo - o) * inv, (hi - o) * inv);
    return std::min(std::min(tmax.x, tmax.y), tmax.z);
  }
  float correctedAlpha(float a, float step) const { return 1.0f - std::pow(std::max(1.0f - a, 0.0f), step / P.opacityStepMm); }
  glm::vec3 gradientIndex(glm::vec3 idx) const {
    return 0.5f * glm::vec3(sample(idx + glm::vec3(1, 0, 0)) - sample(idx - glm::vec3(1, 0, 0)),
                            sample(idx + glm::vec3(0, 1, 0)) - sample(idx - glm::vec3(0, 1, 0)),
                            sample(idx + glm::vec3(0, 0, 1)) - sample(idx - glm::vec3(0, 0, 1)));
  }

  // A ray's samples in index space: sample n at o + (t0 + (n + offset) step) d.
  struct RaySamples {
    glm::vec3 o, d;
    float t0, step, offset;
    float at(std::uint32_t n) const { return t0 + (float(n) + offset) * step; }
  };
  // Where a ray is: its next sample and the distance up to which its current brick is occupied.
  struct RayCursor {
    std::uint32_t n = 0;
    float occupiedUntil = -1.0f;
  };

  // Advances the cursor's sample past an empty brick; returns true if the sample at `idx` (the
  // cursor's) must be skipped. For an occupied brick, sets occupiedUntil to the ray distance where
  // it is left.
  bool skip(const RaySamples& r, glm::vec3 idx, RayCursor& c) const {
    glm::ivec3 brick;
    const bool occupied = brickOccupied(idx, brick);
    const float te = brickExit(r.o, r.d, brick);
    if (occupied) {
      c.occupiedUntil = te;
      return false;
    }
    c.n = std::max(c.n + 1u, std::uint32_t(std::ceil((te - r.t0) / r.step - r.offset)));
    return true;
  }

  glm::vec4 shadePixel(glm::vec2 ndc, float offset) const {
    const std::uint32_t flags = P.flags;
    glm::vec3 color(0.0f);
    float alpha = 0.0f;
    glm::vec3 originW, dirW;
    float t0, t1;
    if (setupRay(ndc, originW, dirW, t0, t1)) {
      const glm::vec3 o = glm::vec3(P.worldToIndex * glm::vec4(originW, 1.0f));
      const glm::vec3 d = glm::mat3(P.worldToIndex) * dirW;
      const float step = P.stepScale > 0.0f ? P.stepMm * P.stepScale : P.stepMm;
      const RaySamples ray{o, d, t0, step, offset};
      RayCursor cur;
      std::uint32_t taken = 0;
      while (taken < P.maxSteps) {
        const float t = ray.at(cur.n);
        if (t >= t1) break;
        const glm::vec3 idx = o + t * d;
        ++taken;
        if ((flags & gpu::kFlagEmptySpaceSkipping) && t >= cur.occupiedUntil && skip(ray, idx, cur)) continue;
        ++cur.n;
        std::uint32_t id = 0;
        const float value = materialAt(idx, id);
        if (value < 0.0f) continue;
        const bool overGradient = lut.gradientTop > 0.0f;  // the gradient once, for the table and the shading
        if (overGradient && transparentAtAnyGradient(value)) continue;
        glm::vec3 g = overGradient ? worldGradient(idx) : glm::vec3(0.0f);
        const glm::vec4 s = overGradient ? transfer2(value, glm::length(g)) : transfer(value);
        if (s.a <= 0.0f) continue;
        const float a = correctedAlpha(s.a, step);
        glm::vec3 c(s);
        if ((flags & gpu::kFlagLabelTint) && !isMoving(id)) c = labelTint(c, idx);
        if (id != 0 && tints) c = glm::mix(c, glm::vec3((*tints)[id]), (*tints)[id].a);
        if (flags & gpu::kFlagStrainOverlay) c = strainTint(c, idx);
        if (flags & gpu::kFlagLimitHighlight) c = limitTint(c, idx);
        if (flags & gpu::kFlagShading) {
          if (!overGradient) g = worldGradient(idx);
          const float gl = glm::length(g);
          if (gl > 1e-6f) {
            const float ndl = std::abs(glm::dot(g / gl, dirW));
            c = c * (P.ambient + P.diffuse * ndl) + glm::vec3(P.specular * std::pow(ndl, P.shininess));
          } else {
            c = c * (P.ambient + P.diffuse);
          }
        }
        color += (1.0f - alpha) * a * c;
        alpha += (1.0f - alpha) * a;
        if ((flags & gpu::kFlagEarlyTermination) && alpha >= P.earlyStopAlpha) break;
      }
    }
    const glm::vec3 out = color + (1.0f - alpha) * glm::vec3(P.background) * P.background.a;
    return glm::vec4(glm::clamp(out, 0.0f, 1.0f), 1.0f);
  }

  // pick.comp's handleBehind: the handle id just behind the surface point th (sample t), within reach.
  int handleBehind(glm::vec3 o, glm::vec3 d, float t, float th, float t1, float step) const {
    const float reach = std::min(th + std::max(float(HANDSON_PICK_HANDLE_REACH_MM), float(HANDSON_PICK_HANDLE_REACH_VOXELS) / std::max(glm::length(d), 1e-6f)), t1);
    for (std::uint32_t k = 1; k < 4096; ++k) {
      const float u = t + float(k) * step;
      if (u >= reach) break;
      std::uint32_t hid = 0;
      const float hv = materialAt(o + u * d, hid);
      if (hid != 0 && hv >= 0.0f && transferAt(o + u * d, hv).a > 0.0f) return int(hid);
    }
    return 0;
  }

  // Where a pick ray reports its surface (pick.comp): the sample t where the accumulated opacity
  // passes pickAlpha (the point th interpolated within its step), or, on a ray that ends fainter than
  // that but at least pickFaintAlpha opaque, its most visible sample.
  struct RayHit {
    bool hit = false;
    float t = 0.0f, th = 0.0f;
    std::uint32_t id = 0;
  };
  RayHit pickDepth(glm::vec3 o, glm::vec3 d, float t0, float t1) const {
    const float step = P.stepMm;
    float alpha = 0.0f, bestShare = 0.0f;
    RayHit best;
    const RaySamples ray{o, d, t0, step, 0.5f};
    RayCursor cur;
    std::uint32_t taken = 0;
    while (taken < P.maxSteps) {
      const float t = ray.at(cur.n);
      if (t >= t1) break;
      const glm::vec3 idx = o + t * d;
      ++taken;
      if (t >= cur.occupiedUntil && skip(ray, idx, cur)) continue;
      ++cur.n;
      std::uint32_t id = 0;
      const float value = materialAt(idx, id);
      if (value < 0.0f) continue;
      const glm::vec4 s = transferAt(idx, value);
      if (s.a <= 0.0f) continue;
      const float before = alpha, a = correctedAlpha(s.a, step);
      alpha += (1.0f - alpha) * a;
      if ((1.0f - before) * a > bestShare) {
        bestShare = (1.0f - before) * a;
        best = {true, t, std::max(t - 0.5f * step, t0), id};
      }
      if (alpha >= P.pickAlpha) {
        const float f = std::clamp((P.pickAlpha - before) / std::max(alpha - before, 1e-6f), 0.0f, 1.0f);
        return {true, t, std::max(t - step + f * step, t0), id};
      }
    }
    if (P.pickFaintAlpha > 0.0f && alpha >= P.pickFaintAlpha && bestShare > 0.0f) return best;
    return {};
  }

  gpu::PickResult pick(glm::vec2 ndc) const {
    gpu::PickResult r{};
    r.world = glm::vec4(0.0f);
    r.voxel = glm::ivec4(-1, -1, -1, 0);
    glm::vec3 originW, dirW;
    float t0, t1;
    if (std::isnan(ndc.x) || std::isnan(ndc.y) || !setupRay(ndc, originW, dirW, t0, t1)) return r;
    const glm::vec3 o = glm::vec3(P.worldToIndex * glm::vec4(originW, 1.0f));
    const glm::vec3 d = glm::mat3(P.worldToIndex) * dirW;
    const RayHit h = pickDepth(o, d, t0, t1);
    if (!h.hit) return r;
    r.world = glm::vec4(originW + h.th * dirW, 1.0f);
    r.voxel = glm::ivec4(glm::ivec3(glm::floor(o + h.th * d + 0.5f)), int(h.id));
    if (h.id == 0) r.voxel.w = handleBehind(o, d, h.t, h.th, t1, P.stepMm);  // a handle just behind the surface
    return r;
  }
};

}  // namespace

std::vector<std::uint8_t> raymarchReference(const ReferenceScene& scene, const gpu::RenderParams& params,
                                            std::vector<glm::vec3>* accumulation) {
  const Sampler s{*scene.volume, *scene.lut, *scene.occupancy, params, scene.mask, scene.handleTints, scene.strain, scene.labels, scene.strainOverLimit};
  const int w = params.outputWidth, h = params.outputHeight;
  std::vector<std::uint8_t> img(std::size_t(w) * h * 4);
  const bool accumulate = (params.flags & gpu::kFlagAccumulate) != 0;
  if (accumulate) {
    if (!accumulation) throw Error("raymarch reference: accumulation asked for without its sum");
    if (accumulation->size() != std::size_t(w) * h) accumulation->assign(std::size_t(w) * h, glm::vec3(0.0f));
  }
  auto rows = [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y)
      for (int x = 0; x < w; ++x) {
        const glm::vec2 ndc((float(x) + 0.5f) / float(w) * 2.0f - 1.0f, (float(y) + 0.5f) / float(h) * 2.0f - 1.0f);
        glm::vec4 c(0.0f, 0.0f, 0.0f, 1.0f);
        if (accumulate) {
          // raymarch.comp: the still frame's sum, this phase added unless it is complete; its mean shown.
          glm::vec3& sum = (*accumulation)[std::size_t(y) * w + x];
          if (params.flags & gpu::kFlagShowSum) {
            c = glm::vec4(glm::clamp(sum / float(params.summedFrames), 0.0f, 1.0f), 1.0f);
          } else {
            const glm::vec3 phase(s.shadePixel(ndc, sampleOffset(params, x, y)));
            sum = params.summedFrames > 0 ? sum + phase : phase;
            c = glm::vec4(glm::clamp(sum / (float(params.summedFrames) + 1.0f), 0.0f, 1.0f), 1.0f);
          }
        } else {
          c = s.shadePixel(ndc, sampleOffset(params, x, y));
        }
        std::uint8_t* p = &img[(std::size_t(y) * w + x) * 4];
        for (int ch = 0; ch < 4; ++ch) p[ch] = std::uint8_t(std::lround(c[ch] * 255.0f));
      }
  };
  const int threads = std::max(1u, std::min(8u, std::thread::hardware_concurrency()));
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) pool.emplace_back(rows, h * t / threads, h * (t + 1) / threads);
  for (auto& th : pool) th.join();
  return img;
}

std::vector<gpu::PickResult> pickReference(const ReferenceScene& scene, const gpu::RenderParams& params,
                                           const std::vector<glm::vec2>& ndcPoints) {
  const Sampler s{*scene.volume, *scene.lut, *scene.occupancy, params, scene.mask, scene.handleTints, scene.strain, scene.labels, scene.strainOverLimit};
  std::vector<gpu::PickResult> out;
  out.reserve(ndcPoints.size());
  for (const auto& p : ndcPoints) out.push_back(s.pick(p));
  return out;
}

}  // namespace handson
