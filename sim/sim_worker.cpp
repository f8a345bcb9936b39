#include "sim_worker.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "sim/error.h"
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

void SimWorker::run() {
  try {
    model_.prepareSolve();  // the solver's one-off set-up before the first pose, not inside its frame
  } catch (const std::exception&) {
    // Reported by the first solve, which tries again.
  }
  std::vector<Eigen::Vector3d> x = model_.restState();  // warm start: the last coarse state
  std::vector<Eigen::Vector3d> lastGood = x;
  std::vector<RigidTransform> solved(std::size_t(model_.constraints().handleCount));  // at rest
  auto snapshot = [&](std::uint64_t input, const std::vector<RigidTransform>& handles, const CoarseSolveStats& st, std::chrono::steady_clock::time_point t0) {
    SimSnapshot s;
    s.input = input;
    s.stats = st;
    s.coarse = x;
    s.handles = handles;
    if (options_.reconstructFine) s.fine = model_.reconstruct(handles, x);
    if (options_.elementRotations) s.rotations = model_.elementRotations(x);
    s.reactions = model_.handleReactions(handles, x);
    s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return s;
  };
  auto newer = [&] {
    std::lock_guard<std::mutex> lock(mutex_);
    return stop_ || pending_.has_value();
  };
  for (;;) {
    std::vector<RigidTransform> handles;
    std::uint64_t input = 0;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [&] { return stop_ || pending_.has_value(); });
      if (stop_) return;
      handles = std::move(*pending_);
      pending_.reset();
      input = submitted_;
    }
    const auto t0 = std::chrono::steady_clock::now();
    SimSnapshot s;
    CoarseSolveStats st;
    try {
      if (!finite(handles)) throw Error("simulation: a handle transform is not finite");
      double solveMs = 0.0, boundaryMs = 0.0;  // over all increments
      for (const auto& Tk : increments(solved, handles, options_.continuationMm, options_.continuationDeg)) {
        {
          std::lock_guard<std::mutex> lock(mutex_);
          if (stop_) return;  // shutting down: do not finish a long continuation
        }
        st = model_.solve(Tk, x, options_.coarseIterations);
        solveMs += st.solveMs;
        boundaryMs += st.boundaryMs;
      }
      st.solveMs = solveMs;
      st.boundaryMs = boundaryMs;
      s = snapshot(input, handles, st, t0);
      s.settled = (st.converged || options_.idleIterations <= 0) && options_.refineSteps <= 0;
      lastGood = x;
      solved = handles;
    } catch (const std::exception& e) {
      x = lastGood;
      s = SimSnapshot{};
      s.input = input;
      s.error = e.what();
      s.coarse = x;
      s.settled = true;  // answered: with an error
      st = CoarseSolveStats{};
    }
    const bool ok = s.error.empty();
    std::vector<Eigen::Vector3d> fine = s.fine;
    publish(std::move(s));
    if (!ok) continue;
    // A held pose settles: more coarse iterations while nothing newer arrives.
    bool failed = false;
    for (int done = 0; !st.converged && done < options_.idleIterations && !newer(); done += options_.coarseIterations) {
      try {
        st = model_.solve(handles, x, options_.coarseIterations);
        lastGood = x;
        SimSnapshot more = snapshot(input, handles, st, t0);
        more.settled = (st.converged || done + options_.coarseIterations >= options_.idleIterations) && options_.refineSteps <= 0;
        fine = more.fine;
        publish(std::move(more));
      } catch (const std::exception& e) {
        // The last good state stays; this input is answered (settled) with the error.
        x = lastGood;
        SimSnapshot err;
        err.input = input;
        err.error = e.what();
        err.coarse = x;
        err.settled = true;
        publish(std::move(err));
        failed = true;
        break;
      }
    }
    if (failed) continue;
    if (options_.refineSteps <= 0) continue;
    if (fine.empty()) {
      if (newer()) continue;
      fine = model_.reconstruct(handles, x);  // the refinement starts from the coarse answer
    }
    for (int step = 1; step <= options_.refineSteps; ++step) {
      if (newer()) break;  // a newer input wins
      SimSnapshot r;
      r.input = input;
      try {
        const auto s0 = std::chrono::steady_clock::now();
        refiner_.step(handles, x, fine, options_.refineIterations);
        r.refineMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - s0).count();
        r.refineStep = step;
        r.coarse = x;
        r.fine = fine;
        r.handles = handles;
        r.settled = step == options_.refineSteps;
        if (options_.elementRotations) r.rotations = model_.elementRotations(x);
        r.reactions = fineHandleReactions(model_.meshes().fine, fineK_, model_.constraints(), handles, fine);
      } catch (const std::exception& e) {
        r = SimSnapshot{};
        r.input = input;
        r.error = e.what();
        r.coarse = x;
        r.settled = true;
        publish(std::move(r));
        break;
      }
      r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const bool report = r.settled && options_.tissueLimits && scene_;
      std::optional<SimSnapshot> again;
      if (report) again = r;  // the state is published at once; its report follows (publishWithLimits)
      publish(std::move(r));
      if (report && !newer()) publishWithLimits(std::move(*again), t0);
    }
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
