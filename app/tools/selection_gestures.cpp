#include "selection_gestures.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>

#include "interaction/camera.h"
#include "interaction/handles.h"
#include "interaction/selection.h"
#include "interaction/touch.h"
#include "sim/distance_transform.h"

namespace handson {

namespace {

// A box of the volume's grid (inclusive corners) and its own x-fastest indexing.
struct Box {
  Eigen::Vector3i lo, hi;
  Eigen::Vector3i dims() const { return hi - lo + Eigen::Vector3i::Ones(); }
  std::size_t size() const { return std::size_t(dims().prod()); }
  std::size_t index(const Eigen::Vector3i& v) const {
    const Eigen::Vector3i d = dims(), r = v - lo;
    return std::size_t(r.x()) + std::size_t(d.x()) * (std::size_t(r.y()) + std::size_t(d.y()) * std::size_t(r.z()));
  }
};

// The bounding box of voxels (linear indices on g).
Box boundingBox(const std::vector<std::uint32_t>& voxels, const VolumeGeometry& g) {
  Box b{Eigen::Vector3i::Constant(1 << 30), Eigen::Vector3i::Constant(-(1 << 30))};
  for (std::uint32_t v : voxels) {
    const Eigen::Vector3i p = g.voxelOf(v);
    b.lo = b.lo.cwiseMin(p);
    b.hi = b.hi.cwiseMax(p);
  }
  return b;
}

double percentile95(std::vector<double> d) {
  const std::size_t at = std::min(d.size() - 1, std::size_t(std::ceil(0.95 * double(d.size()))) - 1);
  std::nth_element(d.begin(), d.begin() + std::ptrdiff_t(at), d.end());
  return d[at];
}

// The 26-connected components of the voxels of `box` whose `kind` is `want`, each visited once
// (`seen` marks them); calls `component` with each one's voxels (linear indices on g).
template <class Fn>
void eachComponent(const Box& box, const VolumeGeometry& g, const std::vector<std::uint8_t>& kind, std::uint8_t want, std::vector<std::uint8_t>& seen, Fn&& component) {
  const Eigen::Vector3i d = box.dims();
  std::vector<std::size_t> stack;
  for (std::size_t start = 0; start < box.size(); ++start) {
    if (kind[start] != want || seen[start]) continue;
    std::vector<std::uint32_t> voxels;
    seen[start] = 1;
    stack.assign(1, start);
    while (!stack.empty()) {
      const std::size_t i = stack.back();
      stack.pop_back();
      const Eigen::Vector3i p(int(i % std::size_t(d.x())), int(i / std::size_t(d.x()) % std::size_t(d.y())), int(i / (std::size_t(d.x()) * std::size_t(d.y()))));
      voxels.push_back(std::uint32_t(linearIndex(g, box.lo + p)));
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const Eigen::Vector3i q = p + Eigen::Vector3i(dx, dy, dz);
            if ((q.array() < 0).any() || (q.array() >= d.array()).any()) continue;
            const std::size_t j = std::size_t(q.x()) + std::size_t(d.x()) * (std::size_t(q.y()) + std::size_t(d.y()) * std::size_t(q.z()));
            if (kind[j] == want && !seen[j]) {
              seen[j] = 1;
              stack.push_back(j);
            }
          }
    }
    component(std::move(voxels));
  }
}

// One pinch of the app's (interaction/selection.h): two fingers land about `target`, their
// depth-picks on either side of it, spread so that the app's extent is `spreadMm`; one lifts.
// Returns the finished selection (with its boundary rim when the rules say so) and its seed.
struct Pinched {
  FinishedPinch finished;  // its voxels as grown (complete(): gathered, sorted and rimmed) and its seed
  std::vector<std::uint32_t> shown;  // its live voxels as the app drew them before the lift
  double liftMs = 0.0;  // the fingers lifted (the frame's thread)
};
Pinched appPinch(PinchSelection& pinch, const VolumeGeometry& g, const Eigen::Vector3i& target, double spreadMm) {
  const Eigen::Vector3d w = g.toWorld(target.cast<double>());
  OrbitCamera camera;
  camera.target = glm::dvec3(w.x(), w.y(), w.z());
  camera.distance = 500.0;
  const Viewport viewport{1000, 1000};
  const double spreadPx = spreadMm / camera.pixelSizeAt(camera.distance, viewport.height);
  const std::array<glm::dvec2, 2> at{viewport.center() - glm::dvec2(0.5 * spreadPx, 0.0), viewport.center() + glm::dvec2(0.5 * spreadPx, 0.0)};
  TouchInput input;
  input.setViewport(viewport);
  auto touch = [&](TouchPhase phase, int finger) {
    const TouchEvent e{phase, finger, at[std::size_t(finger)], 1.0, 0.0};
    input.apply(e);
    pinch.onTouch(e, input, camera, viewport);
  };
  touch(TouchPhase::Down, 0);
  touch(TouchPhase::Down, 1);
  pinch.takePickRequest();
  const glm::dvec3 side = camera.right() * 0.5;  // picks 1 mm apart, their midpoint the target
  pinch.onPicks({camera.target - side, camera.target + side}, camera, viewport);
  std::vector<std::uint32_t> shown = pinch.liveVoxels();  // the app's live selection, drawn as it grew
  const auto lift = std::chrono::steady_clock::now();
  touch(TouchPhase::Up, 1);
  touch(TouchPhase::Up, 0);
  const double liftMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - lift).count();
  auto done = pinch.takeFinishedPinch();
  if (!done) return {};
  return {std::move(*done), std::move(shown), liftMs};
}

double ms(std::chrono::steady_clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

// A change of handle ids painted as the app paints it: the ids, the pinch that was drawn meanwhile
// back to them; the box to upload (its voxels), the edit's.
std::size_t paintChange(const EditOnCopy& e, const std::vector<std::uint32_t>& landed, std::vector<std::uint8_t>& ids, std::vector<std::uint8_t>& mask) {
  for (std::uint32_t v : e.mask.cleared) ids[v] = 0;
  for (const auto& [v, id] : e.mask.joined) ids[v] = id;
  for (std::uint32_t v : e.mask.cleared) mask[v] = ids[v];
  for (const auto& [v, id] : e.mask.joined) mask[v] = ids[v];
  for (std::uint32_t v : landed) mask[v] = ids[v];
  return (e.boxMin.array() <= e.boxMax.array()).all() ? std::size_t((e.boxMax - e.boxMin + Eigen::Vector3i::Ones()).prod()) : 0;
}

// The app's grids of handle ids: the handles' alone, and as shown.
struct AppMask {
  std::vector<std::uint8_t> ids, shown;
};

// A finished pinch's edit as the window makes it (app/session/selection_controller.h): the handles
// and the pinch's voxels copied, the edit taken in and its voxels and the pinch's repainted on the
// frame's thread; the pinch's voxels sorted and rimmed and the edit itself on a worker.
EditOnCopy editAsTheWindowDoes(HandleSet& handles, AppMask& m, Pinched p, const PinchRequest& request, const VolumeGeometry& g, GestureStep& s) {
  std::vector<std::uint8_t>& ids = m.ids;
  std::vector<std::uint8_t>& mask = m.shown;
  const auto t1 = std::chrono::steady_clock::now();
  std::vector<Handle> copy = handles.handles();
  // Drawn as the live selection meanwhile: what was shown (its voxels gathered on the worker).
  std::vector<std::uint32_t> landing;
  if (p.finished.grower && !p.shown.empty()) {
    landing = std::move(p.shown);
  } else {
    p.finished.gather();
    landing = p.finished.voxels;
  }
  const auto t2 = std::chrono::steady_clock::now();
  const std::uint32_t seed = p.finished.seed;
  std::vector<std::uint32_t> voxels = std::move(p.finished).complete();
  s.pinchVoxels = voxels.size();
  EditOnCopy edit = applyPinchOnCopy(std::move(copy), std::move(voxels), seed, request, g);
  const auto t3 = std::chrono::steady_clock::now();
  if (edit.changed) handles.replace(std::move(edit.after));
  s.uploadVoxels = paintChange(edit, landing, ids, mask);
  const auto t4 = std::chrono::steady_clock::now();
  s.editMs = ms(t4 - t1);
  s.editFrameMs = ms(t2 - t1) + ms(t4 - t3);
  return edit;
}

// Dice, precision and recall of a selection (ascending voxels) against the organ's mask.
void score(const std::vector<std::uint32_t>& selection, const std::vector<std::uint8_t>& organ, std::size_t organVoxels, GestureStep& s) {
  std::size_t hit = 0;
  for (std::uint32_t v : selection) hit += organ[v] != 0;
  s.selected = selection.size();
  s.dice = 2.0 * double(hit) / double(selection.size() + organVoxels);
  s.precision = selection.empty() ? 0.0 : double(hit) / double(selection.size());
  s.recall = double(hit) / double(organVoxels);
}

}  // namespace

const char* gestureKindName(GestureKind k) {
  switch (k) {
    case GestureKind::First: return "first";
    case GestureKind::Add: return "add";
    case GestureKind::Remove: return "remove";
  }
  return "?";
}

GestureTarget gestureTarget(std::vector<std::uint32_t> voxels, const VolumeGeometry& g) {
  GestureTarget t;
  if (voxels.empty()) return t;
  std::sort(voxels.begin(), voxels.end());
  const RegionDistance d = regionDistance(voxels, g);
  const std::uint32_t deepest = deepestVoxelOf(voxels, d, g);  // ascending: the lowest index on ties
  t.deepest = g.voxelOf(deepest);
  t.depthMm = std::sqrt(double(d.at(g, deepest)));
  std::vector<double> dist;
  dist.reserve(voxels.size());
  for (std::uint32_t v : voxels) dist.push_back((g.voxelOf(v) - t.deepest).cast<double>().cwiseProduct(g.spacing).norm());
  t.spreadMm = std::max(percentile95(std::move(dist)), g.spacing.minCoeff());
  t.voxels = std::move(voxels);
  return t;
}

ErrorRegion largestErrorRegion(const std::vector<std::uint8_t>& organ, const std::vector<std::uint8_t>& selected, const VolumeGeometry& g) {
  // Error kinds on the box of the organ and the selection: 1 missed, 2 leaked, 0 right.
  std::vector<std::uint32_t> either;
  for (std::size_t v = 0; v < organ.size(); ++v)
    if (organ[v] || selected[v]) either.push_back(std::uint32_t(v));
  ErrorRegion out;
  if (either.empty()) return out;
  const Box box = boundingBox(either, g);
  std::vector<std::uint8_t> kind(box.size(), 0), seen(box.size(), 0);
  for (std::uint32_t v : either)
    if (bool(organ[v]) != bool(selected[v])) kind[box.index(g.voxelOf(v))] = organ[v] ? 1 : 2;
  std::vector<std::uint32_t> largest;
  for (const std::uint8_t want : {std::uint8_t(1), std::uint8_t(2)})
    eachComponent(box, g, kind, want, seen, [&](std::vector<std::uint32_t> c) {
      if (c.size() > largest.size()) {
        largest = std::move(c);
        out.missed = want == 1;
      }
    });
  out.target = gestureTarget(std::move(largest), g);
  return out;
}

OrganGestures runGestureProtocol(const std::string& dataset, const Volume& ct, const QuantizedVolume& q, const Volume& labels,
                                 const OrganLabel& organ, const GestureProtocol& protocol) {
  const VolumeGeometry& g = q.geometry;
  OrganGestures out{dataset, organ.name, 0, {}};
  const Eigen::Vector3i first = deepestVoxel(labels, organ.label, ct);
  if (first.x() < 0) return out;
  std::vector<std::uint8_t> organMask(labels.voxelCount(), 0);
  for (std::size_t v = 0; v < labels.voxelCount(); ++v) organMask[v] = labels.value(v) == float(organ.label);
  const auto radiusAndCount = organRadiusMm(labels, organ.label, first);
  const double radius = radiusAndCount.first;
  const std::size_t organVoxels = radiusAndCount.second;
  out.organVoxels = organVoxels;
  PinchSelection pinch(q, protocol.params);
  HandleSet handles;
  int selection = 0;
  std::vector<std::uint8_t> selectedMask(organMask.size(), 0);
  AppMask appMask{std::vector<std::uint8_t>(organMask.size(), 0), std::vector<std::uint8_t>(organMask.size(), 0)};
  for (int n = 1; n <= protocol.gestures; ++n) {
    GestureStep s;
    s.gesture = n;
    const auto t0 = std::chrono::steady_clock::now();
    PinchRequest request{PinchOp::New, 0, protocol.corrections};
    if (n == 1) {
      s.target = first;
      s.spreadMm = radius;
      s.regionVoxels = organVoxels;
    } else {
      const ErrorRegion e = largestErrorRegion(organMask, selectedMask, g);
      if (e.target.voxels.empty()) break;  // the selection is the organ
      s.kind = e.missed ? GestureKind::Add : GestureKind::Remove;
      s.target = e.target.deepest;
      s.spreadMm = e.target.spreadMm;
      s.regionVoxels = e.target.voxels.size();
      request = {e.missed ? PinchOp::Add : PinchOp::Remove, selection, protocol.corrections};
    }
    Pinched p = appPinch(pinch, g, s.target, s.spreadMm);
    s.liftMs = p.liftMs;
    const EditOnCopy edit = editAsTheWindowDoes(handles, appMask, std::move(p), request, g, s);
    s.refused = edit.handle == 0;
    if (edit.handle) selection = edit.handle;
    s.milliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    const Handle* h = handles.find(selection);
    const std::vector<std::uint32_t> none;
    const std::vector<std::uint32_t>& voxels = h ? h->voxels : none;
    std::fill(selectedMask.begin(), selectedMask.end(), 0);
    for (std::uint32_t v : voxels) selectedMask[v] = 1;
    score(voxels, organMask, organVoxels, s);
    out.steps.push_back(s);
  }
  return out;
}

}  // namespace handson
