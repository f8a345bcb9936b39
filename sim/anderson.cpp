#include "sim/anderson.h"

#include <algorithm>
#include <vector>

namespace handson {

void AndersonAcceleration::reset() {
  count_ = 0;
  next_ = 0;
  havePrevious_ = false;
}

void AndersonAcceleration::push(const Eigen::VectorXd& x, const Eigen::VectorXd& f) {
  if (dX_.rows() != x.size() || dX_.cols() != depth_) {
    dX_.resize(x.size(), depth_);
    dF_.resize(x.size(), depth_);
    count_ = next_ = 0;
  }
  dX_.col(next_) = x - xPrev_;
  dF_.col(next_) = f - fPrev_;
  next_ = (next_ + 1) % depth_;
  count_ = std::min(count_ + 1, depth_);
}

// gamma = argmin |f - dF gamma| by Gram-Schmidt on dF's columns, newest pair first, each
// orthogonalized twice against the ones before ("twice is enough": orthogonal to rounding even when
// the secants are nearly parallel), in q_ (n x m, no allocation once sized). A column left with
// under 1e-10 of its length is dependent on newer ones and drops out (its gamma 0), so of two
// nearly parallel pairs the older goes. gamma is indexed by ring slot.
Eigen::VectorXd AndersonAcceleration::leastSquares(const Eigen::VectorXd& f) {
  const int m = count_;
  q_.resize(dF_.rows(), depth_);
  std::vector<int> slot(static_cast<std::size_t>(m), 0);  // the j-th newest pair's column
  for (int j = 0; j < m; ++j) slot[std::size_t(j)] = ((next_ - 1 - j) % depth_ + depth_) % depth_;
  Eigen::MatrixXd R = Eigen::MatrixXd::Zero(m, m);  // m x m, upper triangular in newest-first order
  std::vector<char> kept(std::size_t(m), 0);
  for (int j = 0; j < m; ++j) {
    q_.col(j) = dF_.col(slot[std::size_t(j)]);
    const double length = q_.col(j).norm();
    for (int pass = 0; pass < 2; ++pass)
      for (int i = 0; i < j; ++i)
        if (kept[std::size_t(i)]) {
          const double c = q_.col(i).dot(q_.col(j));
          R(i, j) += c;
          q_.col(j) -= c * q_.col(i);
        }
    const double left = q_.col(j).norm();
    if (!(left > 1e-10 * length)) continue;
    kept[std::size_t(j)] = 1;
    R(j, j) = left;
    q_.col(j) /= left;
  }
  Eigen::VectorXd g = Eigen::VectorXd::Zero(m);  // newest-first order
  for (int j = m - 1; j >= 0; --j) {
    if (!kept[std::size_t(j)]) continue;
    double v = q_.col(j).dot(f);
    for (int k = j + 1; k < m; ++k) v -= R(j, k) * g[k];
    g[j] = v / R(j, j);
  }
  Eigen::VectorXd gamma = Eigen::VectorXd::Zero(m);
  for (int j = 0; j < m; ++j) gamma[slot[std::size_t(j)]] = g[j];
  return gamma;
}

Eigen::VectorXd AndersonAcceleration::step(const Eigen::VectorXd& x, const Eigen::VectorXd& f) {
  // A pair whose update did not change (the same iterate again) says nothing of the map: skipped.
  if (havePrevious_ && depth_ > 0 && xPrev_.size() == x.size() && (f - fPrev_).squaredNorm() > 1e-28 * f.squaredNorm()) push(x, f);
  if (count_ > 0 && dX_.rows() != x.size()) reset();
  xPrev_ = x;
  fPrev_ = f;
  havePrevious_ = true;
  if (count_ == 0) return f;
  const Eigen::VectorXd gamma = leastSquares(f);  // m, by ring slot
  if (!gamma.allFinite()) return f;
  Eigen::VectorXd s = f;
  s.noalias() -= dX_.leftCols(count_) * gamma;
  s.noalias() -= dF_.leftCols(count_) * gamma;
  return s;
}

namespace {

double largestTriple(const Eigen::VectorXd& v) {
  double m = 0.0;
  for (Eigen::Index i = 0; i + 2 < v.size(); i += 3) m = std::max(m, v.segment<3>(i).norm());
  return m;
}

}  // namespace

Eigen::VectorXd AndersonAcceleration::guardedStep(const Eigen::VectorXd& x, const Eigen::VectorXd& f, double maxRatio) {
  Eigen::VectorXd s = step(x, f);
  if (s.allFinite() && largestTriple(s) <= maxRatio * largestTriple(f)) return s;
  reset();
  return f;
}

}  // namespace handson
