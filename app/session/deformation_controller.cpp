#include "deformation_controller.h"

#include "app/io/volume_io.h"
#include "app/io/fine_mesh_vtu.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <sstream>

#include "render/deform_pass.h"
#include "sim/coarsening.h"
#include "sim/base/error.h"
#include "sim/fine_interpolation.h"
#include "sim/quantized_volume.h"
#include "sim/region_shape.h"
#include "sim/sliding_interface.h"
#include "sim/scene_cache.h"
#include "sim/scene_cut.h"
#include "sim/strain.h"
#include "sim/tet_raster.h"
#include "sim/tissue_limits.h"

namespace handson {

namespace {
struct Cancelled {};
}  // namespace

struct DeformationController::Model {
  SimScene scene;
  std::unique_ptr<CoarseModel> model;
  FineInterpolationData data;
  std::unique_ptr<SimWorker> worker;
  double seconds = 0.0;
  CacheOutcome cache;  // loaded from the on-disk cache, or a note about it
  std::vector<std::size_t> refusedCuts;  // the session's cuts the scene refused (their indices)
  std::string cutNote;                   // what the cuts did
};

DeformationController::DeformationController(const Volume& image, const QuantizedVolume& quantized, VolumeRenderer& renderer, DeformationOptions options)
    : image_(image), quantized_(quantized), renderer_(renderer), options_(std::move(options)) {
  const VolumeGeometry& g = image.geometry();
  imageLo_ = Eigen::Vector3d::Constant(1e300);
  imageHi_ = -imageLo_;
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3d w = g.toWorld(Eigen::Vector3d((c & 1) ? g.dims.x() - 1 : 0, (c & 2) ? g.dims.y() - 1 : 0, (c & 4) ? g.dims.z() - 1 : 0));
    imageLo_ = imageLo_.cwiseMin(w);
    imageHi_ = imageHi_.cwiseMax(w);
  }
}

DeformationController::~DeformationController() {
  try {
    stopAll();
    reapBuilders(true);
  } catch (...) {
    // Shutting down: the renderer may already be gone from under a lost device.
  }
}

DeformationController::Key DeformationController::keyOf(const HandleSet& handles) {
  Key k;
  for (const auto& h : handles.handles()) {
    if (h.status == HandleStatus::Idle || h.voxels.empty()) continue;
    k.ids.push_back(h.status == HandleStatus::Fixed ? -h.id : h.id);
    k.sizes.push_back(h.voxels.size());
    k.firstVoxels.push_back(std::size_t(h.voxels.front()) * 31u + h.voxels.back());
  }
  return k;
}

void DeformationController::reapBuilders(bool wait) {
  for (auto it = retired_.begin(); it != retired_.end();)
    if (wait || it->done->load()) {
      if (it->thread.joinable()) it->thread.join();
      it = retired_.erase(it);
    } else {
      ++it;
    }
}

void DeformationController::stopAll() {
  ++generation_;  // a running build sees it at its next progress report and stops
  // Never wait for a cancelled build on the render thread: it is joined once it has noticed.
  if (builder_.joinable()) retired_.push_back({std::move(builder_), builderDone_});
  {
    std::lock_guard<std::mutex> lock(mutex_);
    built_.reset();
    building_ = false;
    error_.clear();
  }
  if (model_) {
    model_->worker.reset();  // joins the solve
    model_.reset();
  }
  renderer_.endDeformation();
  state_.reset();
  stateFresh_ = fineFresh_ = false;
  shownRefineStep_ = 0;
  sentPoses_.clear();
  shownInput_ = lastSent_ = answeredInput_ = 0;
  shownReactions_.clear();
  shownLimits_.reset();
  shownConverged_ = shownSettled_ = answeredSettled_ = false;
  unconverged_ = false;
  lastError_.clear();
}

void DeformationController::startBuild(const HandleSet& handles) {
  stopAll();
  std::vector<SimHandle> sim;
  simIds_.clear();
  simActive_.clear();
  restBoxes_.clear();
  restVoxelBoxes_.clear();
  restOutline_.clear();
  const VolumeGeometry& g = image_.geometry();
  for (int pass = 0; pass < 2; ++pass)  // active handles first, then fixed ones
    for (const auto& h : handles.handles()) {
      if (h.voxels.empty() || h.status != (pass == 0 ? HandleStatus::Active : HandleStatus::Fixed)) continue;
      sim.push_back({h.voxels, {h.pose}});  // the region covers where the handle is now
      simIds_.push_back(h.id);
      simActive_.push_back(pass == 0);
      Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
      std::vector<Eigen::Vector3d> centres;
      centres.reserve(h.voxels.size());
      for (std::uint32_t v : h.voxels) {
        const Eigen::Vector3d w = g.toWorld(g.voxelOf(v).cast<double>());
        lo = lo.cwiseMin(w);
        hi = hi.cwiseMax(w);
        centres.push_back(w);
      }
      restBoxes_.push_back({lo, hi});
      restVoxelBoxes_.push_back(voxelIndexBox(g, h.voxels));
      // Its outside, thinned to 4 mm: what must stay clear of a shaped region's held cells.
      HandlePoints outline = thinHandlePoints(centres, std::max(4.0, g.spacing.maxCoeff()));
      std::vector<Eigen::Vector3d> surface;
      for (std::size_t i = 0; i < outline.point.size(); ++i)
        if (outline.surface[i]) surface.push_back(outline.point[i]);
      restOutline_.push_back(std::move(surface));
    }
  if (simActive_.empty() || !simActive_.front()) return;  // nothing moves: nothing to simulate
  ++buildsStarted_;
  const std::uint64_t gen = generation_.load();
  builderDone_ = std::make_shared<std::atomic<bool>>(false);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    building_ = true;
    buildStage_ = "starting";
    buildFraction_ = 0.0;
  }
  // The builder takes its own copy of the settings and the cuts: the render thread may change them.
  builder_ = std::thread([this, gen, done = builderDone_, sim = std::move(sim), cuts = cuts_, settings = options_.sim, cacheDir = options_.cacheDir] {
    struct MarkDone {
      std::shared_ptr<std::atomic<bool>> flag;
      ~MarkDone() { flag->store(true); }
    } markDone{done};
    const auto t0 = std::chrono::steady_clock::now();
    const ProgressFn progress = [this, gen](double f, const std::string& stage) {
      if (generation_.load() != gen) throw Cancelled{};
      std::lock_guard<std::mutex> lock(mutex_);
      buildStage_ = stage;
      buildFraction_ = f;
    };
    try {
      auto m = std::make_unique<Model>();
      m->model = buildOrLoadSimulation(image_, sim, settings, m->scene, {cacheDir, &m->cache}, progress);
      cutBuilt(*m, {cuts, settings.coarseSolver, progress});
      m->data = m->model->interpolationData();
      m->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::lock_guard<std::mutex> lock(mutex_);
      if (generation_.load() == gen) {
        built_ = std::move(m);
        building_ = false;
      }
    } catch (const Cancelled&) {
      // A newer handle set replaced this one.
    } catch (const std::exception& e) {
      std::lock_guard<std::mutex> lock(mutex_);
      if (generation_.load() == gen) {
        error_ = e.what();
        building_ = false;
      }
    }
  });
}

bool DeformationController::outgrown(const std::vector<RigidTransform>& T) const {
  if (!model_) return false;
  const SimScene& sc = model_->scene;
  const double margin = 0.5 * options_.sim.paddingMm;
  for (std::size_t i = 0; i < T.size() && i < restBoxes_.size(); ++i) {
    if (!simActive_[i]) continue;
    const auto& [lo, hi] = restBoxes_[i];
    for (int c = 0; c < 8; ++c) {
      const Eigen::Vector3d w = T[i].apply(Eigen::Vector3d((c & 1) ? hi.x() : lo.x(), (c & 2) ? hi.y() : lo.y(), (c & 4) ? hi.z() : lo.z()));
      for (int a = 0; a < 3; ++a) {
        // A side already at the image's edge cannot grow: no rebuild for it.
        if (w[a] < sc.lo[a] + margin && sc.lo[a] > imageLo_[a] + 1e-6) return true;
        if (w[a] > sc.hi[a] - margin && sc.hi[a] < imageHi_[a] - 1e-6) return true;
      }
    }
    if (i < restOutline_.size() && outlineNearRegionBoundary(sc.meshes.coarseGrid, sc.regionCell, restOutline_[i], T[i].R, T[i].t, margin)) return true;
  }
  return false;
}

void DeformationController::adoptBuilt() {
  std::unique_ptr<Model> m;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    m = std::move(built_);
  }
  if (!m) return;
  if (builder_.joinable()) builder_.join();  // it has finished: it handed its model over
  // Built with the cuts as they are now (a change restarts the build). A cut refused by the first
  // build after it was made goes; one that an earlier build took stays (refused here by this
  // build's region, which follows the handles, it may be taken again by a later one).
  for (auto i = m->refusedCuts.rbegin(); i != m->refusedCuts.rend(); ++i)
    if (*i >= confirmedCuts_ && *i < cuts_.size()) cuts_.erase(cuts_.begin() + std::ptrdiff_t(*i));
  confirmedCuts_ = cuts_.size();
  SimWorkerOptions wo;
  wo.coarseIterations = options_.coarseIterations;
  wo.idleIterations = options_.idleIterations;
  wo.reconstructFine = false;  // the GPU interpolates the fine nodes
  wo.elementRotations = true;
  wo.refineSteps = options_.refineSteps;
  wo.tissueLimits = options_.sim.materials;  // the refined state says what tissue is past its limit
  wo.movingHandles.assign(simActive_.begin(), simActive_.end());  // and which active handle's motion did it
  m->worker = std::make_unique<SimWorker>(*m->model, m->scene, wo);
  vk::DeformSetup setup;
  setup.interpolation = &m->data;
  setup.fineTets = &m->scene.meshes.fine.tets;
  setup.regionLo = m->scene.lo;
  setup.regionHi = m->scene.hi;
  setup.background = quantized_.toNormalized(image_.valueRange().first);
  setup.worldToIndex = image_.geometry().worldToIndex();
  // The limit highlight: each fine tet's tissue limit, when the table gives any.
  const std::vector<float> limits = tetStrainLimits(m->scene.band, options_.sim.materials);
  if (std::any_of(limits.begin(), limits.end(), [](float l) { return std::isfinite(l); })) setup.strainLimits = &limits;  // finite, or a handle's own (hidden)
  // Handles that slide are drawn where their poses put them (the tets straddling their surfaces
  // slide with the tissue); glued ones by their tets.
  if (!m->scene.constraints.slide.empty()) {
    const std::vector<char> slides = slidingHandles(m->scene.constraints.slide, simIds_.size());
    for (std::size_t h = 0; h < simIds_.size(); ++h) setup.rigidIds.push_back(slides[h] ? std::uint32_t(simIds_[h]) : 0);
    setup.rigidRestBoxes = restVoxelBoxes_;
  }
  try {
    renderer_.beginDeformation(setup);
  } catch (const std::exception& e) {
    std::lock_guard<std::mutex> lock(mutex_);
    error_ = std::string("the GPU cannot show the deformation: ") + e.what();
    return;
  }
  model_ = std::move(m);
}

void DeformationController::pull() {
  if (!model_) return;
  while (auto s = model_->worker->takeLatest()) {
    answeredInput_ = s->input;
    answeredSettled_ = s->settled;
    if (s->limits && s->refineStep > 0 && s->input == shownInput_ && s->refineStep == shownRefineStep_) {
      shownLimits_ = s->limits;  // the report on the state already shown (the worker publishes it after the state)
      continue;
    }
    if (!s->error.empty()) {  // refused input: the last good state stays
      if (lastError_.empty()) ++failures_;  // a new episode of refused poses
      lastError_ = s->error;
      continue;
    }
    try {
      state_ = packFrameState(s->coarse, s->rotations, s->handles);
      if (s->refineStep > 0 && !s->fine.empty()) {
        const Eigen::Matrix4d w2i = image_.geometry().worldToIndex();
        finePositions_.resize(s->fine.size());
        for (std::size_t i = 0; i < s->fine.size(); ++i) {
          if (!s->fine[i].allFinite()) throw Error("simulation: a refined position is not finite");
          finePositions_[i] = (w2i * s->fine[i].homogeneous()).cast<float>();
        }
        fineFresh_ = true;
        stateFresh_ = false;
      } else {
        fineFresh_ = false;
        stateFresh_ = true;
      }
      shownRefineStep_ = s->refineStep;
    } catch (const std::exception& e) {
      lastError_ = e.what();
      continue;
    }
    lastError_.clear();
    if (s->refineStep > 0) {
      stages_.add("refinement", s->refineMs);
    } else {
      stages_.add("coarse-solve", s->stats.solveMs);
      stages_.add("boundary-forces", s->stats.boundaryMs);
    }
    shownInput_ = s->input;
    shownSeconds_ = s->seconds;
    if (s->refineStep == 0) shownConverged_ = s->stats.converged;  // a refined state keeps its coarse solve's
    shownSettled_ = s->settled;
    shownStats_ = s->stats;
    shownReactions_ = s->reactions;
    shownLimits_ = s->limits;
    // States the worker stopped on without converging: a failure of the solve, counted once per
    // episode (a drag gives one unconverged pose after another until a pose converges again).
    if (s->settled && s->refineStep == 0) {
      if (!s->stats.converged && !unconverged_) ++failures_;
      unconverged_ = !s->stats.converged;
    }
  }
}

// The uncut scene's model becomes the cut one's: the scene cut group by group on a copy (cutScene
// leaves it unchanged when it refuses a group), then the coarse model updated from the uncut one
// where the cuts pass (sim/coarse_cut.cpp). The uncut model reads only its own data in that update,
// so the scenes are swapped first (the cut model refers to the Model's scene) and back if the
// update fails, which refuses every cut of this build and keeps the uncut model.
void DeformationController::cutBuilt(Model& m, const CutBuild& b) {
  if (b.cuts.empty()) return;
  std::string why = "graded cells and tet elements do not see cuts";
  SimScene cut = m.scene;
  std::size_t faces = 0;
  const bool cells = m.model->elementKind() == CoarseElement::Cell && !m.model->graded();
  for (std::size_t i = 0; i < b.cuts.size(); ++i) try {
      reportProgress(b.progress, double(i) / double(b.cuts.size()), "cutting");  // a newer build cancels this one here
      if (!cells) throw Error(why);
      faces += cutScene(cut, b.cuts[i]).cutFaces;
    } catch (const Error& e) {
      m.refusedCuts.push_back(i);
      why = e.what();
    }
  std::ostringstream note;
  if (m.refusedCuts.size() < b.cuts.size()) {
    std::swap(m.scene, cut);  // `cut` holds the uncut scene now
    try {
      m.model = std::make_unique<CoarseModel>(*m.model, m.scene.meshes, m.scene.fineK, m.scene.constraints, b.progress);
      m.model->setSolver(b.solver);
      note << b.cuts.size() - m.refusedCuts.size() << (b.cuts.size() - m.refusedCuts.size() == 1 ? " cut, " : " cuts, ") << faces << " faces separated, "
           << m.model->elementCount() - m.scene.meshes.coarseGrid.cellCount() << " coarse elements added";
    } catch (const Error& e) {
      std::swap(m.scene, cut);
      m.refusedCuts.resize(b.cuts.size());
      std::iota(m.refusedCuts.begin(), m.refusedCuts.end(), std::size_t{0});
      why = std::string("the coarse model could not be updated: ") + e.what();
    }
  }
  if (!m.refusedCuts.empty()) note << (m.refusedCuts.size() < b.cuts.size() ? "; " : "") << m.refusedCuts.size() << " refused: " << why;
  m.cutNote = note.str();
}

bool DeformationController::addCut(const std::vector<CutQuad>& quads) {
  if (quads.empty() || quads.size() > kMaxCutQuads) return false;
  cuts_.push_back(quads);
  rebuild_ = true;
  return true;
}

void DeformationController::clearCuts() {
  if (cuts_.empty()) return;
  cuts_.clear();
  confirmedCuts_ = 0;
  rebuild_ = true;
}

void DeformationController::setInterface(SimSettings::Interface i) {
  if (i == options_.sim.interface) return;
  options_.sim.interface = i;
  rebuild_ = true;
}

bool DeformationController::prepareFrame(FrameRequest& req, const HandleSet& handles, bool attach) {
  if (!options_.enabled) return false;
  reapBuilders(false);
  const Key key = keyOf(handles);
  if (!(key == key_) || rebuild_) {
    key_ = key;
    rebuild_ = false;
    startBuild(handles);
  }
  if (!model_) adoptBuilt();
  if (!model_) return false;
  // Active handles move with their pose; fixed ones are held where they are (their pose too).
  std::vector<RigidTransform> T(simIds_.size());
  for (std::size_t i = 0; i < simIds_.size(); ++i)
    if (const Handle* h = handles.find(simIds_[i])) T[i] = h->pose;
  if (outgrown(T)) {
    // The handle came within half the padding of the region's fixed faces: rebuild around where
    // it is now (moved handles are drawn rigidly meanwhile).
    startBuild(handles);
    return false;
  }
  bool changed = T.size() != sentPoses_.size();
  for (std::size_t i = 0; !changed && i < T.size(); ++i) changed = T[i].R != sentPoses_[i].R || T[i].t != sentPoses_[i].t;
  if (changed) {
    lastSent_ = model_->worker->setHandles(T);
    sentPoses_ = T;
  }
  pull();
  if (!attach) return shownInput_ > 0;
  if (fineFresh_) {
    req.deformFine = &finePositions_;  // shown; its coarse state too, for a later redo
    if (state_) req.deform = &*state_;
    fineFresh_ = false;
  } else if (state_ && stateFresh_) {
    req.deform = &*state_;
    stateFresh_ = false;
  }
  return shownInput_ > 0;
}

bool DeformationController::prepareFrameSettled(FrameRequest& req, const HandleSet& handles, double seconds) {
  // Only the settled answer is shown (never an intermediate one that happened to land first), so
  // the frames do not depend on timing.
  prepareFrame(req, handles, false);
  if (state() == State::Building && waitBuilt(seconds)) prepareFrame(req, handles, false);
  if (model_) waitSettled(seconds);
  req.deformExact = true;  // drawn at its exact state, not lagging as live frames during motion may
  return prepareFrame(req, handles, true);
}

double DeformationController::fineCellMm() const {
  if (!model_) return 0.0;
  const NestedMeshes& m = model_->scene.meshes;
  return m.coarseGrid.cell().maxCoeff() / double(std::max(1, m.refinement));
}

bool DeformationController::exportDeformed(Volume& out) const {
  if (!model_ || !renderer_.deforming() || shownInput_ == 0) return false;
  out = image_;
  renderer_.settleDeformation();  // a frame during motion may have left the images lagging the state
  takeRegionFromQuantized(out, quantized_, renderer_.deformer()->readVolume(), model_->scene.lo, model_->scene.hi);
  return true;
}

std::vector<Eigen::Vector3d> DeformationController::drawnFinePositions() const {
  renderer_.settleDeformation();                           // the exact state, not one lagging it
  const auto pos = renderer_.deformer()->readPositions();  // voxel index space, as drawn
  if (pos.size() != model_->scene.meshes.fine.nodes.size()) return {};
  const Eigen::Matrix4d toWorld = quantized_.geometry.worldToIndex().inverse();
  std::vector<Eigen::Vector3d> x(pos.size());
  for (std::size_t i = 0; i < pos.size(); ++i) x[i] = (toWorld * pos[i].cast<double>()).head<3>();
  return x;
}

bool DeformationController::exportMeshAndStrain(const std::string& meshPath, const std::string& strainPath) const {
  if (!model_ || !renderer_.deforming() || shownInput_ == 0) return false;
  const SimScene& sc = model_->scene;
  const auto x = drawnFinePositions();
  if (x.empty()) return false;
  std::vector<float> strain = tetStrain(sc.meshes.fine, x);
  const std::vector<float> limits = tetStrainLimits(sc.band, options_.sim.materials);
  hideRigidStrain(strain, limits);
  std::vector<double> element(sc.meshes.fine.tets.size());
  for (std::size_t t = 0; t < element.size(); ++t) element[t] = model_->model->elementOfFineTet(t);
  writeFineMeshVtu(meshPath, {sc, x, strain, limits, element});
  std::vector<std::int32_t> tetOf;
  Volume unused;
  rasterizeDeformed(image_, sc.meshes.fine, x, {sc.lo, sc.hi, 0.0f}, unused,
                    {nullptr, nullptr, defaultMaxTetVoxels(sc.meshes.fine, image_.geometry().worldToIndex()), &tetOf, {}});
  writeVolume(strainVolume(image_.geometry(), tetOf, strain), strainPath);
  return true;
}

DeformationController::State DeformationController::state() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!error_.empty()) return State::Failed;
  if (model_ || built_) return State::Ready;
  if (building_) return State::Building;
  return State::Off;
}

namespace {
std::string formatMm(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", v);
  return text;
}
}  // namespace

std::uint64_t DeformationController::failures() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return failures_ + (error_.empty() ? 0 : 1);
}

std::string DeformationController::status() const {
  std::ostringstream s;
  switch (state()) {
    case State::Off: return "";
    case State::Failed: {
      std::lock_guard<std::mutex> lock(mutex_);
      return "simulation failed: " + error_;
    }
    case State::Building: {
      std::lock_guard<std::mutex> lock(mutex_);
      char pct[16];
      std::snprintf(pct, sizeof(pct), "%.0f%%", 100.0 * buildFraction_);
      return "simulation: " + buildStage_ + " " + pct;
    }
    case State::Ready:
      if (!model_) return "simulation: ready";
      s << "simulation: " << model_->scene.meshes.coarse.tets.size() << " coarse / " << model_->scene.meshes.fine.tets.size() << " fine tets"
        << (shownInput_ == 0 ? ""
            : shownSettled_ && !shownConverged_ && shownRefineStep_ == 0
                ? ", did not converge (" + std::to_string(shownStats_.iterations) + (shownStats_.iterations == 1 ? " iteration" : " iterations") +
                      ", last update " + formatMm(shownStats_.lastUpdate) + " mm): showing the last state it reached"
                : ", " + modelState())
        << (lastError_.empty() ? "" : "; last pose refused: " + lastError_) << (model_->cache.hit ? " (preprocessing from the cache)" : "")
        << (model_->cache.note.empty() ? "" : " [" + model_->cache.note + "]") << (model_->cutNote.empty() ? "" : "; " + model_->cutNote);
      return s.str();
  }
  return "";
}

bool DeformationController::waitBuilt(double seconds) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  for (;;) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!building_) return bool(built_) || bool(model_);
    }
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

std::string DeformationController::shownTissueLimits() const {
  return shownLimits_ ? describeTissueLimits(*shownLimits_, simIds_) : std::string();
}

std::vector<std::pair<int, HandleReaction>> DeformationController::shownReactions() const {
  std::vector<std::pair<int, HandleReaction>> out;
  if (!model_ || shownInput_ == 0) return out;
  for (std::size_t k = 0; k < shownReactions_.size() && k < simIds_.size(); ++k) out.emplace_back(simIds_[k], shownReactions_[k]);
  return out;
}

std::string DeformationController::modelState() const {
  switch (state()) {
    case State::Off: return "";
    case State::Building: return "building";
    case State::Failed: return "failed";
    case State::Ready: break;
  }
  if (shownInput_ == 0) return "rest";
  if (shownRefineStep_ == 0 && !shownConverged_) return shownSettled_ ? "unconverged" : "coarse";
  const int n = options_.refineSteps;
  if (shownRefineStep_ >= n) return "converged";
  return "refining " + std::to_string(shownRefineStep_) + "/" + std::to_string(n);
}

bool DeformationController::waitSettled(double seconds) {
  if (!model_ || lastSent_ == 0) return false;
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  for (;;) {
    pull();
    if (answeredInput_ == lastSent_ && answeredSettled_) return true;
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

}  // namespace handson
