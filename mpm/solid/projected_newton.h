// Projected Newton minimiser of method.md §3 step 2, independent of MPM: it only needs a
// Potential with
//   Vector initial_velocity(), Real energy(x) (+inf outside the domain), Vector gradient(x),
//   SparseMatrix hessian(x, bool project_to_psd), Real gradient_scale().
// Direction: H d = -g either by a sparse LDL^T factorisation (direct, exact Newton steps; the
// symbolic analysis is done once per minimisation since the pattern does not change), or
// by CG with a diagonal preconditioner (on products H x without assembling H when the
// Potential offers linearize(x, project) -> {diagonal, ...} and hessian_product(linear, x);
// the solid's does), to the relative tolerance
//   eta_k = min(cg_max_tolerance, max(cg_min_tolerance, cg_forcing ||g_k|| / ||g_0||,
//                                     cg_stop_margin cg_stop / ||g_k||)),
// which keeps Newton's local quadratic rate (inexact Newton with eta_k = O(||g_k||)) and asks
// CG for no more than the stop needs (a step leaves about eta_k ||g_k|| of gradient). A
// Newton iteration (energy, SVDs, stiffness, line search) costs several CG products, so the
// first direction is already solved to cg_max_tolerance.
// Step: backtracking (Armijo) line search on the energy; a trial with a non-finite energy
// (e.g. an inverted neo-Hookean particle) is rejected like one that does not decrease.
// Stop: ||g_k|| <= max(relative_tolerance ||g_0||, absolute_tolerance gradient_scale()), with
// cg_relative_tolerance in place of relative_tolerance for CG directions (cg_stop), since an
// exact step lands quadratically below the stop and a forced CG step only just below it
// (method.md#solid-step); the CG that stands in for a failed factorisation is forced towards
// cg_stop too. Or a gradient stalled at the round-off floor within stall_factor of the direct
// stop.
// The result reports every gradient norm and why the iteration stopped; a step that did not
// converge is returned as such (the caller decides whether that is a NumericalFailure).
#pragma once

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/types.h"
#include "linear_solver/pcg.h"

namespace iqmpm {

struct ProjectedNewtonOptions {
  Real relative_tolerance = 1e-5;   // on ||g_k|| / ||g_0||, exact (direct) Newton steps
  Real cg_relative_tolerance = 1e-7;  // the same, when the directions are by CG
  Real absolute_tolerance = 1e-12;  // on ||g_k|| / gradient_scale() (a body at rest, roundoff)
  int max_iterations = 50;          // Newton iterations
  bool project_hessian = true;      // per-particle PSD projection of dP/dF (SPD system)
  bool direct = false;              // LDL^T factorisation instead of CG for the direction
  Real cg_forcing = 0.1;            // eta_k = cg_forcing ||g_k|| / ||g_0||, clamped to:
  Real cg_max_tolerance = 1e-2;
  Real cg_min_tolerance = 1e-12;
  Real cg_stop_margin = 0.5;        // eta_k >= cg_stop_margin tolerance / ||g_k||
  int cg_max_iterations = 1000;     // per Newton iteration; an unfinished CG still descends
  Real armijo = 1e-4;               // sufficient decrease E(x + a d) <= E(x) + armijo a g.d
  Real backtracking_factor = 0.5;
  // A gradient that changes by less than stall_change (relative) in one iteration, within
  // stall_factor of the direct stop (relative_tolerance), is at the round-off floor and
  // counts as converged.
  Real stall_change = 1e-6;
  Real stall_factor = 100;
  int max_backtracks = 40;
  // Energy differences below this times |E| are roundoff: accepted as "no increase".
  Real energy_roundoff = 1e-14;
};

enum class NewtonStatus {
  converged,
  max_iterations,      // iteration cap reached, gradient still above tolerance
  line_search_failed,  // no step along d decreased E (at the roundoff floor, or a bad direction)
  non_finite,          // the start is outside the energy's domain, or CG returned NaN
};

inline const char* to_string(NewtonStatus status) {
  switch (status) {
    case NewtonStatus::converged: return "converged";
    case NewtonStatus::max_iterations: return "max_iterations";
    case NewtonStatus::line_search_failed: return "line_search_failed";
    case NewtonStatus::non_finite: return "non_finite";
  }
  return "unknown";
}

struct NewtonResult {
  NewtonStatus status = NewtonStatus::non_finite;
  bool converged = false;
  int iterations = 0;              // accepted Newton steps
  int cg_iterations = 0;           // total over all Newton iterations
  int cg_unfinished = 0;           // CG solves that hit cg_max_iterations
  int backtracks = 0;              // total step halvings
  int gradient_fallbacks = 0;      // directions replaced by -g (not a descent direction)
  bool started_from_zero = false;  // v^n was outside the energy's domain, started from v = 0
  std::vector<Real> gradient_norms;  // ||g_0||, ||g_1||, ...
  std::vector<Real> energies;        // E_0, E_1, ...
  Real tolerance = 0;                // the gradient norm that counted as converged
  bool roundoff_floor = false;       // converged by stalling within stall_factor of the direct stop

  std::string summary() const {
    std::ostringstream out;
    out << "Newton " << to_string(status) << " after " << iterations << " iterations (" << cg_iterations
        << " CG, " << backtracks << " backtracks); |g| =";
    for (Real g : gradient_norms) out << ' ' << g;
    out << "; tolerance " << tolerance;
    if (roundoff_floor) out << " (stalled at the round-off floor)";
    return out.str();
  }
};

// Whether a Potential gives Hessian products without assembling the Hessian.
template <class P, class = void>
struct HasHessianProducts : std::false_type {};
template <class P>
struct HasHessianProducts<P, std::void_t<decltype(std::declval<const P&>().hessian_product(
                                 std::declval<const P&>().linearize(std::declval<const typename P::Vector&>(), true),
                                 std::declval<const typename P::Vector&>()))>> : std::true_type {};

template <class Potential>
NewtonResult minimize_projected_newton(const Potential& potential, Eigen::Matrix<Real, Eigen::Dynamic, 1>& x,
                                       const ProjectedNewtonOptions& options = {}) {
  using Vector = Eigen::Matrix<Real, Eigen::Dynamic, 1>;
  using SparseMatrix = typename Potential::SparseMatrix;
  NewtonResult result;

  Real energy = potential.energy(x);
  if (!std::isfinite(energy)) {
    x.setZero();
    energy = potential.energy(x);
    result.started_from_zero = true;
    if (!std::isfinite(energy)) {
      result.status = NewtonStatus::non_finite;
      return result;
    }
  }
  Vector g = potential.gradient(x);
  Real g_norm = g.norm();
  const Real g0 = g_norm;
  result.gradient_norms.push_back(g_norm);
  result.energies.push_back(energy);
  const Real absolute = options.absolute_tolerance * potential.gradient_scale();
  const Real direct_tolerance = std::max(options.relative_tolerance * g0, absolute);
  const Real cg_stop = std::max(options.cg_relative_tolerance * g0, absolute);
  result.tolerance = options.direct ? direct_tolerance : cg_stop;
  if (!std::isfinite(g_norm)) {
    result.status = NewtonStatus::non_finite;
    return result;
  }
  if (g_norm <= result.tolerance) {
    result.status = NewtonStatus::converged;
    result.converged = true;
    return result;
  }

  Eigen::ConjugateGradient<SparseMatrix, Eigen::Lower | Eigen::Upper, Eigen::DiagonalPreconditioner<Real>> cg;
  using ColumnMatrix = Eigen::SparseMatrix<Real, Eigen::ColMajor, int>;
  Eigen::SimplicialLDLT<ColumnMatrix> ldlt;
  bool analysed = false;
  result.status = NewtonStatus::max_iterations;
  for (int k = 0; k < options.max_iterations; ++k) {
    Vector d;
    bool solved = false;
    if (options.direct) {
      const ColumnMatrix Hc = potential.hessian(x, options.project_hessian);
      if (!analysed) ldlt.analyzePattern(Hc), analysed = true;
      ldlt.factorize(Hc);
      if (ldlt.info() == Eigen::Success) {
        d = ldlt.solve(-g);
        solved = d.allFinite();
      }
    }
    if (!solved) {  // CG, or the factorisation failed (an unprojected, singular Hessian)
      const Real eta =
          std::min(options.cg_max_tolerance,
                   std::max({options.cg_min_tolerance, options.cg_forcing * g_norm / g0, options.cg_stop_margin * cg_stop / g_norm}));
      if constexpr (HasHessianProducts<Potential>::value) {
        const auto linear = potential.linearize(x, options.project_hessian);
        // Eigen's DiagonalPreconditioner: 1 / diagonal, 1 where the diagonal is 0.
        const Vector inverse = linear.diagonal.unaryExpr([](Real h) { return h != 0 ? 1 / h : Real(1); });
        d = Vector::Zero(g.size());
        const PcgResult cg_result = preconditioned_cg(
            [&](const Vector& y) -> Vector { return potential.hessian_product(linear, y); },
            [&](const Vector& r, Vector& z) { z = inverse.cwiseProduct(r); }, Vector(-g), d, eta,
            options.cg_max_iterations);
        result.cg_iterations += cg_result.iterations;
        if (!cg_result.converged) ++result.cg_unfinished;
      } else {
        const SparseMatrix H = potential.hessian(x, options.project_hessian);  // cg keeps a reference
        cg.compute(H);
        cg.setMaxIterations(options.cg_max_iterations);
        cg.setTolerance(eta);
        d = cg.solve(-g);
        result.cg_iterations += int(cg.iterations());
        if (cg.info() != Eigen::Success) ++result.cg_unfinished;
      }
    }
    if (!d.allFinite()) {
      result.status = NewtonStatus::non_finite;
      break;
    }
    Real slope = g.dot(d);
    if (!(slope < 0)) {  // only possible with an unprojected, indefinite Hessian
      d = -g;
      slope = -g_norm * g_norm;
      ++result.gradient_fallbacks;
    }

    Real alpha = 1;
    bool accepted = false;
    Vector trial;
    Real trial_energy = 0;
    for (int b = 0; b <= options.max_backtracks; ++b) {
      trial = x + alpha * d;
      trial_energy = potential.energy(trial);
      if (std::isfinite(trial_energy) &&
          trial_energy <= energy + options.armijo * alpha * slope + options.energy_roundoff * std::abs(energy)) {
        accepted = true;
        break;
      }
      alpha *= options.backtracking_factor;
      ++result.backtracks;
    }
    if (!accepted) {
      result.status = NewtonStatus::line_search_failed;
      break;
    }
    x.swap(trial);
    energy = trial_energy;
    g = potential.gradient(x);
    const Real previous_norm = g_norm;
    g_norm = g.norm();
    ++result.iterations;
    result.gradient_norms.push_back(g_norm);
    result.energies.push_back(energy);
    if (!std::isfinite(g_norm)) {
      result.status = NewtonStatus::non_finite;
      break;
    }
    if (g_norm <= result.tolerance) {
      result.status = NewtonStatus::converged;
      result.converged = true;
      break;
    }
    // Round-off floor: the gradient no longer changes (the energy cannot resolve the step)
    // within a factor 100 of the direct stop. Measured on the elastic gate at dt = 1e-4 s:
    // |g| stuck at 3.17e-9 for 48 iterations against a relative tolerance of 2.4e-9.
    const bool stalled = std::abs(g_norm - previous_norm) <= options.stall_change * g_norm;
    if (stalled && g_norm <= options.stall_factor * direct_tolerance) {
      result.status = NewtonStatus::converged;
      result.converged = true;
      result.roundoff_floor = true;
      break;
    }
  }
  return result;
}

}  // namespace iqmpm
