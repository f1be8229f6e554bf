// Free-slip walls held on the corners (fluid.wall_constraint = corners) against the wall
// face rows y (faces), docs/method.md#walls-on-corners: the same discrete problem where the
// fluid fills the wall's faces, and the same force on the wall from the held momentum as
// from the multipliers.
#include <cmath>

#include "diagnostics/measurements.h"
#include "simulation/simulation.h"
#include "support/scenes.h"
#include "support/test_helpers.h"

namespace iqmpm {
namespace {

template <int dim>
struct Solved {
  std::vector<Real> pressure;  // p_f by dual cell (0 where none)
  std::array<std::array<Real, 2>, dim> wall_force{};
  int unknowns = 0;
};

template <int dim>
Solved<dim> first_steps(Json doc, const std::string& wall_constraint, int steps, Real dt) {
  doc["fluid"]["wall_constraint"] = wall_constraint;
  Simulation<dim> sim(read_scene(doc));
  for (int s = 0; s < steps; ++s) sim.step(dt);
  Solved<dim> out;
  const int cells = sim.grid().dual_cells().size();
  for (int k = 0; k < cells; ++k) out.pressure.push_back(sim.fluid_pressure(k));
  for (int a = 0; a < dim; ++a)
    for (int s = 0; s < 2; ++s) out.wall_force[a][s] = wall_force(sim, a, s);
  out.unknowns = sim.pressure_system().size();
  return out;
}

template <class D>
class WallConstraintTest : public ::testing::Test {};
TYPED_TEST_SUITE(WallConstraintTest, testing::Dimensions);

// The floating cube's tank at its first steps (2-D: the floating block; 3-D: the cube):
// the fluid fills every wall face, so holding each wall corner's normal velocity is the
// face rows' constraint and the pressure is the same to the solver's tolerance; the wall
// force (held momentum against multipliers) too. The corners' system has no y rows.
TYPED_TEST(WallConstraintTest, CornersGiveTheFaceRowsPressureInAFullTank) {
  constexpr int dim = TypeParam::value;
  const Json doc = dim == 2 ? testing::benchmark_document("floating_block/floating_block.json", {"solver.method=cholmod"})
                            : testing::benchmark_document("floating_block_3d/floating_block_3d.json", {"solver.tolerance=1e-12"});
  const Solved<dim> corners = first_steps<dim>(doc, "corners", 3, 2e-3);
  const Solved<dim> faces = first_steps<dim>(doc, "faces", 3, 2e-3);
  Real difference = 0, norm = 0;
  for (std::size_t k = 0; k < corners.pressure.size(); ++k) {
    difference += std::pow(corners.pressure[k] - faces.pressure[k], 2);
    norm += std::pow(faces.pressure[k], 2);
  }
  EXPECT_LT(std::sqrt(difference / norm), 1e-8);
  EXPECT_LT(corners.unknowns, faces.unknowns);
  for (int a = 0; a < dim; ++a)
    for (int s = 0; s < 2; ++s)
      EXPECT_NEAR(corners.wall_force[a][s], faces.wall_force[a][s], 1e-7 * std::abs(faces.wall_force[0][0]) + 1e-9)
          << "axis " << a << " side " << s;
}

// The position correction with solids builds its own system (fluid/position_correction.h):
// with walls on the corners it holds each wall corner's normal displacement instead of a
// y row per face, and in the full tank that is the same constraint, so the particles move
// the same to the solver's tolerance (in 3-D the y rows cost the correction's CG about 7x
// the iterations: docs/method.md#position-correction).
TYPED_TEST(WallConstraintTest, CornersGiveTheFaceRowsPositionCorrectionInAFullTank) {
  constexpr int dim = TypeParam::value;
  const Json doc = testing::benchmark_document(dim == 2 ? "floating_block/floating_block.json" : "floating_block_3d/floating_block_3d.json",
                                               {"solver.tolerance=1e-12"});
  auto positions = [&](const std::string& wall_constraint, Real relaxation, int* correction_unknowns = nullptr) {
    Json d = doc;
    d["fluid"]["wall_constraint"] = wall_constraint;
    d["experimental"]["position_correction"] = relaxation;
    Simulation<dim> sim(read_scene(d));
    for (int s = 0; s < 3; ++s) sim.step(2e-3);
    if (correction_unknowns) *correction_unknowns = sim.last_step().correction_unknowns;
    return sim.fluid().position;
  };
  // Particles are re-sorted by cell, so the runs are compared particle by particle only
  // where they agree to round-off; the correction's own size by the particles' second moment.
  auto second_moment = [](const std::vector<Vec<dim>>& x) {
    Real sum = 0;
    for (const auto& p : x) sum += p.squaredNorm();
    return sum;
  };
  int corner_rows = 0, face_rows = 0;
  const std::vector<Vec<dim>> corners = positions("corners", 1, &corner_rows), faces = positions("faces", 1, &face_rows),
                              uncorrected = positions("faces", 0);
  EXPECT_GT(corner_rows, 0);
  EXPECT_LT(corner_rows, face_rows);  // no wall rows
  ASSERT_EQ(corners.size(), faces.size());
  Real difference = 0;
  for (std::size_t p = 0; p < faces.size(); ++p) difference = std::max(difference, (corners[p] - faces[p]).norm());
  // The correction moved the particles (its effect on the second moment, 2-D 6e-3 m^2,
  // 3-D 2e-3 m^2), and corners and faces agree to round-off (4e-13 / 2e-12 m a particle;
  // 4e-12 / 4e-10 m^2), far below the correction's own displacements (1e-5 m and more).
  const Real correction_effect = std::abs(second_moment(faces) - second_moment(uncorrected));
  EXPECT_GT(correction_effect, 1e-4);
  EXPECT_LT(std::abs(second_moment(corners) - second_moment(faces)), 1e-5 * correction_effect);
  EXPECT_LT(difference, 1e-9);
}

}  // namespace
}  // namespace iqmpm
