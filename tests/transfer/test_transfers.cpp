// APIC transfers (method.md §6): P2G conserves mass and linear momentum exactly and
// angular momentum including the affine part; P2G then G2P reproduces an affine field.
// Both kernels: N1 on the corners (fluid) and N2 on the nodes (solid).
#include "particles/particles.h"
#include "support/test_helpers.h"
#include "transfer/apic.h"

namespace iqmpm {
namespace {

template <class D>
class TransferTest : public ::testing::Test {
 protected:
  static constexpr int dim = D::value;

  TransferTest() : grid(Vec<dim>::Zero(), Vec<dim>::Ones(), 1.0 / 16) {}

  // Random particles in the interior, random velocities and affine matrices.
  void seed(int count, unsigned s) {
    std::mt19937 rng(s);
    std::uniform_real_distribution<Real> mass(0.5, 2.0);
    for (int p = 0; p < count; ++p) {
      particles.add(testing::random_vector<dim>(rng, 0.2, 0.8), testing::random_vector<dim>(rng, -1, 1), mass(rng), 1e-4);
      particles.affine.back() = testing::random_matrix<dim>(rng, -3, 3);
    }
    bins = sort_particles_by_cell(grid, particles);
  }

  // Angular momentum as the skew matrix sum (x (mv)^T - (mv) x^T).
  static Mat<dim> skew(const Vec<dim>& x, const Vec<dim>& momentum) {
    return x * momentum.transpose() - momentum * x.transpose();
  }

  // Particle angular momentum with the APIC term m_p (D_p C_p^T - C_p D_p), D_p the
  // kernel's second moment at x_p (Jiang et al. 2015).
  template <int width, class StencilOf, class PositionOf>
  Mat<dim> particle_angular_momentum(StencilOf stencil_of, PositionOf position_of) const {
    Mat<dim> L = Mat<dim>::Zero();
    for (std::size_t p = 0; p < particles.size(); ++p) {
      const auto s = stencil_of(grid.to_cells(particles.position[p]), grid.dx);
      Mat<dim> second_moment = Mat<dim>::Zero();
      for_each_offset<dim, width>([&](const IVec<dim>& offset) {
        const Vec<dim> r = position_of(s.base + offset) - particles.position[p];
        second_moment += s.weight(offset) * r * r.transpose();
      });
      const Mat<dim> affine_part = particles.mass[p] * second_moment * particles.affine[p].transpose();
      L += skew(particles.position[p], particles.mass[p] * particles.velocity[p]) + affine_part - affine_part.transpose();
    }
    return L;
  }

  template <class PositionOf>
  void check_conservation(const GridMomentum<dim>& g, const GridLayout<dim>& layout, PositionOf position_of,
                          const Mat<dim>& particle_L) {
    Real particle_mass = 0, grid_mass = 0;
    Vec<dim> particle_momentum = Vec<dim>::Zero(), grid_momentum = Vec<dim>::Zero();
    Mat<dim> grid_L = Mat<dim>::Zero();
    for (std::size_t p = 0; p < particles.size(); ++p) {
      particle_mass += particles.mass[p];
      particle_momentum += particles.mass[p] * particles.velocity[p];
    }
    for (int k = 0; k < layout.size(); ++k) {
      grid_mass += g.mass[k];
      grid_momentum += g.momentum[k];
      grid_L += skew(position_of(layout.multi_index(k)), g.momentum[k]);
    }
    EXPECT_NEAR(grid_mass, particle_mass, 1e-12 * particle_mass);
    EXPECT_LT((grid_momentum - particle_momentum).norm(), 1e-12 * particle_mass);
    EXPECT_LT((grid_L - particle_L).norm(), 1e-12 * particle_mass);
    EXPECT_GT(particle_L.norm(), 1e-3);  // the check is not vacuous
  }

  // Sets v_p = A x_p + b and C_p = A, transfers to the grid and back.
  template <class P2G, class G2P>
  void check_affine_round_trip(P2G p2g, G2P g2p) {
    std::mt19937 rng(5);
    const Mat<dim> A = testing::random_matrix<dim>(rng, -2, 2);
    const Vec<dim> b = testing::random_vector<dim>(rng, -1, 1);
    for (std::size_t p = 0; p < particles.size(); ++p) {
      particles.velocity[p] = A * particles.position[p] + b;
      particles.affine[p] = A;
    }
    GridMomentum<dim> g;
    p2g(g);
    std::vector<Vec<dim>> velocity(g.mass.size(), Vec<dim>::Zero());
    for (std::size_t k = 0; k < g.mass.size(); ++k)
      if (g.mass[k] > 0) velocity[k] = g.momentum[k] / g.mass[k];
    const Particles<dim> before = particles;
    for (std::size_t p = 0; p < particles.size(); ++p) particles.velocity[p].setZero(), particles.affine[p].setZero();
    g2p(velocity);
    for (std::size_t p = 0; p < particles.size(); ++p) {
      EXPECT_LT((particles.velocity[p] - (A * before.position[p] + b)).norm(), 1e-11);
      EXPECT_LT((particles.affine[p] - A).norm(), 1e-10);
    }
  }

  Grid<dim> grid;
  Particles<dim> particles;
  ParticleBins<dim> bins;
};
TYPED_TEST_SUITE(TransferTest, testing::Dimensions);

TYPED_TEST(TransferTest, FluidP2GConservesMassMomentumAndAngularMomentum) {
  constexpr int dim = TypeParam::value;
  this->seed(500, 1);
  GridMomentum<dim> g;
  fluid_particles_to_grid(this->grid, this->particles, this->bins, g);
  auto corner = [&](const IVec<dim>& c) { return this->grid.corner_position(c); };
  const Mat<dim> L = this->template particle_angular_momentum<2>(
      [](const Vec<dim>& xi, Real dx) { return linear_stencil<dim>(xi, dx); }, corner);
  this->check_conservation(g, this->grid.corners(), corner, L);
}

TYPED_TEST(TransferTest, SolidP2GConservesMassMomentumAndAngularMomentum) {
  constexpr int dim = TypeParam::value;
  this->seed(500, 2);
  GridMomentum<dim> g;
  solid_particles_to_grid(this->grid, this->particles, this->bins, g);
  auto node = [&](const IVec<dim>& i) { return this->grid.dual_cell_centre(i); };
  const Mat<dim> L = this->template particle_angular_momentum<3>(
      [](const Vec<dim>& xi, Real dx) { return quadratic_stencil<dim>(xi, dx); }, node);
  this->check_conservation(g, this->grid.nodes(), node, L);
}

TYPED_TEST(TransferTest, FluidRoundTripReproducesAffineField) {
  constexpr int dim = TypeParam::value;
  this->seed(300, 3);
  this->check_affine_round_trip(
      [&](GridMomentum<dim>& g) { fluid_particles_to_grid(this->grid, this->particles, this->bins, g); },
      [&](const std::vector<Vec<dim>>& v) { fluid_grid_to_particles(this->grid, v, 0.0, this->particles); });
}

TYPED_TEST(TransferTest, SolidRoundTripReproducesAffineField) {
  constexpr int dim = TypeParam::value;
  this->seed(300, 4);
  this->check_affine_round_trip(
      [&](GridMomentum<dim>& g) { solid_particles_to_grid(this->grid, this->particles, this->bins, g); },
      [&](const std::vector<Vec<dim>>& v) { solid_grid_to_particles<dim>(this->grid, v, this->particles, nullptr); });
}

TYPED_TEST(TransferTest, ColouredParallelP2GMatchesSerialOrder) {
  // The slab colouring must give the same grid as a plain serial loop (no lost updates).
  constexpr int dim = TypeParam::value;
  this->seed(2000, 6);
  GridMomentum<dim> parallel;
  fluid_particles_to_grid(this->grid, this->particles, this->bins, parallel);
  const GridLayout<dim> corners = this->grid.corners();
  std::vector<Real> serial(corners.size(), 0);
  for (std::size_t p = 0; p < this->particles.size(); ++p) {
    const auto s = linear_stencil<dim>(this->grid.to_cells(this->particles.position[p]), this->grid.dx);
    for_each_offset<dim, 2>([&](const IVec<dim>& o) { serial[corners.index(s.base + o)] += s.weight(o) * this->particles.mass[p]; });
  }
  for (int k = 0; k < corners.size(); ++k) EXPECT_NEAR(parallel.mass[k], serial[k], 1e-12);
}

}  // namespace
}  // namespace iqmpm
