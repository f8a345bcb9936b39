#pragma once
// Anderson acceleration of a fixed-point iteration x <- x + f(x) (Walker & Ni 2011, "type II"):
// the next iterate mixes the last few iterates so that the linear model of f through their secant
// pairs vanishes in the least-squares sense. For the coarse solve (sim/coarse_pcg.cpp) f is the
// preconditioned update d = A(R)^-1 r(x); the lagged rotations make that iteration converge
// linearly, slowly where small elements turn against stiff ones (docs/simulation.md, "The coarse
// solve").
//
// With the last m secant pairs, dX = [x_i+1 - x_i] and dF = [f_i+1 - f_i] (n x m each):
//   gamma = argmin_g |f_k - dF g|_2          (m unknowns; Gram-Schmidt QR)
//   x_k+1 = x_k + f_k - (dX + dF) gamma.
// With no pair it is the plain step x_k + f_k. Pairs are formed only within one run of the
// iteration (begin() starts a run); pairs from earlier runs are kept, as secants of the nearly
// same map (a drag's frames), until the depth pushes them out or reset() drops them.
#include <Eigen/Core>

namespace handson {

class AndersonAcceleration {
 public:
  /// depth m: secant pairs kept (0: the plain iteration).
  explicit AndersonAcceleration(int depth) : depth_(depth) {}
  /// A new run: the next step forms no pair with the last run's iterate.
  void begin() { havePrevious_ = false; }
  /// Drops every pair.
  void reset();
  /// The next iterate from x and its update f = g(x) - x (same size, free dofs). Returns the step
  /// taken, next - x.
  Eigen::VectorXd step(const Eigen::VectorXd& x, const Eigen::VectorXd& f);
  /// step() for stacked 3-vectors (node positions): a mix that is not finite, or whose largest
  /// 3-vector is more than maxRatio times the plain update's largest, is dropped for the plain
  /// update f, and every pair with it (secants that no longer describe the map: the map changed
  /// under them, or it barely changes along a secant, so the mix extrapolates far along it).
  Eigen::VectorXd guardedStep(const Eigen::VectorXd& x, const Eigen::VectorXd& f, double maxRatio);
  int pairs() const { return count_; }

 private:
  void push(const Eigen::VectorXd& x, const Eigen::VectorXd& f);
  Eigen::VectorXd leastSquares(const Eigen::VectorXd& f);
  int depth_;
  Eigen::MatrixXd dX_, dF_;  ///< n x depth: the pairs, a ring (next_ the slot the next one takes)
  int count_ = 0, next_ = 0;
  Eigen::MatrixXd q_;        ///< n x depth: the secants' orthonormal basis (leastSquares' storage)
  Eigen::VectorXd xPrev_, fPrev_;
  bool havePrevious_ = false;
};

}  // namespace handson
