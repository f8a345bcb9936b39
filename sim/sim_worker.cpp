#include "sim_worker.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "sim/base/error.h"
#include "sim/strain.h"

#include <chrono>
#include <exception>
#include <utility>

namespace handson {

SimWorker::SimWorker(CoarseModel& model, const std::vector<Mat12>& fineK, const SimWorkerOptions& options)
    : model_(model), fineK_(fineK), refiner_(model, fineK), options_(options) {
  thread_ = std::thread([this] { run(); });
}

SimWorker::SimWorker(CoarseModel& model, const SimScene& scene, const SimWorkerOptions& options)
    : model_(model),
      fineK_(scene.fineK),
      refiner_(model, scene.fineK, scene.youngs, scene.poisson, RefineOptions{options.refineMethod, options.refineThreads}),
      options_(options),
      scene_(&scene) {
  thread_ = std::thread([this] { run(); });
}

SimWorker::~SimWorker() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

std::uint64_t SimWorker::setHandles(std::vector<RigidTransform> handles) {
  std::uint64_t id;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    pending_ = std::move(handles);
    id = ++submitted_;
  }
  wake_.notify_one();
  return id;
}

std::optional<SimSnapshot> SimWorker::takeLatest() {
  std::lock_guard<std::mutex> lock(mutex_);
  return std::exchange(latest_, std::nullopt);
}

std::optional<SimSnapshot> SimWorker::waitFor(std::uint64_t input, int refineStep, double timeoutSeconds) {
  std::unique_lock<std::mutex> lock(mutex_);
  const bool ok = published_.wait_for(lock, std::chrono::duration<double>(timeoutSeconds),
                                      [&] { return lastInput_ > input || (lastInput_ == input && lastStep_ >= refineStep); });
  if (!ok) return std::nullopt;
  return latest_ ? std::exchange(latest_, std::nullopt) : std::nullopt;
}

void SimWorker::publish(SimSnapshot s) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    lastInput_ = s.input;
    lastStep_ = s.refineStep;
    latest_ = std::move(s);
  }
  published_.notify_all();
}

namespace {
// Increments from `from` to `to` such that no handle turns by more than maxDeg or translates by
// more than maxMm in one (at least one increment: `to` itself).
std::vector<std::vector<RigidTransform>> increments(const std::vector<RigidTransform>& from, const std::vector<RigidTransform>& to, double maxMm,
                                                     double maxDeg) {
  int steps = 1;
  if (from.size() == to.size())
    for (std::size_t h = 0; h < to.size(); ++h) {
      const Eigen::AngleAxisd rel(from[h].R.transpose() * to[h].R);
      steps = std::max({steps, int(std::ceil(std::abs(rel.angle()) * 180.0 / M_PI / maxDeg)), int(std::ceil((to[h].t - from[h].t).norm() / maxMm))});
    }
  steps = std::min(steps, 64);
  std::vector<std::vector<RigidTransform>> out;
  for (int k = 1; k < steps; ++k) {
    const double f = double(k) / steps;
    std::vector<RigidTransform> Tk(to.size());
    for (std::size_t h = 0; h < to.size(); ++h) {
      const Eigen::AngleAxisd rel(from[h].R.transpose() * to[h].R);
      Tk[h].R = from[h].R * Eigen::AngleAxisd(f * rel.angle(), rel.axis()).toRotationMatrix();
      Tk[h].t = from[h].t + f * (to[h].t - from[h].t);
    }
    out.push_back(std::move(Tk));
  }
  out.push_back(to);
  return out;
}

bool finite(const std::vector<RigidTransform>& T) {
  for (const auto& t : T)
    if (!t.R.allFinite() || !t.t.allFinite()) return false;
  return true;
}
}  // namespace

// The worker's coarse state across inputs: the last state (the warm start), the last state a solve
// accepted, and the poses it answered.
struct SimWorker::RunState {
  std::vector<Eigen::Vector3d> x, lastGood;
  std::vector<RigidTransform> solved;
};

// One input being answered: its poses, its number and when its answer began.
struct SimWorker::Input {
  std::vector<RigidTransform> handles;
  std::uint64_t number = 0;
  std::chrono::steady_clock::time_point t0;
};

SimSnapshot SimWorker::snapshot(const Input& in, const std::vector<Eigen::Vector3d>& x, const CoarseSolveStats& st) const {
  SimSnapshot s;
  s.input = in.number;
  s.stats = st;
  s.coarse = x;
  s.handles = in.handles;
  if (options_.reconstructFine) s.fine = model_.reconstruct(in.handles, x);
  if (options_.elementRotations) s.rotations = model_.elementRotations(x);
  s.reactions = model_.handleReactions(in.handles, x);
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - in.t0).count();
  return s;
}

// An input answered with an error: the last good state stands (settled: answered).
SimSnapshot SimWorker::failed(const Input& in, RunState& r, const std::string& what) {
  r.x = r.lastGood;
  SimSnapshot s;
  s.input = in.number;
  s.error = what;
  s.coarse = r.x;
  s.settled = true;
  return s;
}

bool SimWorker::newer() {
  std::lock_guard<std::mutex> lock(mutex_);
  return stop_ || pending_.has_value();
}

std::optional<SimWorker::Input> SimWorker::nextInput() {
  std::unique_lock<std::mutex> lock(mutex_);
  wake_.wait(lock, [&] { return stop_ || pending_.has_value(); });
  if (stop_) return std::nullopt;
  Input in;
  in.handles = std::move(*pending_);
  pending_.reset();
  in.number = submitted_;
  in.t0 = std::chrono::steady_clock::now();
  return in;
}

// The coarse solve of an input, through the continuation's increments from the last poses solved;
// published. Nullopt when stopping or when the input was refused (the error is published).
std::optional<CoarseSolveStats> SimWorker::solveInput(const Input& in, RunState& r, std::vector<Eigen::Vector3d>& fine) {
  CoarseSolveStats st;
  SimSnapshot s;
  try {
    if (!finite(in.handles)) throw Error("simulation: a handle transform is not finite");
    double solveMs = 0.0, boundaryMs = 0.0;  // over all increments
    for (const auto& Tk : increments(r.solved, in.handles, options_.continuationMm, options_.continuationDeg)) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (stop_) return std::nullopt;  // shutting down: do not finish a long continuation
      }
      st = model_.solve(Tk, r.x, options_.coarseIterations);
      solveMs += st.solveMs;
      boundaryMs += st.boundaryMs;
    }
    st.solveMs = solveMs;
    st.boundaryMs = boundaryMs;
    s = snapshot(in, r.x, st);
    s.settled = (st.converged || options_.idleIterations <= 0) && options_.refineSteps <= 0;
    r.lastGood = r.x;
    r.solved = in.handles;
  } catch (const std::exception& e) {
    publish(failed(in, r, e.what()));
    return std::nullopt;
  }
  fine = s.fine;
  publish(std::move(s));
  return st;
}

// A held pose settles: more coarse iterations while nothing newer arrives, each published. False
// when a solve failed (its error published).
bool SimWorker::settle(const Input& in, RunState& r, CoarseSolveStats st, std::vector<Eigen::Vector3d>& fine) {
  for (int done = 0; !st.converged && done < options_.idleIterations && !newer(); done += options_.coarseIterations) {
    try {
      st = model_.solve(in.handles, r.x, options_.coarseIterations);
      r.lastGood = r.x;
      SimSnapshot more = snapshot(in, r.x, st);
      more.settled = (st.converged || done + options_.coarseIterations >= options_.idleIterations) && options_.refineSteps <= 0;
      fine = more.fine;
      publish(std::move(more));
    } catch (const std::exception& e) {
      publish(failed(in, r, e.what()));  // the last good state stays; this input is answered with the error
      return false;
    }
  }
  return true;
}

// The two-level refinement of a held pose from the coarse answer, each step published (the last
// with its tissue-limit report after it) until a newer input arrives.
void SimWorker::refine(const Input& in, const RunState& r, std::vector<Eigen::Vector3d> fine) {
  if (fine.empty()) {
    if (newer()) return;
    fine = model_.reconstruct(in.handles, r.x);  // the refinement starts from the coarse answer
  }
  for (int step = 1; step <= options_.refineSteps; ++step) {
    if (newer()) break;  // a newer input wins
    SimSnapshot s;
    s.input = in.number;
    try {
      const auto s0 = std::chrono::steady_clock::now();
      refiner_.step(in.handles, r.x, fine, options_.refineIterations);
      s.refineMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - s0).count();
      s.refineStep = step;
      s.coarse = r.x;
      s.fine = fine;
      s.handles = in.handles;
      s.settled = step == options_.refineSteps;
      if (options_.elementRotations) s.rotations = model_.elementRotations(r.x);
      s.reactions = fineHandleReactions(model_.meshes().fine, fineK_, model_.constraints(), in.handles, fine);
    } catch (const std::exception& e) {
      SimSnapshot err;
      err.input = in.number;
      err.error = e.what();
      err.coarse = r.x;
      err.settled = true;
      publish(std::move(err));
      break;
    }
    s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - in.t0).count();
    const bool report = s.settled && options_.tissueLimits && scene_;
    std::optional<SimSnapshot> again;
    if (report) again = s;  // the state is published at once; its report follows (publishWithLimits)
    publish(std::move(s));
    if (report && !newer()) publishWithLimits(std::move(*again), in.t0);
  }
}

void SimWorker::run() {
  try {
    model_.prepareSolve();  // the solver's one-off set-up before the first pose, not inside its frame
  } catch (const std::exception&) {
    // Reported by the first solve, which tries again.
  }
  RunState r;
  r.x = model_.restState();  // warm start: the last coarse state
  r.lastGood = r.x;
  r.solved.assign(std::size_t(model_.constraints().handleCount), RigidTransform{});  // at rest
  while (const std::optional<Input> in = nextInput()) {
    std::vector<Eigen::Vector3d> fine;
    const std::optional<CoarseSolveStats> st = solveInput(*in, r, fine);
    if (!st) {
      std::lock_guard<std::mutex> lock(mutex_);
      if (stop_) return;
      continue;
    }
    if (!settle(*in, r, *st, fine)) continue;
    if (options_.refineSteps > 0) refine(*in, r, std::move(fine));
  }
}

void SimWorker::publishWithLimits(SimSnapshot s, std::chrono::steady_clock::time_point t0) {
  try {
    const TetMesh& mesh = scene_->meshes.fine;
    if (!nearest_) nearest_ = nearestHandleOfNodes(mesh, scene_->constraints, options_.movingHandles);
    s.limits = tissueLimits(mesh, tetStrain(mesh, s.fine), scene_->band, *options_.tissueLimits, *nearest_, scene_->constraints.handleCount);
  } catch (const std::exception&) {
    return;  // no report (e.g. out of memory): the state itself was published and stands
  }
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  publish(std::move(s));
}

}  // namespace handson
