// The health check's pieces of a body (diagnostics/health.h): the grouped union-find
// against the definition, the connected components of the graph that links two particles
// of a body closer than `link`, found by comparing every pair. Typed over 2-D and 3-D.
#include <numeric>
#include <random>
#include <vector>

#include "diagnostics/health.h"
#include "support/test_helpers.h"

namespace iqmpm {
namespace {

template <int dim>
std::vector<int> pieces_by_every_pair(const std::vector<Vec<dim>>& x, const std::vector<int>& body, int bodies, Real link) {
  const int n = int(x.size());
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  auto root = [&](int p) {
    while (parent[p] != p) p = parent[p];
    return p;
  };
  for (int p = 0; p < n; ++p)
    for (int q = p + 1; q < n; ++q)
      if (body[p] == body[q] && (x[p] - x[q]).norm() < link) parent[root(q)] = root(p);
  std::vector<int> pieces(bodies, 0);
  for (int p = 0; p < n; ++p) pieces[body[p]] += root(p) == p;
  return pieces;
}

template <class D>
class HealthTest : public ::testing::Test {};
TYPED_TEST_SUITE(HealthTest, testing::Dimensions);

// Clouds of three bodies that interpenetrate, in clusters whose gaps straddle the link
// length (some closer, some farther), or clusters metres apart: the same pieces as the
// pair-by-pair definition, seed after seed; and the edge cases: pairs just inside and just
// outside the link, along an axis and across a diagonal, and particles at negative
// coordinates.
TYPED_TEST(HealthTest, BodyPiecesAreTheComponentsOfTheLinkGraph) {
  constexpr int dim = TypeParam::value;
  const Real link = 0.03;
  for (unsigned seed = 1; seed <= 20; ++seed) {
    SCOPED_TRACE(seed);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<Real> uniform(0, 1);
    std::vector<Vec<dim>> x;
    std::vector<int> body;
    const int clusters = 6 + int(seed % 5);
    for (int c = 0; c < clusters; ++c) {
      Vec<dim> centre;
      // Odd seeds: clusters far apart (empty bins by the billion between them).
      for (int a = 0; a < dim; ++a) centre[a] = -0.05 + (seed % 2 ? 40.0 : 0.25) * uniform(rng);
      const Real spread = 0.01 + 0.04 * uniform(rng);
      const int count = 5 + int(40 * uniform(rng));
      for (int k = 0; k < count; ++k) {
        Vec<dim> p = centre;
        for (int a = 0; a < dim; ++a) p[a] += spread * (uniform(rng) - 0.5);
        x.push_back(p);
        body.push_back(int(3 * uniform(rng)));
      }
    }
    EXPECT_EQ(pieces_by_body<dim>(x, body, 3, link), pieces_by_every_pair<dim>(x, body, 3, link));
  }
  for (const Real factor : {0.999999, 1.000001}) {
    SCOPED_TRACE(factor);
    Vec<dim> axis = Vec<dim>::Zero(), diagonal = Vec<dim>::Constant(1 / std::sqrt(Real(dim)));
    axis[0] = 1;
    for (const Vec<dim>& direction : {axis, diagonal}) {
      const Vec<dim> start = Vec<dim>::Constant(-0.0123);
      const std::vector<Vec<dim>> x{start, start + factor * link * direction};
      const int expected = factor < 1 ? 1 : 2;
      EXPECT_EQ(pieces_by_body<dim>(x, {0, 0}, 1, link), std::vector<int>{expected});
      EXPECT_EQ(pieces_by_body<dim>(x, {0, 1}, 2, link), (std::vector<int>{1, 1}));  // two bodies never join
    }
  }
}

}  // namespace
}  // namespace iqmpm
