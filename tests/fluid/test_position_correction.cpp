// The optional position correction (method.md §3 step 6) has its own volume-drift tests.
// The dam break at its benchmark resolution (dx = a/32, 0.6 s): particles spread, and the
// region the water fills (the `volume` probe, volume_drift) falls to -16.8 % without the
// correction, the particle measure (Simulation::fluid_particle_volume, a count per cell) to
// -21.6 % at the end. With relaxation 1, the scenes' (the step's own operators and factor,
// no solids), the region stays within -1.56 / +0.16 % at every step and the particle
// measure ends at -8.7 % (measured 2026-12-03; at 0.5 -1.75 / +0.16 % and -8.6 %, the
// same with 1 and 2 threads). Margins: the uncorrected run
// must show the problem (< -10 % and < -15 %), the corrected one keep the region within 2 %
// at every step (issue 23's criterion) and the particle measure within 10 %.
// At a/16 this correction ends at -2.4 % (lowest -3.1 %): 16 cells across the column leave
// few interior cells for its filter (fluid/position_correction.h); the count-per-cell
// target before it kept +0.3 % there but ran away at a/64 (second test).
#include <algorithm>

#include "fluid/position_correction.h"
#include "grid/nested_dissection.h"
#include "run/runner.h"
#include "simulation/simulation.h"
#include "support/test_helpers.h"

namespace iqmpm {
namespace {

struct Drifts {
  double particles, region_end, region_farthest;  // region_farthest: largest |drift| over the steps
};

Drifts dam_break_drifts(const std::vector<std::string>& overrides) {
  const std::string path = std::string(IQMPM_BENCHMARKS_DIR) + "/dam_break/dam_break.json";
  const RunResult result = run_scene(load_scene(path, overrides), {});
  EXPECT_TRUE(result.ok) << result.summary["status"];
  const auto column = std::find(result.columns.begin(), result.columns.end(), "volume") - result.columns.begin();
  EXPECT_LT(column, Eigen::Index(result.columns.size())) << "the dam break scene has a volume probe";
  const double initial = result.metrics.front()[column];
  double farthest = 0;
  for (const auto& row : result.metrics) farthest = std::max(farthest, std::abs(row[column] / initial - 1));
  return {result.summary["particle_volume_drift"].get<double>(), result.summary["volume_drift"].get<double>(), farthest};
}

TEST(PositionCorrectionTest, KeepsDamBreakVolume) {
  const Drifts uncorrected = dam_break_drifts({"experimental.position_correction=0"});
  const Drifts corrected = dam_break_drifts({"experimental.position_correction=1"});
  EXPECT_LT(uncorrected.particles, -0.15);
  EXPECT_LT(uncorrected.region_end, -0.10);
  EXPECT_LT(std::abs(corrected.particles), 0.10);
  EXPECT_LT(corrected.region_farthest, 0.02);
}

// At a/64 the correction used to run away (the target counted particles per cell and kept
// its checkerboard part, which D cannot produce: fluid/position_correction.h). In the
// first 0.1 s of that dam break the region then fell by 4-7 % while the uncorrected run
// stays within 0.25 %; with the smoothed, filtered target it stays within -0.20 / +0.10 %
// at every step (measured 2026-12-03; at relaxation 1, the scenes' value, -0.20 / +0.11 %).
// Margin 1 %, checked at every step.
TEST(PositionCorrectionTest, StaysQuietOnAFineDamBreak) {
  const Drifts corrected = dam_break_drifts({"dx=0.00228125", "end_time=0.1", "experimental.position_correction=1"});
  EXPECT_LT(corrected.region_farthest, 0.01);
}

template <class D>
class PositionCorrectionAtABodyTest : public ::testing::Test {};
TYPED_TEST_SUITE(PositionCorrectionAtABodyTest, testing::Dimensions);

// A block held deep in a full tank, the water in the ring of cells around it made sparse or
// crowded (its particles' volume scaled by 1 -/+ 0.2): one correction (relaxation 1) with
// solids should move water into the sparse ring as it moves it out of the crowded one,
// since phi counts the block's volume and the ring is full, not partly empty. Treated as
// next to empty space (expanded only) the ring gave water off and never took it back, and
// a floating body rode on a depleted layer (method.md#position-correction). Returns the
// ring's excess volume fraction phi - 1 before and after.
// How the correction's system is solved: the default solver (ldlt in 2-D, PCG in 3-D), or
// LDL^T (in 2-D and 3-D) in AMD's order or in the grid's nested-dissection order, as the
// simulation passes it.
enum class CorrectionSolve { scene_default, ldlt_amd, ldlt_grid_order, ldlt_cells_order };

// `after` receives the corrected particles.
template <int dim>
std::pair<Real, Real> ring_excess(Real scale, CorrectionSolve solve = CorrectionSolve::scene_default,
                                  Particles<dim>* after = nullptr) {
  const Real dx = dim == 2 ? 0.05 : 0.1;
  Json doc = testing::fluid_box_scene(dim, dx, testing::xyz<dim>(1, 0.8, 1), testing::xyz<dim>(1, 1, 1));
  const std::vector<Real> lo = testing::xyz<dim>(0.3, 0.3, 0.3), hi = testing::xyz<dim>(0.7, 0.5, 0.7);
  doc["solids"] = Json::array({{{"name", "block"}, {"model", "fixed_corotated"}, {"density", 1000.0},
                                {"youngs_modulus", 1e7}, {"poisson_ratio", 0.3},
                                {"shapes", Json::array({testing::box(lo, hi)})}}});
  Simulation<dim> sim(read_scene(doc));
  const Grid<dim>& grid = sim.grid();
  auto in_ring = [&](const Vec<dim>& x) {
    bool in_grown = true, in_block = true;
    for (int a = 0; a < dim; ++a) {
      in_grown = in_grown && x[a] > lo[a] - dx && x[a] < hi[a] + dx;
      in_block = in_block && x[a] > lo[a] && x[a] < hi[a];
    }
    return in_grown && !in_block;
  };
  Particles<dim> fluid = sim.fluid();
  for (std::size_t p = 0; p < fluid.size(); ++p)
    if (in_ring(fluid.position[p])) fluid.initial_volume[p] *= scale;
  auto excess = [&](const Particles<dim>& particles) {
    std::vector<Real> volume = smoothed_particle_volume_per_cell(grid, particles, false);
    const std::vector<Real> solid_volume = smoothed_particle_volume_per_cell(grid, sim.solid(), true);
    for (std::size_t k = 0; k < volume.size(); ++k) volume[k] += solid_volume[k];
    const GridLayout<dim> cells = grid.dual_cells();
    Real sum = 0;
    int count = 0;
    for (int k = 0; k < cells.size(); ++k) {
      const Vec<dim> centre = grid.dx * (cells.multi_index(k).template cast<Real>() + Vec<dim>::Constant(0.5)) + grid.origin;
      if (in_ring(centre)) sum += volume[k], ++count;
    }
    return sum / (count * grid.cell_volume()) - 1;
  };
  const Real before = excess(fluid);
  std::array<std::array<bool, 2>, dim> slip;
  for (int a = 0; a < dim; ++a)
    for (int s = 0; s < 2; ++s) slip[a][s] = sim.slip_wall(a, s);
  LinearSolverOptions solver;
  solver.tolerance = 1e-10;
  if (solve != CorrectionSolve::scene_default) solver.method = LinearSolverMethod::ldlt;
  const CellOrdering<dim> ordering = solve == CorrectionSolve::ldlt_grid_order
                                         ? CellOrdering<dim>::whole_grid(grid.dual_cells(), grid.cells)
                                     : solve == CorrectionSolve::ldlt_cells_order ? CellOrdering<dim>::occupied_cells(grid.dual_cells())
                                                                                  : CellOrdering<dim>();
  correct_fluid_positions<dim>(grid, fluid, sim.solid(), slip, sim.options().walls_on_corners, 1000, 1,
                               Real(0.5) * dx / sim.scene().particles_per_axis, solver, ordering);
  if (after) *after = fluid;
  return {before, excess(fluid)};
}

// Measured (2026-12-03, phi = fluid + block volume, smoothed, over the ring's cells; before
// +/-0.151): the correction removes 60 / 65 % of the sparse ring's deficit and 52 % of the
// crowded ring's surplus in 2-D / 3-D; expanding only, it removed 1.4 / 1.6 % of the
// deficit (and 68 / 71 % of the surplus). Margins: at least 30 % each way, and the two
// within a factor 2 of each other.
TYPED_TEST(PositionCorrectionAtABodyTest, FillsASparseRingAsItSpreadsACrowdedOne) {
  constexpr int dim = TypeParam::value;
  const auto [sparse_before, sparse_after] = ring_excess<dim>(0.8);
  const auto [crowded_before, crowded_after] = ring_excess<dim>(1.2);
  ASSERT_LT(sparse_before, -0.1);
  ASSERT_GT(crowded_before, 0.1);
  const Real filled = 1 - sparse_after / sparse_before, spread = 1 - crowded_after / crowded_before;
  EXPECT_GT(filled, 0.3);
  EXPECT_GT(spread, 0.3);
  EXPECT_LT(std::max(filled / spread, spread / filled), 2.0);
}

// The correction's direct solve in the grid's order and in the order of a dissection of
// its own cells (its wall and solid-face rows placed by their cells): any elimination order
// solves the same system, so the particles must end where AMD's order puts them, to
// round-off (1e-9 of a cell; the displacement itself is up to a quarter cell). An order that
// is not a permutation of the system's unknowns fails here.
TYPED_TEST(PositionCorrectionAtABodyTest, CellOrdersMoveTheParticlesAsAmdOrderDoes) {
  constexpr int dim = TypeParam::value;
  Particles<dim> amd;
  ring_excess<dim>(0.8, CorrectionSolve::ldlt_amd, &amd);
  for (const CorrectionSolve order : {CorrectionSolve::ldlt_grid_order, CorrectionSolve::ldlt_cells_order}) {
    Particles<dim> ordered;
    ring_excess<dim>(0.8, order, &ordered);
    ASSERT_EQ(amd.size(), ordered.size());
    Real largest = 0;
    for (std::size_t p = 0; p < amd.size(); ++p) largest = std::max(largest, (amd.position[p] - ordered.position[p]).norm());
    EXPECT_LT(largest, 1e-9 * (dim == 2 ? 0.05 : 0.1)) << (order == CorrectionSolve::ldlt_grid_order ? "grid" : "cells");
  }
}

}  // namespace
}  // namespace iqmpm
