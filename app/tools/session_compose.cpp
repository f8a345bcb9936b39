#include "session_compose.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <tuple>

#include "app/tools/scenario_retarget.h"
#include "app/tools/selection_eval.h"
#include <Eigen/Geometry>

#include "interaction/manipulation.h"
#include "interaction/selection.h"
#include "interaction/view_adjust.h"
#include "render/transfer_function.h"
#include "sim/distance_transform.h"
#include "sim/base/error.h"

namespace handson {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kBackground = -1;  // a ray that hits nothing visible

}  // namespace

std::vector<double> distanceToOutside2d(const std::vector<std::uint8_t>& inside, int nx, int ny) {
  if (nx <= 0 || ny <= 0 || inside.size() != std::size_t(nx) * std::size_t(ny)) throw Error("distance transform: the mask is not nx x ny");
  // sim/distance_transform on one slice, with a ring of outside cells (it does not count the grid's
  // own border as outside).
  const int w = nx + 2, h = ny + 2;
  std::vector<std::uint8_t> padded(std::size_t(w) * std::size_t(h), 0);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) padded[std::size_t(i + 1) + std::size_t(w) * std::size_t(j + 1)] = inside[std::size_t(i) + std::size_t(nx) * std::size_t(j)] ? 1 : 0;
  const std::vector<float> d2 = squaredDistanceToOutside(padded, Eigen::Vector3i(w, h, 1), Eigen::Vector3d::Ones());
  std::vector<double> out(inside.size());
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) out[std::size_t(i) + std::size_t(nx) * std::size_t(j)] = std::sqrt(double(d2[std::size_t(i + 1) + std::size_t(w) * std::size_t(j + 1)]));
  return out;
}

namespace {

// What the camera sees on a grid of pixels `step` apart: the label under each cell's pick and the
// pick's depth along the view direction (mm).
struct Footprint {
  int step = 1, nx = 0, ny = 0;
  std::vector<int> label;
  std::vector<double> depth;

  glm::dvec2 px(int i, int j) const { return {(i + 0.5) * step, (j + 0.5) * step}; }
  // Distance in pixels from each cell to the nearest cell outside `inside` (the viewport's border is
  // outside too): the largest disc around the cell that stays in the footprint.
  template <class Pred>
  std::vector<double> innerDistance(Pred inside) const {
    std::vector<std::uint8_t> in(label.size());
    for (std::size_t k = 0; k < label.size(); ++k) in[k] = inside(label[k]) ? 1 : 0;
    std::vector<double> d = distanceToOutside2d(in, nx, ny);
    for (double& v : d) v *= step;
    return d;
  }
  // The cell farthest inside (ties: nearest the viewport's centre); radius in pixels (0: none).
  std::pair<glm::dvec2, double> innermost(const std::vector<double>& dist) const {
    std::size_t best = dist.size();
    const glm::dvec2 c(0.5 * nx * step, 0.5 * ny * step);
    for (std::size_t k = 0; k < dist.size(); ++k) {
      if (dist[k] <= 0.0) continue;
      if (best == dist.size() || dist[k] > dist[best] ||
          (dist[k] == dist[best] && glm::distance(px(int(k % nx), int(k / nx)), c) < glm::distance(px(int(best % nx), int(best / nx)), c)))
        best = k;
    }
    if (best == dist.size()) return {c, 0.0};
    return {px(int(best % nx), int(best / nx)), dist[best]};
  }
  // The depth at the cell under a pixel (NaN for a miss or outside the viewport).
  double depthAt(glm::dvec2 p) const {
    const int i = int(std::floor(p.x / step)), j = int(std::floor(p.y / step));
    if (i < 0 || j < 0 || i >= nx || j >= ny) return std::nan("");
    return depth[std::size_t(i) + std::size_t(nx) * std::size_t(j)];
  }
};

// The handles a footprint sees instead of the labels: their ids in the mask, drawn at their poses.
struct HandleOverlay {
  const std::vector<std::uint8_t>& mask;
  std::vector<MovingHandlePose> moving;
};

// With handles, a hit's "label" is the handle id there instead (0: none).
Footprint look(const CpuPicker& picker, const Volume& labels, const OrbitCamera& cam, const Viewport& vp, int step, const HandleOverlay* handles = nullptr) {
  const std::vector<std::uint8_t>* handleMask = handles ? &handles->mask : nullptr;
  Footprint fp;
  fp.step = step;
  fp.nx = vp.width / step;
  fp.ny = vp.height / step;
  std::vector<glm::dvec2> pixels;
  pixels.reserve(std::size_t(fp.nx) * std::size_t(fp.ny));
  for (int j = 0; j < fp.ny; ++j)
    for (int i = 0; i < fp.nx; ++i) pixels.push_back(fp.px(i, j));
  const std::vector<gpu::PickResult> hits = picker.pick(cam, vp, pixels, handleMask, handles ? handles->moving : std::vector<MovingHandlePose>{});
  fp.label.resize(pixels.size());
  fp.depth.resize(pixels.size());
  const glm::dvec3 eye = cam.eye(), fwd = cam.forward();
  for (std::size_t k = 0; k < pixels.size(); ++k) {
    fp.label[k] = hits[k].world.w > 0.5f ? picker.labelAt(hits[k], labels) : kBackground;
    if (fp.label[k] == kBackground && hits[k].world.w > 0.5f) fp.label[k] = 0;  // a voxel outside the map
    if (handleMask && hits[k].world.w > 0.5f) fp.label[k] = int(hits[k].voxel.w);
    fp.depth[k] = hits[k].world.w > 0.5f ? glm::dot(glm::dvec3(hits[k].world) - eye, fwd) : std::nan("");
  }
  return fp;
}

// The radius (mm) of a ball of the label's volume.
double equivalentRadiusMm(const Volume& labels, int label) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < labels.voxelCount(); ++i) n += labels.value(i) == float(label);
  const Eigen::Vector3d s = labels.geometry().spacing;
  return std::cbrt(3.0 * double(n) * s.prod() / (4.0 * kPi));
}

// `steps` + 1 frames from `from` to `to` in equal steps.
std::vector<std::vector<glm::dvec2>> lerpFrames(const std::vector<glm::dvec2>& from, const std::vector<glm::dvec2>& to, int steps) {
  std::vector<std::vector<glm::dvec2>> frames{from};
  for (int k = 1; k <= steps; ++k) {
    frames.emplace_back();
    for (std::size_t f = 0; f < from.size(); ++f) frames.back().push_back(glm::mix(from[f], to[f], double(k) / steps));
  }
  return frames;
}

class EventWriter {
 public:
  explicit EventWriter(SessionScript& s) : s_(s) {}
  double t = 0.0;
  void ui(UiAction action, const std::string& value = "", double dt = 0.1) {
    s_.events.push_back(uiEvent(std::round(t * 1000.0) / 1000.0, action, value));
    t += dt;
  }
  void touch(TouchPhase phase, std::int64_t id, glm::dvec2 px) {
    // (quarter pixels and milliseconds keep the file readable)
    s_.events.push_back(touchEvent(std::round(t * 1000.0) / 1000.0, phase, id, glm::round(px * 4.0) / 4.0));
  }
  // Fingers down at `from`, moved in `steps` equal steps to `to` (dt apart), lifted; then a pause.
  // Fingers down at frames[0], moved through the later frames (dt apart), lifted; then a pause.
  void path(std::int64_t firstId, const std::vector<std::vector<glm::dvec2>>& frames, double dt) {
    const std::size_t n = frames.front().size();
    for (std::size_t f = 0; f < n; ++f) touch(TouchPhase::Down, firstId + std::int64_t(f), frames.front()[f]);
    for (std::size_t k = 1; k < frames.size(); ++k) {
      t += dt;
      for (std::size_t f = 0; f < n; ++f) touch(TouchPhase::Move, firstId + std::int64_t(f), frames[k][f]);
    }
    t += dt;
    for (std::size_t f = n; f-- > 0;) touch(TouchPhase::Up, firstId + std::int64_t(f), frames.back()[f]);
    t += 0.1;
  }
  void stroke(std::int64_t firstId, const std::vector<glm::dvec2>& from, const std::vector<glm::dvec2>& to, int steps, double dt) {
    path(firstId, lerpFrames(from, to, steps), dt);
  }

 private:
  SessionScript& s_;
};

}  // namespace

namespace {

// A view a session can be composed in: its direction, its cut (none unless clipping) and its room.
struct ComposeView {
  double azimuthDeg = 0.0, elevationDeg = 0.0;
  ClipRegion cut;
  double score = 0.0;  // the organ's + the anchor's inscribed radius (px, every 4th pixel picked)
};
constexpr std::size_t kComposeViewsTried = 6;

// The phases of a composed session over one view (composeFullSession). Each phase writes its touches
// to the script and runs them here too, so that the next one is placed where the app then shows the
// handle; what a phase leaves for the next is kept in the members below.
class Composer {
 public:
  // clip: the view may cut in front of the organ (a view-oriented clip plane), under `preset`
  // (the session starts with the volume's own preset and switches to it before clipping).
  Composer(const Volume& ctIn, const Volume& labelsIn, const ComposeOptions& options, const std::string& preset, bool clip)
      : ct(ctIn), labels(labelsIn), o(options), vp(o.viewport), aspect(double(vp.width) / double(vp.height)), picker(ct, preset), s(out.script), w(s),
        mid(vp.center()), mask(picker.volume().data.size(), 0), clipping(clip), startPreset(o.preset.empty() ? defaultPresetFor(ct) : o.preset) {
    if (clipping) {
      organPts = worldPoints(o.organ);
      anchorPts = worldPoints(o.anchor);
      organRadiusMm = equivalentRadiusMm(labels, o.organ);
    }
  }

  ComposedSession compose(const Eigen::Vector3i& deep, const ComposeView& view, const std::string& volumePath) {
    useView(deep, view);
    orbitIn(volumePath);
    if (clipping) exposeByClipping();
    w.ui(UiAction::SetMode, "select");
    selectBoth();
    w.ui(UiAction::HandleStatus, "2:fixed");
    w.ui(UiAction::SetMode, "manipulate");
    prepareHandle();
    tiltWithThree();
    dragWithOne();
    pushWithTwo();
    twistAndSpread();
    w.ui(UiAction::HandleStatus, "2:idle");
    finish();
    return std::move(out);
  }

 private:
  const Volume& ct;
  const Volume& labels;
  const ComposeOptions& o;
  const Viewport vp;
  const double aspect;
  CpuPicker picker;
  ComposedSession out;
  SessionScript& s;
  EventWriter w;
  const glm::dvec2 mid;
  std::vector<std::uint8_t> mask;  // the pinched handles (1: the organ's, 2: the anchor's) on the picker's grid
  OrbitCamera cam;
  double bestAz = 0.0, bestEl = 0.0, mmPerPx = 0.0;
  double minDistance = 0.0;        // the eye stays outside the volume (from the aim)
  static constexpr double kWantedRoomPx = 28.0;  // the organ's inscribed radius the view aims for
  Footprint fp;                    // the chosen view at rest
  glm::dvec2 co{0.0}, ca{0.0};     // the organ's and the anchor's innermost pixels
  double ro = 0.0, ra = 0.0;       // and their room
  Eigen::Vector3i lo, hi;          // the organ handle's voxel box
  std::size_t anchored = 0;        // fingers that landed on the handle in the last simulated gesture
  const bool clipping;             // the view cuts in front of the organ (exposeByClipping)
  const std::string startPreset;   // the script's: the volume's own (or the one asked for)
  std::vector<Eigen::Vector3d> organPts, anchorPts;  // their voxels' centres (world), when clipping
  ClipRegion plane;                // the chosen view's clip plane (when clipping)
  double organRadiusMm = 0.0;
  RigidTransform tilted, dragged, pushed, spread;  // the handle after each gesture
  glm::dvec2 g1{0.0}, u{0.0}, h1{0.0};
  double r1 = -1.0;

  bool organ(int l) const { return l == o.organ; }
  bool anchor(int l) const { return l == o.anchor; }
  static bool onHandle1(int l) { return l == 1; }

  // The camera around the organ's deepest voxel, at a distance that shows the organ about a fifth of
  // the view high, never inside the volume.
  void frameCamera(const Eigen::Vector3i& deep) {
    const Eigen::Vector3d aimW = ct.geometry().toWorld(deep.cast<double>());
    const glm::dvec3 aim(aimW.x(), aimW.y(), aimW.z());
    cam = OrbitCamera::framing(ct.geometry(), 0.0, 0.0, aspect);
    const double halfFov = 0.5 * cam.fovY;
    const VolumeGeometry& g = ct.geometry();
    minDistance = 0.0;
    for (int c = 0; c < 8; ++c) {
      const Eigen::Vector3d corner((c & 1) ? g.dims.x() - 1 : 0, (c & 2) ? g.dims.y() - 1 : 0, (c & 4) ? g.dims.z() - 1 : 0);
      const Eigen::Vector3d wc = g.toWorld(corner);
      minDistance = std::max(minDistance, 1.05 * glm::distance(aim, glm::dvec3(wc.x(), wc.y(), wc.z())));
    }
    cam.target = aim;
    cam.distance = std::max(5.0 * equivalentRadiusMm(labels, o.organ) / std::tan(halfFov), minDistance);
    cam.nearPlane = std::max(1e-3, 0.01 * cam.distance);
    cam.farPlane = cam.distance + 2.0 * g.diagonalMm();
  }

 public:
  // The views (every 30 degrees of azimuth at elevations 0 and +-25, each with the candidate cuts)
  // that show the organ with 16 px and the anchor with 6 px of room, roomiest first (ties: in that
  // order). Throws when there is none.
  std::vector<ComposeView> rankViews(const Eigen::Vector3i& deep) {
    frameCamera(deep);
    auto isOrgan = [this](int l) { return organ(l); };
    auto isAnchor = [this](int l) { return anchor(l); };
    std::vector<ComposeView> views;
    double bestOrgan = 0.0, bestAnchor = 0.0;
    for (double elevation : {0.0, 25.0, -25.0})
      for (int k = 0; k < 12; ++k) {
        cam.azimuth = glm::radians(30.0 * k);
        cam.elevation = glm::radians(elevation);
        for (const ClipRegion& cut : candidateCuts()) {
          picker.setClip(cut);
          const Footprint f = look(picker, labels, cam, vp, 4);
          const double rOrgan = f.innermost(f.innerDistance(isOrgan)).second, rAnchor = f.innermost(f.innerDistance(isAnchor)).second;
          if (rOrgan > bestOrgan || (rOrgan == bestOrgan && rAnchor > bestAnchor)) bestOrgan = rOrgan, bestAnchor = rAnchor;
          if (rOrgan >= 16.0 && rAnchor >= 6.0) views.push_back({30.0 * k, elevation, cut, rOrgan + rAnchor});
        }
      }
    if (views.empty())
      throw Error("compose: no view direction shows label " + std::to_string(o.organ) + " with 16 px and label " + std::to_string(o.anchor) +
                  " with 6 px of room for the fingers (best: " + std::to_string(int(bestOrgan)) + " and " + std::to_string(int(bestAnchor)) + " px" +
                  (clipping ? ", with the " + picker.preset() + " preset and a clip plane in front of either" : "") + ")");
    std::stable_sort(views.begin(), views.end(), [](const ComposeView& a, const ComposeView& b) { return a.score > b.score; });
    return views;
  }

 private:
  // The chosen view, picked every 2nd pixel: the organ's and the anchor's innermost pixels and room.
  void useView(const Eigen::Vector3i& deep, const ComposeView& view) {
    frameCamera(deep);
    auto isOrgan = [this](int l) { return organ(l); };
    auto isAnchor = [this](int l) { return anchor(l); };
    bestAz = view.azimuthDeg;
    bestEl = view.elevationDeg;
    plane = view.cut;
    cam.azimuth = glm::radians(bestAz);
    cam.elevation = glm::radians(bestEl);
    picker.setClip(plane);
    fp = look(picker, labels, cam, vp, 2);
    std::tie(co, ro) = fp.innermost(fp.innerDistance(isOrgan));
    std::tie(ca, ra) = fp.innermost(fp.innerDistance(isAnchor));
    if (ro < kWantedRoomPx && ro > 0.0) {
      // An organ narrower than its ball (a kidney, a vessel) leaves the fingers little room at a
      // fifth of the view: come closer, as far as the eye stays outside the volume.
      const double closer = std::max(ro / kWantedRoomPx, minDistance / cam.distance);
      if (closer < 0.95) {
        cam.distance *= closer;
        cam.nearPlane = std::max(1e-3, 0.01 * cam.distance);
        fp = look(picker, labels, cam, vp, 2);
        std::tie(co, ro) = fp.innermost(fp.innerDistance(isOrgan));
        std::tie(ca, ra) = fp.innermost(fp.innerDistance(isAnchor));
      }
    }
    if (ro < 12.0 || ra < 4.0) throw Error("compose: the chosen view leaves too little room for the fingers");
    mmPerPx = cam.pixelSizeAt(fp.depthAt(co), vp.height);
  }

  // The voxel centres (world) of a label.
  std::vector<Eigen::Vector3d> worldPoints(int label) const {
    std::vector<Eigen::Vector3d> pts;
    const VolumeGeometry& g = labels.geometry();
    for (std::size_t v = 0; v < labels.voxelCount(); ++v)
      if (labels.value(v) == float(label)) pts.push_back(g.toWorld(g.voxelOf(v).cast<double>()));
    return pts;
  }
  // How far along n the nearest of the points lies.
  static double frontOf(const std::vector<Eigen::Vector3d>& pts, const glm::dvec3& n) {
    double d = kInf;
    for (const auto& p : pts) d = std::min(d, n.x * p.x() + n.y * p.y() + n.z * p.z());
    return d;
  }
  // The cuts tried in the current view: none; when clipping, a view-oriented plane in front of the
  // organ's nearest voxel, or of the nearer of the organ and the anchor, by 1.5 voxels or by half
  // the organ's radius (room for it to turn toward the viewer without being cut).
  std::vector<ClipRegion> candidateCuts() const {
    if (!clipping) return {ClipRegion{}};
    const glm::dvec3 n = cam.forward();
    const double organFront = frontOf(organPts, n), bothFront = std::min(organFront, frontOf(anchorPts, n));
    std::vector<ClipRegion> cuts;
    for (double margin : {1.5 * ct.geometry().spacing.maxCoeff(), 0.5 * organRadiusMm})
      for (double d : {organFront, bothFront}) {
        ClipRegion c;
        c.plane = true;
        c.normal = glm::vec3(n);
        c.offset = float(d - margin);
        if (std::none_of(cuts.begin(), cuts.end(), [&](const ClipRegion& k) { return k.offset == c.offset; })) cuts.push_back(c);
      }
    return cuts;
  }

  // In the chosen view: the clipping preset, then Clip mode and one-finger drags that place the
  // view's plane through the point under the finger and push it to the chosen cut (the app's own
  // gesture, interaction/view_adjust.h). The finger starts off every face handle of the volume's
  // box (by 1.5 grab radii), in the lowest row whose first stroke fits in the view; a longer drag is
  // split into strokes from the same start (a later drag in the same view moves the plane it left).
  // The cut the app then shows is the one the strokes make, to the quarter pixel the script stores;
  // the picks from here on use it.
  void exposeByClipping() {
    if (picker.preset() != startPreset) w.ui(UiAction::SetPreset, picker.preset());
    w.ui(UiAction::SetMode, "clip");
    glm::dvec3 boxLo, boxHi;
    volumeWorldBox(ct.geometry(), boxLo, boxHi);
    const glm::dvec3 n = cam.forward();
    const double pixMm = cam.pixelSizeAt(cam.distance, vp.height);
    picker.setClip(ClipRegion{});
    // The plane the touch-down at px places: through the picked point (the target on a miss).
    auto placed = [&](glm::dvec2 px) {
      const gpu::PickResult hit = picker.pick(cam, vp, {px}).front();
      return glm::dot(n, hit.world.w > 0.5f ? glm::dvec3(hit.world) : cam.target);
    };
    // Room for a stroke from px in the direction of `need` (pixels up when positive).
    auto room = [&](glm::dvec2 px, double need) { return need > 0.0 ? px.y - 4.0 : vp.height - 4.0 - px.y; };
    // The start: off every face handle, from the bottom rows up, the first whose first stroke fits
    // (or the roomiest); all strokes start there.
    std::optional<glm::dvec2> p0;
    double made = 0.0, bestRoom = -1.0;
    for (int j = vp.height - 8; j >= 8; j -= 8) {
      std::optional<glm::dvec2> px;  // the row's pixel nearest the middle off the handles
      for (int di = 0; di <= vp.width / 2 - 8 && !px; di += 8)
        for (int sgn : {1, -1})
          if (!px && !boxFaceNear(boxLo, boxHi, cam, vp, glm::dvec2(mid.x + sgn * di, j), 1.5 * faceGrabRadiusPx(vp)))
            px = glm::round(glm::dvec2(mid.x + sgn * di, j) * 4.0) / 4.0;
      if (!px) continue;
      const double base = placed(*px), need = (double(plane.offset) - base) / pixMm;
      if (room(*px, need) > bestRoom) p0 = px, made = base, bestRoom = room(*px, need);
      if (bestRoom >= std::abs(need)) break;
    }
    if (!p0 || bestRoom < 8.0) throw Error("compose: no place for a clip-plane drag off the clip box's face handles");
    for (int stroke = 0;; ++stroke) {
      const double need = (double(plane.offset) - made) / pixMm;
      if (std::abs(need) < 0.25 && stroke > 0) break;
      if (stroke == 32) throw Error("compose: the clip plane needs more than 32 strokes to reach the organ");
      const double l = std::clamp(need, -room(*p0, need), room(*p0, need));
      const glm::dvec2 b = glm::round((*p0 - glm::dvec2(0.0, l)) * 4.0) / 4.0;
      w.stroke(30, {*p0}, {b}, std::max(2, int(std::abs(l) / 12.0)), 0.03);
      made += planeDragMm(cam, vp, b - *p0);
      if (std::abs(l) < room(*p0, need)) break;
    }
    plane.offset = float(made);
    picker.setClip(plane);
    fp = look(picker, labels, cam, vp, 2);
    const auto isOrgan = [this](int l) { return organ(l); };
    const auto isAnchor = [this](int l) { return anchor(l); };
    std::tie(co, ro) = fp.innermost(fp.innerDistance(isOrgan));
    std::tie(ca, ra) = fp.innermost(fp.innerDistance(isAnchor));
    if (ro < 12.0 || ra < 4.0) throw Error("compose: the clipped view leaves too little room for the fingers");
    mmPerPx = cam.pixelSizeAt(fp.depthAt(co), vp.height);
    out.clipPlane = formatClipPlane(plane);
    out.preset = picker.preset();
    out.organPx = co;
    out.anchorPx = ca;
    out.organRadiusPx = ro;
    out.anchorRadiusPx = ra;
    out.mmPerPx = mmPerPx;
  }

  // The script's start, and a one-finger orbit into the view.
  void orbitIn(const std::string& volumePath) {
    out.azimuthDeg = bestAz;
    out.elevationDeg = bestEl;
    out.mmPerPx = mmPerPx;
    out.organPx = co;
    out.anchorPx = ca;
    out.organRadiusPx = ro;
    out.anchorRadiusPx = ra;
    s.viewport = vp;
    s.preset = startPreset;
    out.preset = picker.preset();
    s.mode = "navigate";
    if (!volumePath.empty()) {
      s.volumeSource = "file";
      s.volumePath = volumePath;
    }
    // Start about 30 degrees of azimuth short of the view; a one-finger drag orbits there (pi / height
    // radians per pixel: interaction/gesture.h). Nothing is selected yet, so any drag navigates. The
    // drag is in whole quarter pixels (as the file stores them) and the start is set from it exactly.
    const double halfOrbit = std::round(30.0 / 180.0 * vp.height * 2.0) / 4.0;
    OrbitCamera start = cam;
    start.azimuth = glm::radians(bestAz) - 2.0 * halfOrbit * kPi / vp.height;
    s.camera = CameraState::from(start);
    w.stroke(1, {mid - glm::dvec2(halfOrbit, 0.0)}, {mid + glm::dvec2(halfOrbit, 0.0)}, 10, 0.05);
  }

  // Pinches: down inside the footprint (3 px margin), spread until the extent (sigma_px times the
  // fingers' distance) is 2.5 inscribed radii (1.8 before the path bound: a path through the organ
  // is longer than the straight line, so the same spread takes less; at 1.8 totalseg-small's right
  // kidney gave a 516-voxel handle that the test model's blur lost the fingers on, at 2.5 1,341
  // voxels). Each is also run here, through the app's own PinchSelection answered by the CPU picks,
  // so that the later touches can be put on the handle it makes (a grown region is often only part
  // of the organ: the kidney's cortex and medulla differ).
  void selectBoth() {
    pinch(3, co, ro, 1);  // a new handle is active
    pinch(5, ca, ra, 2);
  }
  void pinch(std::int64_t id, glm::dvec2 c, double r, std::uint8_t handle) {
    const double s1 = 2.5 * r;
    const double s0 = std::clamp(0.45 * s1, 4.0, 2.0 * (r - 3.0));
    const std::vector<glm::dvec2> from{c - glm::dvec2(0.5 * s0, 0.0), c + glm::dvec2(0.5 * s0, 0.0)};
    const std::vector<glm::dvec2> to{c - glm::dvec2(0.5 * s1, 0.0), c + glm::dvec2(0.5 * s1, 0.0)};
    const std::size_t first = s.events.size();
    w.stroke(id, from, to, 4, 0.1);
    PinchSelection selection(picker.volume(), GrowParams{});
    TouchInput input;
    input.setViewport(vp);
    for (std::size_t k = first; k < s.events.size(); ++k) {
      const TouchEvent& e = s.events[k].touch;
      input.apply(e);
      selection.onTouch(e, input, cam, vp);
      const std::vector<glm::dvec2> request = selection.takePickRequest();
      if (request.empty()) continue;
      std::vector<std::optional<glm::dvec3>> world;
      for (const gpu::PickResult& h : picker.pick(cam, vp, request))
        world.push_back(h.world.w > 0.5f ? std::optional<glm::dvec3>(glm::dvec3(h.world)) : std::nullopt);
      selection.onPicks(world, cam, vp);
    }
    const auto voxels = selection.takeFinished();
    if (!voxels || voxels->empty())
      throw Error("compose: the pinch on label " + std::to_string(handle == 1 ? o.organ : o.anchor) + " selects nothing" +
                  (selection.feedback().empty() ? "" : " (" + selection.feedback() + ")"));
    for (std::uint32_t v : *voxels) mask[v] = handle;
  }

  // From here the handle moves, and each gesture is run here too on the rigid model the app draws
  // while dragging (its own HandleManipulator, anchored by CPU picks with the handle drawn at its
  // pose), so that every later touch goes where the handle then shows — innermost, away from the
  // seam that the simulated deformation blends between the handle and its surroundings.
  void prepareHandle() {
    lo = picker.volume().geometry.dims;
    hi = Eigen::Vector3i(-1, -1, -1);
    for (std::size_t v = 0; v < mask.size(); ++v)
      if (mask[v] == 1) {
        const Eigen::Vector3i c = picker.volume().geometry.voxelOf(std::uint32_t(v));
        lo = lo.cwiseMin(c);
        hi = hi.cwiseMax(c);
      }
  }
  std::vector<MovingHandlePose> drawn(const RigidTransform& pose) const {
    std::vector<MovingHandlePose> m;
    if (!pose.isIdentity()) m.push_back(MovingHandlePose{1, pose, lo, hi});
    return m;
  }
  Footprint seen(const RigidTransform& pose, int step) const {
    const HandleOverlay handles{mask, drawn(pose)};
    return look(picker, labels, cam, vp, step, &handles);
  }
  // Fingers put down at frames[0] and moved through the later frames: the handle's new pose; how
  // many fingers landed on it goes to `anchored`.
  RigidTransform simulatePath(const RigidTransform& pose, const std::vector<std::vector<glm::dvec2>>& frames) {
    const std::vector<gpu::PickResult> hits = picker.pick(cam, vp, frames.front(), &mask, drawn(pose));
    std::vector<FingerAnchor> anchors;
    for (std::size_t i = 0; i < hits.size(); ++i)
      if (hits[i].world.w > 0.5f && hits[i].voxel.w == 1) anchors.push_back({std::int64_t(i), Eigen::Vector3d(hits[i].world.x, hits[i].world.y, hits[i].world.z)});
    anchored = anchors.size();
    if (anchors.empty()) return pose;
    HandleManipulator m;
    m.anchor(anchors, pose);
    RigidTransform p = pose;
    for (std::size_t k = 1; k < frames.size(); ++k) {
      std::vector<std::pair<std::int64_t, glm::dvec2>> ndc;
      for (std::size_t i = 0; i < frames[k].size(); ++i) ndc.push_back({std::int64_t(i), vp.toNdc(frames[k][i])});
      if (const auto q = m.move(ndc, p, cam, aspect, 0)) p = *q;
    }
    return p;
  }
  RigidTransform simulate(const RigidTransform& pose, const std::vector<glm::dvec2>& from, const std::vector<glm::dvec2>& to, int steps) {
    return simulatePath(pose, lerpFrames(from, to, steps));
  }
  static double distanceAt(const Footprint& f, const std::vector<double>& dist, glm::dvec2 q) {
    const int i = int(std::floor(q.x / f.step)), j = int(std::floor(q.y / f.step));
    return i < 0 || j < 0 || i >= f.nx || j >= f.ny ? 0.0 : dist[std::size_t(i) + std::size_t(f.nx) * std::size_t(j)];
  }

  // Three fingers first, on the handle at rest: two hold an axis (0.86 arm above the innermost
  // pixel), the third (0.43 arm below) is drawn 0.36 arm toward them; every finger inside the
  // inscribed disc (they are at most 1.32 arms from its centre).
  void tiltWithThree() {
    const Footprint rest = seen(RigidTransform{}, 2);
    const auto [h0, rh] = rest.innermost(rest.innerDistance(onHandle1));
    if (rh < 8.0)
      throw Error("compose: the selection of label " + std::to_string(o.organ) + " shows too little surface for the fingers (" +
                  std::to_string(rh) + " px of room, 8 needed)");
    out.handleRadiusPx = rh;
    // A tilt's outcome is not up to the fingers alone (docs/gesture-solve.md: three fingers are ill-posed when
    // the touched surface faces the viewer: a small screen motion is a large turn either way). Of the
    // layout turned by 0, 90, 180 and 270 degrees, only one whose result is stable is used: run again
    // with every finger 1 px off (as picks on another driver or grid may land), it turns about an axis
    // across the view (an out-of-plane tilt) by the same angle (within 25 % and 15 degrees of axis).
    // Among those, the one after which most of the handle stays in sight.
    const double arm = std::min((rh - 3.0) / 1.32, 15.0 / mmPerPx);
    std::vector<glm::dvec2> tilt0, tilt1;
    const glm::dvec3 fwd = cam.forward();
    for (int k = 0; k < 4; ++k) {
      const glm::dvec2 x(std::cos(k * kPi / 2.0), std::sin(k * kPi / 2.0)), y(-x.y, x.x);  // the layout's right and down
      const std::vector<glm::dvec2> from{h0 + arm * (-x - 0.86 * y), h0 + arm * (x - 0.86 * y), h0 + arm * 0.43 * y};
      std::vector<glm::dvec2> to = from;
      to[2] -= 0.36 * arm * y;
      bool stable = true;
      RigidTransform p;
      Eigen::AngleAxisd nominal(0.0, Eigen::Vector3d::UnitX());
      for (const glm::dvec2 off : {glm::dvec2(0.0), glm::dvec2(1.0, 0.0), glm::dvec2(0.0, 1.0), glm::dvec2(-1.0, -1.0)}) {
        std::vector<glm::dvec2> a = from, b = to;
        for (std::size_t i = 0; i < a.size(); ++i) a[i] += off, b[i] += off;
        const RigidTransform q = simulate(RigidTransform{}, a, b, 20);
        const Eigen::AngleAxisd turn(q.R);
        if (anchored != 3 || std::abs(turn.axis().dot(Eigen::Vector3d(fwd.x, fwd.y, fwd.z))) > 0.5 || turn.angle() < glm::radians(5.0)) {
          stable = false;
          break;
        }
        if (off == glm::dvec2(0.0)) {
          p = q;
          nominal = turn;
        } else if (std::abs(turn.angle() - nominal.angle()) > 0.25 * nominal.angle() ||
                   std::abs(turn.axis().dot(nominal.axis())) < std::cos(glm::radians(15.0))) {
          stable = false;
          break;
        }
      }
      if (!stable) continue;
      Footprint f = seen(p, 2);
      const auto [c, r] = f.innermost(f.innerDistance(onHandle1));
      if (r > r1) tilt0 = from, tilt1 = to, tilted = p, g1 = c, r1 = r;
    }
    if (tilt0.empty()) throw Error("compose: no three-finger tilt on the selection of label " + std::to_string(o.organ) + " turns it stably out of plane here");
    if (r1 < 6.0) throw Error("compose: the tilted selection of label " + std::to_string(o.organ) + " leaves no room for a finger");
    w.stroke(8, tilt0, tilt1, 20, 0.05);
  }

  // One finger, from where the tilted handle shows most: of eight directions (starting away from
  // the anchor), the one after which most of it stays in sight (a kidney dragged into the liver
  // hides behind it).
  void dragWithOne() {
    glm::dvec2 away = co - ca;
    away = glm::length(away) > 1e-6 ? glm::normalize(away) : glm::dvec2(0.0, 1.0);
    const double dragPx = o.dragMm / mmPerPx;
    u = away;
    dragged = tilted;
    double bestRoom = -1.0;
    for (int k : {0, 1, -1, 2, -2, 3, -3, 4}) {
      const double a = k * kPi / 4.0;
      const glm::dvec2 dir(std::cos(a) * away.x - std::sin(a) * away.y, std::sin(a) * away.x + std::cos(a) * away.y);
      const RigidTransform p = simulate(tilted, {g1}, {g1 + dir * dragPx}, 10);
      if (anchored != 1) continue;
      const Footprint f = seen(p, 4);
      const double room = distanceAt(f, f.innerDistance(onHandle1), g1 + dir * dragPx);
      if (room > bestRoom) bestRoom = room, u = dir, dragged = p;
    }
    if (bestRoom < 0.0) throw Error("compose: no one-finger drag of the tilted selection keeps a finger on it");
    h1 = g1 + u * dragPx;
    w.stroke(11, {g1}, {h1}, 10, 0.05);
  }

  // Of eight orientations for two fingers `h` either side of `c`, both 3 px inside the handle, the
  // one whose picked depths differ least (two anchors at different depths dragged in parallel read
  // partly as depth).
  static glm::dvec2 orientPair(const Footprint& f, const std::vector<double>& room, glm::dvec2 c, double h) {
    glm::dvec2 best(1.0, 0.0);
    double bestDz = kInf;
    for (int k = 0; k < 8; ++k) {
      const glm::dvec2 d(std::cos(k * kPi / 8.0), std::sin(k * kPi / 8.0));
      if (distanceAt(f, room, c + h * d) < 3.0 || distanceAt(f, room, c - h * d) < 3.0) continue;
      const double dz = std::abs(f.depthAt(c + h * d) - f.depthAt(c - h * d));
      if (dz < bestDz) bestDz = dz, best = d;
    }
    return best;
  }

  // Two fingers, across the one-finger drag, both well on the handle.
  void pushWithTwo() {
    const double pushPx = o.pushMm / mmPerPx;
    const glm::dvec2 across(-u.y, u.x);
    const Footprint afterDrag = seen(dragged, 2);
    const std::vector<double> roomAfterDrag = afterDrag.innerDistance(onHandle1);
    const double half = std::min({0.35 * r1, 10.0 / mmPerPx, distanceAt(afterDrag, roomAfterDrag, h1) - 3.0});
    if (half < 2.0) throw Error("compose: after the one-finger drag the selection of label " + std::to_string(o.organ) + " has no room for two fingers");
    const glm::dvec2 pair = orientPair(afterDrag, roomAfterDrag, h1, half);
    const glm::dvec2 h2 = h1 + across * pushPx;
    pushed = simulate(dragged, {h1 - half * pair, h1 + half * pair}, {h2 - half * pair, h2 + half * pair}, 11);
    if (anchored != 2) throw Error("compose: the two-finger drag's fingers do not both land on the selection");
    w.stroke(12, {h1 - half * pair, h1 + half * pair}, {h2 - half * pair, h2 + half * pair}, 11, 0.05);
  }

  // Two fingers where the handle in `f` shows most: their centre and direction; returns their
  // half-distance.
  double pairAt(const Footprint& f, glm::dvec2& centre, glm::dvec2& dir) const {
    const std::vector<double> room = f.innerDistance(onHandle1);
    const auto [c, r] = f.innermost(room);
    const double h = std::min(0.35 * r, 10.0 / mmPerPx);
    if (h < 2.0) throw Error("compose: the moved selection of label " + std::to_string(o.organ) + " has no room for two fingers");
    centre = c;
    dir = orientPair(f, room, c, h);
    return h;
  }

  // Two fingers where the handle then shows most, twisted 20 degrees about their midpoint (a turn
  // about the view axis); then two fingers spread by 6 % (the handle comes toward the viewer by about 6 % of its distance,
  // some 25 mm: the pinch keeps the picked points under the fingers, so depth goes as 1 / spread).
  void twistAndSpread() {
    glm::dvec2 c3, d3;
    const double h3 = pairAt(seen(pushed, 2), c3, d3);
    const double twist = glm::radians(20.0);
    const std::vector<glm::dvec2> twist0{c3 - h3 * d3, c3 + h3 * d3};
    // The fingers follow the arc (straight chords of 2 degrees each), as a hand turns.
    std::vector<std::vector<glm::dvec2>> twistFrames{twist0};
    for (int k = 1; k <= 10; ++k) {
      const double a = twist * k / 10.0;
      const glm::dvec2 dk(std::cos(a) * d3.x - std::sin(a) * d3.y, std::sin(a) * d3.x + std::cos(a) * d3.y);
      twistFrames.push_back({glm::round((c3 - h3 * dk) * 4.0) / 4.0, glm::round((c3 + h3 * dk) * 4.0) / 4.0});
    }
    const RigidTransform twisted = simulatePath(pushed, twistFrames);
    if (anchored != 2) throw Error("compose: the twist's fingers do not both land on the selection");
    w.path(16, twistFrames, 0.05);
    glm::dvec2 c4, d4;
    const double h4 = pairAt(seen(twisted, 2), c4, d4);
    spread = simulate(twisted, {c4 - h4 * d4, c4 + h4 * d4}, {c4 - 1.06 * h4 * d4, c4 + 1.06 * h4 * d4}, 10);
    if (anchored != 2) throw Error("compose: the depth pinch's fingers do not both land on the selection");
    w.stroke(18, {c4 - h4 * d4, c4 + h4 * d4}, {c4 - 1.06 * h4 * d4, c4 + 1.06 * h4 * d4}, 10, 0.05);
  }

  // Select mode: a tap where the moved handle shows most picks it; then the handle edits, each
  // undone. Navigate: a drag that starts off both structures (where the view is emptiest) orbits;
  // the view reset, the export.
  void finish() {
    const Footprint last = seen(spread, 2);
    const auto [tap, rt] = last.innermost(last.innerDistance(onHandle1));
    if (rt < 3.0) throw Error("compose: after the drags the selection of label " + std::to_string(o.organ) + " is out of sight");
    w.ui(UiAction::SetMode, "select");
    w.stroke(14, {tap}, {tap}, 1, 0.04);
    w.t += 0.3;
    for (const auto& [a, v] : std::vector<std::pair<UiAction, const char*>>{
             {UiAction::HandleUnion, "1,2"}, {UiAction::Undo, ""}, {UiAction::Redo, ""}, {UiAction::Undo, ""}, {UiAction::HandleDifference, "1,2"}, {UiAction::Undo, ""}})
      w.ui(a, v);
    w.ui(UiAction::SetMode, "navigate");
    const std::vector<double> background = fp.innerDistance([](int l) { return l == kBackground; });
    const bool someBackground = *std::max_element(background.begin(), background.end()) >= 12.0;
    const glm::dvec2 p = fp.innermost(someBackground ? background : fp.innerDistance([this](int l) { return !organ(l) && !anchor(l); })).first;
    const double dx = std::round(40.0 * vp.height / 512.0);
    w.stroke(20, {p}, {p + glm::dvec2(p.x < mid.x ? dx : -dx, 0.0)}, 9, 0.05);
    w.ui(UiAction::ResetCamera, "", 0.2);
    w.ui(UiAction::Export);
  }
};

}  // namespace

ComposedSession composeFullSession(const Volume& ct, const Volume& labels, const ComposeOptions& o, const std::string& volumePath) {
  if (!labels.geometry().sameGrid(ct.geometry()))
    throw Error("compose: the label map's grid is not the CT's (dimensions, spacing, origin or orientation differ)");
  if (o.organ == o.anchor) throw Error("compose: the organ and the anchor must be different labels");
  if (o.viewport.width < 64 || o.viewport.height < 64 || o.viewport.width > 8192 || o.viewport.height > 8192)
    throw Error("compose: the viewport must be 64 to 8192 pixels a side");
  if (!(o.dragMm >= 0.0 && o.dragMm <= 200.0 && o.pushMm >= 0.0 && o.pushMm <= 200.0))
    throw Error("compose: drag distances must be 0 to 200 mm");
  const Eigen::Vector3i deep = deepestVoxel(labels, o.organ, ct);
  if (deep.x() < 0) throw Error("compose: label " + std::to_string(o.organ) + " (organ) is not in the label map");
  if (deepestVoxel(labels, o.anchor, ct).x() < 0) throw Error("compose: label " + std::to_string(o.anchor) + " (anchor) is not in the label map");
  const std::string preset = o.preset.empty() ? defaultPresetFor(ct) : o.preset;
  // The roomiest views in turn, until one takes the whole session (a later phase can find no room
  // on a view that shows the organ: a tilt that is not stable, a drag behind a neighbour).
  auto attempt = [&](const std::string& p, bool clip) {
    const std::vector<ComposeView> views = Composer(ct, labels, o, p, clip).rankViews(deep);
    std::string firstFailure;
    for (std::size_t r = 0; r < std::min(views.size(), kComposeViewsTried); ++r) {
      try {
        return Composer(ct, labels, o, p, clip).compose(deep, views[r], volumePath);
      } catch (const Error& e) {
        if (firstFailure.empty()) firstFailure = e.what();
      }
    }
    throw Error(firstFailure + " (and on the next " + std::to_string(std::min(views.size(), kComposeViewsTried) - 1) + " roomiest views)");
  };
  try {
    return attempt(preset, false);
  } catch (const Error& unclipped) {
    if (std::string(unclipped.what()).find("no view direction shows") == std::string::npos) throw;
    // No view shows the organ as it is: cut in front of it, under the soft-tissue preset on a CT
    // whose preset was not chosen (the organs of a non-contrast CT show there).
    const std::string clipPreset = o.preset.empty() && preset == "ct-abdomen" ? "ct-soft-tissue" : preset;
    return attempt(clipPreset, true);
  }
}

}  // namespace handson
