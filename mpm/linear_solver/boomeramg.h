// hypre's BoomerAMG (algebraic multigrid) as PCG's preconditioner for the pressure system:
// one V-cycle per application (docs/method.md#linear-solver). The matrix goes to hypre
// through its IJ / ParCSR interface on MPI_COMM_WORLD, so the same code runs one rank today
// and a distributed solve later.
//
// The checkerboard: in 3-D the lowest modes of the Q1-P0 pressure system are checkerboards
// (benchmarks/solvers/README.md), which classical AMG's smooth-error interpolation misses.
// With S = diag(s), s_i = (-1)^(i+j[+k]) of unknown i's dual cell, S A S turns them into
// smooth modes; BoomerAMG is built on S A S and applied as z = S AMG(S r), which is the same
// SPD operator conjugated by S, so CG's theory holds unchanged.
#pragma once

#include <Eigen/SparseCore>
#include <vector>

#include "core/types.h"

// hypre's handle types (HYPRE_IJ_mv.h, HYPRE_parcsr_ls.h), declared here so that only
// boomeramg.cpp includes hypre.
struct hypre_IJMatrix_struct;
struct hypre_IJVector_struct;
struct hypre_Solver_struct;

namespace iqmpm {

// Strength of connection, coarsening and smoother of the hierarchy (docs/method.md#linear-solver
// gives the measured choice).
enum class AmgCoarsening { hmis, pmis, falgout };
enum class AmgInterpolation { extended_i, classical };
enum class AmgSmoother { l1_gauss_seidel, symmetric_gauss_seidel, chebyshev };

struct BoomerAmgParameters {
  Real strong_threshold = 0;  // 0: by dimension, 0.25 in 2-D and 0.5 in 3-D (hypre's advice for each)
  AmgCoarsening coarsening = AmgCoarsening::pmis;
  AmgInterpolation interpolation = AmgInterpolation::extended_i;
  AmgSmoother smoother = AmgSmoother::symmetric_gauss_seidel;
  int interpolation_max_elements = 4;  // interpolation truncated to this many entries per row (0: none)
  int aggressive_levels = 0;           // levels of aggressive coarsening (0: none)
  bool cf_relaxation = false;          // smooth C points then F points (down), F then C (up)
};

// hypre needs MPI and HYPRE_Init once per process. The first BoomerAMG made initialises MPI
// (unless the program already did, e.g. under mpirun) and hypre; both are finalised once at
// exit. A plain binary runs as OpenMPI's singleton (one rank, no mpirun needed, also as root).
void ensure_hypre_initialised();

class BoomerAmgPreconditioner {
 public:
  BoomerAmgPreconditioner(const BoomerAmgParameters& parameters, int dim);
  ~BoomerAmgPreconditioner();
  BoomerAmgPreconditioner(const BoomerAmgPreconditioner&) = delete;
  BoomerAmgPreconditioner& operator=(const BoomerAmgPreconditioner&) = delete;

  // Builds the hierarchy of S A S (A: symmetric, both triangles stored; signs: s_i = +-1 per
  // row, or empty for S = I). A row with a zero diagonal (an unknown that nothing constrains
  // this step, a zero row of the semi-definite A) gets a unit diagonal, as IC(0) gives it a
  // unit pivot: the preconditioner leaves it alone.
  void compute(const Eigen::SparseMatrix<Real>& A, const std::vector<signed char>& signs);
  // z = S AMG(S r): one V-cycle from zero.
  void apply(const Eigen::VectorXd& r, Eigen::VectorXd& z);
  // Sum of the nonzeros of all levels over those of the finest (cost of a cycle per fine
  // product, and the hierarchy's memory).
  Real operator_complexity() const;
  int levels() const;

 private:
  void release();

  BoomerAmgParameters parameters_;
  std::vector<signed char> signs_;
  hypre_IJMatrix_struct* matrix_ = nullptr;
  hypre_IJVector_struct* rhs_ = nullptr;
  hypre_IJVector_struct* solution_ = nullptr;
  hypre_Solver_struct* solver_ = nullptr;
  int size_ = 0;
};

}  // namespace iqmpm
