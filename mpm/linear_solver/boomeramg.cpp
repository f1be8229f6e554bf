#include "linear_solver/boomeramg.h"

#include <mpi.h>
#include <HYPRE.h>
#include <HYPRE_IJ_mv.h>
#include <HYPRE_parcsr_ls.h>
#include <HYPRE_utilities.h>
// Internal headers, for the local data of a vector (copied in and out without hypre's
// per-entry index lookups) and for the hierarchy's size (operator complexity).
#include <_hypre_parcsr_ls.h>
#include <_hypre_parcsr_mv.h>

#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/errors.h"

namespace iqmpm {
namespace {

bool mpi_initialised_here = false;

void finalise_hypre() {
  HYPRE_Finalize();
  int finalised = 0;
  MPI_Finalized(&finalised);
  if (mpi_initialised_here && !finalised) MPI_Finalize();
}

void check(HYPRE_Int code, const char* what) {
  if (code == 0) return;
  char message[256] = {0};
  HYPRE_DescribeError(code, message);
  HYPRE_ClearAllErrors();
  throw NumericalFailure(std::string("hypre BoomerAMG: ") + what + " failed: " + message);
}

// hypre's codes for the parameters (HYPRE_parcsr_ls.h).
constexpr HYPRE_Int hmis_coarsening = 10, pmis_coarsening = 8, falgout_coarsening = 6;
constexpr HYPRE_Int extended_i_interpolation = 6, classical_interpolation = 0;
// l1-scaled Gauss-Seidel forward on the way down and backward on the way up: the V-cycle is
// then a symmetric operator, as CG needs. Hybrid symmetric Gauss-Seidel (a forward and a
// backward sweep) and Chebyshev are symmetric by themselves.
constexpr HYPRE_Int l1_gauss_seidel_forward = 13, l1_gauss_seidel_backward = 14, symmetric_gauss_seidel = 6, chebyshev = 16;
constexpr HYPRE_Int gaussian_elimination = 9;
constexpr int down_cycle = 1, up_cycle = 2, coarsest_level = 3;

}  // namespace

void ensure_hypre_initialised() {
  static const bool done = [] {
    int initialised = 0;
    MPI_Initialized(&initialised);
    if (!initialised) {
      // Without mpirun OpenMPI 4.1 starts as a one-rank singleton; that needs no environment
      // variable, also as root (only mpirun refuses root), checked in Debian's container.
      // Only the thread that solves calls MPI (hypre here is built without OpenMP).
      int provided = 0;
      if (MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS)
        throw NumericalFailure("MPI could not be initialised for hypre (solver.preconditioner = boomeramg)");
      mpi_initialised_here = true;
    }
    check(HYPRE_Init(), "HYPRE_Init");
    std::atexit(finalise_hypre);
    return true;
  }();
  (void)done;
}

BoomerAmgPreconditioner::BoomerAmgPreconditioner(const BoomerAmgParameters& parameters, int dim) : parameters_(parameters) {
  if (parameters_.strong_threshold <= 0) parameters_.strong_threshold = dim == 2 ? 0.25 : 0.5;
  ensure_hypre_initialised();
}

BoomerAmgPreconditioner::~BoomerAmgPreconditioner() { release(); }

void BoomerAmgPreconditioner::release() {
  if (solver_) HYPRE_BoomerAMGDestroy(solver_);
  if (matrix_) HYPRE_IJMatrixDestroy(matrix_);
  if (rhs_) HYPRE_IJVectorDestroy(rhs_);
  if (solution_) HYPRE_IJVectorDestroy(solution_);
  solver_ = nullptr;
  matrix_ = nullptr;
  rhs_ = solution_ = nullptr;
}

void BoomerAmgPreconditioner::compute(const Eigen::SparseMatrix<Real>& A, const std::vector<signed char>& signs) {
  release();
  size_ = int(A.rows());
  signs_ = signs;
  if (!signs_.empty() && int(signs_.size()) != size_) throw std::logic_error("BoomerAMG: one sign per unknown expected");
  const auto sign = [&](int i) -> Real { return signs_.empty() ? 1 : signs_[i]; };
  // This rank holds every row (a distributed solve would give each rank its own range).
  const HYPRE_BigInt first = 0, last = size_ - 1;
  check(HYPRE_IJMatrixCreate(MPI_COMM_WORLD, first, last, first, last, &matrix_), "IJMatrixCreate");
  check(HYPRE_IJMatrixSetObjectType(matrix_, HYPRE_PARCSR), "IJMatrixSetObjectType");
  // Column j of the symmetric A is its row j; a zero row keeps a unit diagonal.
  std::vector<HYPRE_Int> row_sizes(size_);
  std::vector<HYPRE_BigInt> rows(size_), columns;
  std::vector<HYPRE_Complex> values;
  columns.reserve(A.nonZeros() + size_);
  values.reserve(A.nonZeros() + size_);
  for (int i = 0; i < size_; ++i) {
    rows[i] = i;
    const std::size_t start = columns.size();
    bool diagonal = false;
    for (Eigen::SparseMatrix<Real>::InnerIterator it(A, i); it; ++it) {
      if (it.value() == 0 && it.row() != i) continue;
      const bool on_diagonal = it.row() == i;
      diagonal = diagonal || (on_diagonal && it.value() != 0);
      if (on_diagonal && it.value() == 0) continue;
      columns.push_back(it.row());
      values.push_back(sign(i) * it.value() * sign(int(it.row())));
    }
    if (!diagonal) {
      columns.push_back(i);
      values.push_back(1);
    }
    row_sizes[i] = HYPRE_Int(columns.size() - start);
  }
  check(HYPRE_IJMatrixSetRowSizes(matrix_, row_sizes.data()), "IJMatrixSetRowSizes");
  check(HYPRE_IJMatrixInitialize(matrix_), "IJMatrixInitialize");
  check(HYPRE_IJMatrixSetValues(matrix_, size_, row_sizes.data(), rows.data(), columns.data(), values.data()), "IJMatrixSetValues");
  check(HYPRE_IJMatrixAssemble(matrix_), "IJMatrixAssemble");
  for (auto* vector : {&rhs_, &solution_}) {
    check(HYPRE_IJVectorCreate(MPI_COMM_WORLD, first, last, vector), "IJVectorCreate");
    check(HYPRE_IJVectorSetObjectType(*vector, HYPRE_PARCSR), "IJVectorSetObjectType");
    check(HYPRE_IJVectorInitialize(*vector), "IJVectorInitialize");
    check(HYPRE_IJVectorAssemble(*vector), "IJVectorAssemble");
  }

  check(HYPRE_BoomerAMGCreate(&solver_), "BoomerAMGCreate");
  // A preconditioner: one V-cycle from zero per application.
  HYPRE_BoomerAMGSetMaxIter(solver_, 1);
  HYPRE_BoomerAMGSetTol(solver_, 0.0);
  HYPRE_BoomerAMGSetPrintLevel(solver_, 0);
  HYPRE_BoomerAMGSetStrongThreshold(solver_, parameters_.strong_threshold);
  HYPRE_BoomerAMGSetCoarsenType(solver_, parameters_.coarsening == AmgCoarsening::hmis   ? hmis_coarsening
                                         : parameters_.coarsening == AmgCoarsening::pmis ? pmis_coarsening
                                                                                          : falgout_coarsening);
  HYPRE_BoomerAMGSetInterpType(
      solver_, parameters_.interpolation == AmgInterpolation::extended_i ? extended_i_interpolation : classical_interpolation);
  HYPRE_BoomerAMGSetPMaxElmts(solver_, parameters_.interpolation_max_elements);
  HYPRE_BoomerAMGSetAggNumLevels(solver_, parameters_.aggressive_levels);
  HYPRE_BoomerAMGSetNumSweeps(solver_, 1);
  const auto relax = [&](HYPRE_Int down, HYPRE_Int up) {
    HYPRE_BoomerAMGSetCycleRelaxType(solver_, down, down_cycle);
    HYPRE_BoomerAMGSetCycleRelaxType(solver_, up, up_cycle);
  };
  switch (parameters_.smoother) {
    case AmgSmoother::l1_gauss_seidel: relax(l1_gauss_seidel_forward, l1_gauss_seidel_backward); break;
    case AmgSmoother::symmetric_gauss_seidel: relax(symmetric_gauss_seidel, symmetric_gauss_seidel); break;
    case AmgSmoother::chebyshev: relax(chebyshev, chebyshev); break;
  }
  HYPRE_BoomerAMGSetCycleRelaxType(solver_, gaussian_elimination, coarsest_level);
  // Lexicographic (the unknowns' grid order) or C/F: either is symmetric over the V-cycle,
  // since the up cycle reverses the down cycle's order.
  HYPRE_BoomerAMGSetRelaxOrder(solver_, parameters_.cf_relaxation ? 1 : 0);

  HYPRE_ParCSRMatrix parcsr = nullptr;
  HYPRE_ParVector b = nullptr, x = nullptr;
  check(HYPRE_IJMatrixGetObject(matrix_, reinterpret_cast<void**>(&parcsr)), "IJMatrixGetObject");
  check(HYPRE_IJVectorGetObject(rhs_, reinterpret_cast<void**>(&b)), "IJVectorGetObject");
  check(HYPRE_IJVectorGetObject(solution_, reinterpret_cast<void**>(&x)), "IJVectorGetObject");
  check(HYPRE_BoomerAMGSetup(solver_, parcsr, b, x), "BoomerAMGSetup");
}

void BoomerAmgPreconditioner::apply(const Eigen::VectorXd& r, Eigen::VectorXd& z) {
  HYPRE_ParCSRMatrix parcsr = nullptr;
  HYPRE_ParVector b = nullptr, x = nullptr;
  HYPRE_IJMatrixGetObject(matrix_, reinterpret_cast<void**>(&parcsr));
  HYPRE_IJVectorGetObject(rhs_, reinterpret_cast<void**>(&b));
  HYPRE_IJVectorGetObject(solution_, reinterpret_cast<void**>(&x));
  HYPRE_Complex* b_data = hypre_VectorData(hypre_ParVectorLocalVector(reinterpret_cast<hypre_ParVector*>(b)));
  HYPRE_Complex* x_data = hypre_VectorData(hypre_ParVectorLocalVector(reinterpret_cast<hypre_ParVector*>(x)));
  for (int i = 0; i < size_; ++i) {
    b_data[i] = signs_.empty() ? r[i] : signs_[i] * r[i];
    x_data[i] = 0;
  }
  // The cycle's convergence test (tolerance 0) never stops it early: the error code only
  // says that one cycle did not reach the tolerance.
  HYPRE_BoomerAMGSolve(solver_, parcsr, b, x);
  HYPRE_ClearAllErrors();
  z.resize(size_);
  for (int i = 0; i < size_; ++i) z[i] = signs_.empty() ? x_data[i] : signs_[i] * x_data[i];
}

int BoomerAmgPreconditioner::levels() const {
  return solver_ ? int(hypre_ParAMGDataNumLevels(reinterpret_cast<hypre_ParAMGData*>(solver_))) : 0;
}

Real BoomerAmgPreconditioner::operator_complexity() const {
  if (!solver_) return 0;
  auto* data = reinterpret_cast<hypre_ParAMGData*>(solver_);
  const auto nonzeros = [](hypre_ParCSRMatrix* A) {
    return Real(hypre_CSRMatrixNumNonzeros(hypre_ParCSRMatrixDiag(A))) + Real(hypre_CSRMatrixNumNonzeros(hypre_ParCSRMatrixOffd(A)));
  };
  Real total = 0;
  for (int level = 0; level < levels(); ++level) total += nonzeros(hypre_ParAMGDataAArray(data)[level]);
  const Real finest = nonzeros(hypre_ParAMGDataAArray(data)[0]);
  return finest > 0 ? total / finest : 0;
}

}  // namespace iqmpm
