#include "pressure/warm_start.h"

#include <Eigen/Eigenvalues>
#include <algorithm>

#include "pressure/learned_warm_start.h"

namespace iqmpm {

WarmStart::WarmStart(const WarmStartSpec& spec, int dim, const std::vector<int>& cells) : spec_(spec) {
  if (spec_.kind == WarmStartKind::learned) learned_ = LearnedPredictor::load(spec_.model, dim, cells);
}
WarmStart::WarmStart() = default;
WarmStart::~WarmStart() = default;
WarmStart::WarmStart(WarmStart&&) noexcept = default;
WarmStart& WarmStart::operator=(WarmStart&&) noexcept = default;

std::size_t WarmStart::kept() const {
  switch (spec_.kind) {
    case WarmStartKind::none: return 0;
    case WarmStartKind::previous: return 1;
    case WarmStartKind::extrapolate: return 2;
    case WarmStartKind::projection: return std::size_t(std::max(spec_.history, 1));
    case WarmStartKind::learned: return std::size_t(std::max(spec_.history, learned_->sequence_length()));
  }
  return 1;
}

void WarmStart::remember(const UnknownLocations& where, const Eigen::VectorXd& x, double time) {
  const std::size_t keep = kept();
  if (keep == 0) return;
  history_.push_back(map_to_grid(where, x, time));
  while (history_.size() > keep) history_.pop_front();
}

void WarmStart::guess(const UnknownLocations& where, const Eigen::SparseMatrix<Real>& A, const Eigen::VectorXd& b,
                      double time, Eigen::VectorXd& x) {
  x.setZero(A.rows());
  if (history_.empty()) return;
  switch (spec_.kind) {
    case WarmStartKind::none: return;
    case WarmStartKind::previous: map_from_grid(history_.back(), where, x); return;
    case WarmStartKind::extrapolate: {
      const GridSolution& last = history_.back();
      map_from_grid(last, where, x);
      if (history_.size() < 2) return;
      const GridSolution& before = history_[history_.size() - 2];
      const double ratio = (time - last.time) / (last.time - before.time);
      // Where the location was active in both steps; elsewhere the last value stands.
      for (int k = 0; k < block_count; ++k) {
        if (where.offset[k] < 0 || last.value[k].size() != std::size_t(where.locations[k]) ||
            before.value[k].size() != last.value[k].size())
          continue;
        for (std::size_t i = 0; i < where.location[k].size(); ++i) {
          const int l = where.location[k][i];
          if (last.active[k][l] && before.active[k][l])
            x[where.offset[k] + Eigen::Index(i)] += ratio * (last.value[k][l] - before.value[k][l]);
        }
      }
      return;
    }
    case WarmStartKind::projection: project(where, A, b, nullptr, x); return;
    case WarmStartKind::learned: {
      // The walls' multipliers are no field of the network: they take the last step's, as
      // every field does until the network has the T steps it was trained on.
      Eigen::VectorXd predicted = Eigen::VectorXd::Zero(A.rows());
      map_from_grid(history_.back(), where, predicted);
      if (history_.size() >= std::size_t(learned_->sequence_length())) {
        Eigen::VectorXd network = predicted;
        map_from_grid(learned_->predict(history_, where), where, network, {true, true, false, true});
        // A prediction that is not finite (a network outside what it was trained on) is
        // not used: the step starts from the last solution instead, and is counted.
        if (network.allFinite())
          predicted = network;
        else
          ++rejected_predictions_;
      }
      if (spec_.history == 0) {
        x = predicted;
        return;
      }
      project(where, A, b, &predicted, x);
      return;
    }
  }
}

void WarmStart::project(const UnknownLocations& where, const Eigen::SparseMatrix<Real>& A, const Eigen::VectorXd& b,
                        const Eigen::VectorXd* extra, Eigen::VectorXd& x) {
  const std::size_t columns = std::min<std::size_t>(history_.size(), std::size_t(std::max(spec_.history, 1)));
  Eigen::MatrixXd X = Eigen::MatrixXd::Zero(A.rows(), Eigen::Index(columns) + (extra ? 1 : 0));
  for (std::size_t j = 0; j < columns; ++j) {
    Eigen::VectorXd column = Eigen::VectorXd::Zero(A.rows());
    map_from_grid(history_[history_.size() - 1 - j], where, column);
    X.col(Eigen::Index(j)) = column;
  }
  if (extra) X.col(X.cols() - 1) = *extra;
  x = a_norm_best_combination(A, b, X);
  if (!x.allFinite()) {  // an overflow in X^T A X: the newest column alone
    x = X.col(extra ? X.cols() - 1 : 0);
    ++rejected_predictions_;
  }
}

Eigen::VectorXd a_norm_best_combination(const Eigen::SparseMatrix<Real>& A, const Eigen::VectorXd& b,
                                        const Eigen::MatrixXd& X) {
  // A is symmetric: A^T X is the row-major product Eigen runs on the threads.
  const Eigen::MatrixXd AX = A.transpose() * X;
  Eigen::MatrixXd gram = X.transpose() * AX;
  gram = 0.5 * (gram + gram.transpose());
  // Scaled to a unit diagonal, then solved by its eigenvectors with the near-null
  // directions (dependent or zero columns) dropped: the minimum-norm least-A-norm c.
  Eigen::VectorXd scale = Eigen::VectorXd::Zero(X.cols());
  for (Eigen::Index j = 0; j < X.cols(); ++j)
    if (gram(j, j) > 0) scale[j] = 1 / std::sqrt(gram(j, j));
  const Eigen::MatrixXd scaled = scale.asDiagonal() * gram * scale.asDiagonal();
  const Eigen::VectorXd rhs = scale.asDiagonal() * (X.transpose() * b);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(scaled);
  const Eigen::VectorXd& values = eigen.eigenvalues();
  const Real cut = 1e-12 * std::max<Real>(values.size() ? values.maxCoeff() : 0, 0);
  Eigen::VectorXd c = Eigen::VectorXd::Zero(X.cols());
  for (Eigen::Index k = 0; k < values.size(); ++k)
    if (values[k] > cut && values[k] > 0)
      c += eigen.eigenvectors().col(k) * (eigen.eigenvectors().col(k).dot(rhs) / values[k]);
  return X * (scale.asDiagonal() * c);
}

}  // namespace iqmpm
