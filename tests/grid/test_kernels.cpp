// The three kernels of method.md §2: partition of unity, gradients summing to zero, and
// exact reproduction of linear fields (sum w x_i = x, sum x_i grad w^T = I).
#include "grid/grid.h"
#include "grid/kernels.h"
#include "support/test_helpers.h"

namespace iqmpm {
namespace {

template <class D>
class KernelTest : public ::testing::Test {};
TYPED_TEST_SUITE(KernelTest, testing::Dimensions);

template <int dim, int width, class StencilT, class PositionOf>
void check_reproduction(const StencilT& s, const Vec<dim>& x, PositionOf position_of) {
  Real weight_sum = 0;
  Vec<dim> gradient_sum = Vec<dim>::Zero();
  Vec<dim> first_moment = Vec<dim>::Zero();
  Mat<dim> gradient_moment = Mat<dim>::Zero();
  for_each_offset<dim, width>([&](const IVec<dim>& offset) {
    const Vec<dim> xi = position_of(s.base + offset);
    weight_sum += s.weight(offset);
    gradient_sum += s.gradient(offset);
    first_moment += s.weight(offset) * xi;
    gradient_moment += xi * s.gradient(offset).transpose();
  });
  EXPECT_NEAR(weight_sum, 1.0, 1e-13);
  EXPECT_LT(gradient_sum.norm(), 1e-10);
  EXPECT_LT((first_moment - x).norm(), 1e-13);
  EXPECT_LT((gradient_moment - Mat<dim>::Identity()).norm(), 1e-12);
}

TYPED_TEST(KernelTest, QuadraticAndLinearReproduceLinearFields) {
  constexpr int dim = TypeParam::value;
  std::mt19937 rng(7);
  Grid<dim> grid(Vec<dim>::Constant(-0.3), Vec<dim>::Constant(0.7), 0.05);
  for (int trial = 0; trial < 200; ++trial) {
    const Vec<dim> x = testing::random_vector<dim>(rng, -0.25, 0.65);
    const Vec<dim> xi = grid.to_cells(x);
    check_reproduction<dim, 3>(quadratic_stencil<dim>(xi, grid.dx), x,
                               [&](const IVec<dim>& node) { return grid.dual_cell_centre(node); });
    check_reproduction<dim, 2>(linear_stencil<dim>(xi, grid.dx), x,
                               [&](const IVec<dim>& corner) { return grid.corner_position(corner); });
  }
}

TYPED_TEST(KernelTest, StencilsAgreeOnTheDualCell) {
  // The middle quadratic node and the first linear corner are the dual cell holding x
  // (method.md §2: dual cells are the knot spans of N2 and the elements of N1).
  constexpr int dim = TypeParam::value;
  std::mt19937 rng(3);
  Grid<dim> grid(Vec<dim>::Zero(), Vec<dim>::Ones(), 0.1);
  for (int trial = 0; trial < 100; ++trial) {
    const Vec<dim> xi = grid.to_cells(testing::random_vector<dim>(rng, 0.0, 1.0));
    const IVec<dim> cell = dual_cell_of<dim>(xi);
    EXPECT_EQ(quadratic_stencil<dim>(xi, grid.dx).base + IVec<dim>::Ones(), cell);
    EXPECT_EQ(linear_stencil<dim>(xi, grid.dx).base, cell);
  }
}

TYPED_TEST(KernelTest, QuadraticGradientMatchesFiniteDifference) {
  constexpr int dim = TypeParam::value;
  std::mt19937 rng(11);
  const Real dx = 0.1, h = 1e-6;
  for (int trial = 0; trial < 50; ++trial) {
    const Vec<dim> xi = testing::random_vector<dim>(rng, 2.0, 3.0);
    const auto s = quadratic_stencil<dim>(xi, dx);
    for_each_offset<dim, 3>([&](const IVec<dim>& offset) {
      for (int a = 0; a < dim; ++a) {
        Vec<dim> plus = xi, minus = xi;
        plus[a] += h / dx;
        minus[a] -= h / dx;
        const auto sp = quadratic_stencil<dim>(plus, dx), sm = quadratic_stencil<dim>(minus, dx);
        if (sp.base != s.base || sm.base != s.base) continue;  // crossed a knot
        EXPECT_NEAR((sp.weight(offset) - sm.weight(offset)) / (2 * h), s.gradient(offset)[a], 1e-6);
      }
    });
  }
}

}  // namespace
}  // namespace iqmpm
