// The smoothed particle volume per cell that drives the position correction
// (particles/volume_per_cell.h, fluid/position_correction.h): a regular lattice up to the
// walls gives every cell its own volume, the total is the particles' volume wherever they
// are, and it moves continuously with a particle crossing a face, where the count per cell
// jumps by the particle's whole volume.
#include <random>

#include "particles/volume_per_cell.h"
#include "support/test_helpers.h"

namespace iqmpm {
namespace {

template <class D>
class VolumePerCellTest : public ::testing::Test {
 protected:
  static constexpr int dim = D::value;
  VolumePerCellTest() : grid(Vec<dim>::Zero(), Vec<dim>::Ones(), 1.0 / 8) {}

  // per_axis^dim particles per cell at the centres of the cell's sub-cells, in every cell.
  void fill_lattice(int per_axis) {
    const Real spacing = grid.dx / per_axis;
    const Real volume = std::pow(spacing, dim);
    const GridLayout<dim> points(IVec<dim>::Zero(), grid.cells * per_axis);
    for (int k = 0; k < points.size(); ++k)
      particles.add((points.multi_index(k).template cast<Real>() + Vec<dim>::Constant(0.5)) * spacing, Vec<dim>::Zero(), 1, volume);
  }

  Grid<dim> grid;
  Particles<dim> particles;
};
TYPED_TEST_SUITE(VolumePerCellTest, testing::Dimensions);

TYPED_TEST(VolumePerCellTest, ALatticeUpToTheWallsFillsEveryCellExactly) {
  for (int per_axis : {2, 3}) {
    this->particles = {};
    this->fill_lattice(per_axis);
    const std::vector<Real> volume = smoothed_particle_volume_per_cell(this->grid, this->particles, false);
    for (Real v : volume) EXPECT_NEAR(v / this->grid.cell_volume(), 1.0, 1e-12) << per_axis << " per axis";
  }
}

TYPED_TEST(VolumePerCellTest, TheTotalIsTheParticlesVolumeAnywhereInTheDomain) {
  constexpr int dim = TestFixture::dim;
  std::mt19937 rng(7);
  Real total = 0;
  for (int p = 0; p < 500; ++p) {
    const Real v = std::uniform_real_distribution<Real>(1e-5, 2e-5)(rng);
    this->particles.add(testing::random_vector<dim>(rng, 0, 1), Vec<dim>::Zero(), 1, v);
    total += v;
  }
  const std::vector<Real> volume = smoothed_particle_volume_per_cell(this->grid, this->particles, false);
  Real sum = 0;
  for (Real v : volume) sum += v;
  EXPECT_NEAR(sum, total, 1e-12 * total);
}

TYPED_TEST(VolumePerCellTest, AParticleCrossingAFaceMovesVolumeContinuously) {
  constexpr int dim = TestFixture::dim;
  const Real face = 4 * this->grid.dx, eps = 1e-9 * this->grid.dx;
  Vec<dim> x = Vec<dim>::Constant(Real(0.3));
  auto volumes_at = [&](Real x0, bool smoothed) {
    Particles<dim> one;
    x[0] = x0;
    one.add(x, Vec<dim>::Zero(), 1, 1);
    return smoothed ? smoothed_particle_volume_per_cell(this->grid, one, false) : particle_volume_per_cell(this->grid, one, false);
  };
  auto largest_change = [&](bool smoothed) {
    const std::vector<Real> before = volumes_at(face - eps, smoothed), after = volumes_at(face + eps, smoothed);
    Real change = 0;
    for (std::size_t k = 0; k < before.size(); ++k) change = std::max(change, std::abs(after[k] - before[k]));
    return change;
  };
  EXPECT_LT(largest_change(true), 1e-8);
  EXPECT_EQ(largest_change(false), 1.0);  // the count per cell: the whole particle jumps
}

}  // namespace
}  // namespace iqmpm
