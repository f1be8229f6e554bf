// The `solver` object of a scene: the pressure solve's method, preconditioner (BoomerAMG's
// parameters among them) and warm start (docs/method.md#linear-solver, #warm-start).
#include "scene/solver_keys.h"

#include <limits>

#include "core/errors.h"

namespace iqmpm {

void read_solver_keys(JsonReader& solver, LinearSolverOptions& o, WarmStartSpec& w, bool docs) {
  o.method = solver.option<LinearSolverMethod>(
      "method", o.method,
      {{"auto", LinearSolverMethod::automatic}, {"pcg", LinearSolverMethod::pcg}, {"cholmod", LinearSolverMethod::cholmod}, {"ldlt", LinearSolverMethod::ldlt}},
      "auto: ldlt in 2-D up to direct_max_unknowns, pcg otherwise; pcg: conjugate gradients; cholmod: CHOLMOD LL^T; "
      "ldlt: CHOLMOD LDL^T (also quasi-definite systems)");
  o.preconditioner = solver.option<Preconditioner>(
      "preconditioner", o.preconditioner,
      {{"ic0", Preconditioner::ic0}, {"ichol", Preconditioner::ichol}, {"jacobi", Preconditioner::jacobi},
       {"boomeramg", Preconditioner::boomeramg}},
      "PCG preconditioner: ic0 = incomplete Cholesky without fill in grid order; ichol = Eigen's threshold-fill "
      "incomplete Cholesky in AMD order; jacobi; boomeramg = one V-cycle of hypre's algebraic multigrid "
      "(docs/method.md#linear-solver)");
  o.checkerboard_flip = solver.option<CheckerboardFlip>(
      "amg_checkerboard_flip", o.checkerboard_flip,
      {{"auto", CheckerboardFlip::automatic}, {"on", CheckerboardFlip::on}, {"off", CheckerboardFlip::off}},
      "boomeramg: build the multigrid on S A S, S = (-1)^(i+j[+k]) of each unknown's dual cell, so that the "
      "Q1-P0 pressure checkerboards become smooth modes; auto = on in 3-D, off in 2-D");
  o.amg.strong_threshold = solver.number("amg_strong_threshold", o.amg.strong_threshold, 0, 1,
                                         "boomeramg: strength of connection threshold; 0 = 0.25 in 2-D, 0.5 in 3-D");
  o.amg.coarsening = solver.option<AmgCoarsening>(
      "amg_coarsening", o.amg.coarsening,
      {{"hmis", AmgCoarsening::hmis}, {"pmis", AmgCoarsening::pmis}, {"falgout", AmgCoarsening::falgout}},
      "boomeramg: coarsening (hypre's HMIS, PMIS or Falgout)");
  o.amg.interpolation = solver.option<AmgInterpolation>(
      "amg_interpolation", o.amg.interpolation,
      {{"ext+i", AmgInterpolation::extended_i}, {"classical", AmgInterpolation::classical}},
      "boomeramg: interpolation (hypre's extended+i or classical)");
  o.amg.smoother = solver.option<AmgSmoother>(
      "amg_smoother", o.amg.smoother,
      {{"l1_gauss_seidel", AmgSmoother::l1_gauss_seidel}, {"symmetric_gauss_seidel", AmgSmoother::symmetric_gauss_seidel},
       {"chebyshev", AmgSmoother::chebyshev}},
      "boomeramg: smoother, symmetric over the V-cycle as CG needs: l1_gauss_seidel = l1-scaled Gauss-Seidel, "
      "forward down and backward up; symmetric_gauss_seidel = a forward and a backward sweep each time; chebyshev");
  o.amg.cf_relaxation = solver.boolean("amg_cf_relaxation", o.amg.cf_relaxation,
                                       "boomeramg: smooth coarse points before fine ones on the way down (and after on the way up) "
                                       "instead of in the unknowns' order");
  o.amg.interpolation_max_elements = solver.integer("amg_interpolation_max_elements", o.amg.interpolation_max_elements, 0, 100,
                                                    "boomeramg: interpolation truncated to this many entries per row; 0 = no truncation");
  o.amg.aggressive_levels = solver.integer("amg_aggressive_levels", o.amg.aggressive_levels, 0, 20,
                                           "boomeramg: levels of aggressive coarsening from the finest (0 = none)");
  o.tolerance = solver.number("tolerance", o.tolerance, 0, 1, "PCG relative residual tolerance", true);
  o.max_iterations = solver.integer("max_iterations", o.max_iterations, 1, 1000000, "PCG iteration cap; reaching it stops the run");
  o.direct_max_unknowns = solver.integer("direct_max_unknowns", o.direct_max_unknowns, 0, std::numeric_limits<int>::max(), "auto: largest 2-D system solved directly");
  o.ordering = solver.option<DirectOrdering>(
      "ordering", o.ordering, {{"cells", DirectOrdering::cells}, {"grid", DirectOrdering::grid}, {"amd", DirectOrdering::amd}},
      "ldlt's fill-reducing order: cells = nested dissection of the cells each step's system has (the water's, "
      "not the grid's); grid = nested dissection of the whole grid, fixed for the run; amd = AMD on each step's "
      "pattern (docs/method.md#linear-solver)");
  w.kind = solver.option<WarmStartKind>(
      "warm_start", w.kind,
      {{"none", WarmStartKind::none}, {"previous", WarmStartKind::previous}, {"extrapolate", WarmStartKind::extrapolate},
       {"projection", WarmStartKind::projection}, {"learned", WarmStartKind::learned}},
      "PCG's first guess: none = zero; previous = the last step's solution by grid cell; extrapolate = linear in time "
      "through the last two; projection = the A-norm-best combination of the last warm_start_history solutions "
      "(Fischer); learned = MPMNet's prediction (solver.model) combined with them the same way (docs/method.md#warm-start)");
  w.history = solver.integer("warm_start_history", w.history, 0, 32,
                             "projection, learned: solutions combined (k); learned with 0 takes the network's prediction as it is");
  w.model = solver.text("model", w.model.empty() ? std::optional<std::string>("") : w.model,
                        "learned: the MPMNet TorchScript model file (mpmnet/README.md); a relative path is taken from the "
                        "working directory");
  if (!docs && w.kind == WarmStartKind::projection && w.history < 1)
    throw InputError("scene key 'solver.warm_start_history' = 0: projection needs at least 1 solution; accepted: 1 to 32");
  if (!docs && w.kind == WarmStartKind::learned && w.model.empty())
    throw InputError("scene key 'solver.model': required with solver.warm_start = \"learned\" (an MPMNet TorchScript file, mpmnet/README.md)");
}

}  // namespace iqmpm
