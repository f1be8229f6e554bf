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

}  // namespace
}  // namespace iqmpm
