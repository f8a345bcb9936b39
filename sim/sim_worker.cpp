#include "sim_worker.h"

#include <chrono>
#include <exception>
#include <utility>

namespace handson {

SimWorker::SimWorker(CoarseModel& model, const std::vector<Mat12>& fineK, const SimWorkerOptions& options)
    : model_(model), refiner_(model, fineK), options_(options) {
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

void SimWorker::run() {
  std::vector<Eigen::Vector3d> x = model_.restState();  // warm start: the last coarse state
  std::vector<Eigen::Vector3d> lastGood = x;
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
    s.input = input;
    try {
      s.stats = model_.solve(handles, x, options_.coarseIterations);
      s.coarse = x;
      s.fine = model_.reconstruct(handles, x);
      lastGood = x;
    } catch (const std::exception& e) {
      x = lastGood;
      s.error = e.what();
      s.coarse = x;
    }
    s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const bool refine = s.error.empty() && options_.refineSteps > 0;
    std::vector<Eigen::Vector3d> fine = refine ? s.fine : std::vector<Eigen::Vector3d>{};
    publish(std::move(s));
    if (!refine) continue;
    for (int step = 1; step <= options_.refineSteps; ++step) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (stop_ || pending_) break;  // a newer input wins
      }
      refiner_.step(x, fine, options_.refineIterations);
      SimSnapshot r;
      r.input = input;
      r.refineStep = step;
      r.coarse = x;
      r.fine = fine;
      r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      publish(std::move(r));
    }
  }
}

}  // namespace handson
