// Checks of a scene's geometry, made when it is read (docs/method.md#scene-geometry,
// #resource-limits): shapes, bodies against each other and the domain, and the grid's
// size against the solver's 32-bit indices; and where a shape holds a point.
#include "scene/geometry.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <fmt/format.h>
#include <limits>

#include "core/errors.h"
#include "core/log.h"

namespace iqmpm {
namespace {

constexpr Real kInf = std::numeric_limits<Real>::infinity();

// (b - a) x (c - a) of 2-D points.
Real cross(const Real* a, const Real* b, const Real* c) { return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]); }

// c, collinear with the segment ab, lies on it.
bool within(const Real* a, const Real* b, const Real* c) {
  return std::min(a[0], b[0]) <= c[0] && c[0] <= std::max(a[0], b[0]) && std::min(a[1], b[1]) <= c[1] && c[1] <= std::max(a[1], b[1]);
}

// The segments ab and cd share a point (crossing or touching).
bool segments_meet(const Real* a, const Real* b, const Real* c, const Real* d) {
  const Real d1 = cross(c, d, a), d2 = cross(c, d, b), d3 = cross(a, b, c), d4 = cross(a, b, d);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0))) return true;
  return (d1 == 0 && within(c, d, a)) || (d2 == 0 && within(c, d, b)) || (d3 == 0 && within(a, b, c)) ||
         (d4 == 0 && within(a, b, d));
}

// The axis-aligned box around a shape: lo[a], hi[a].
std::array<std::vector<Real>, 2> bounds(const ShapeSpec& s, int dim) {
  if (s.type == ShapeType::box) return {s.min, s.max};
  std::array<std::vector<Real>, 2> box{std::vector<Real>(dim, kInf), std::vector<Real>(dim, -kInf)};
  for (int a = 0; a < dim; ++a) {
    if (s.type == ShapeType::sphere) box[0][a] = s.centre[a] - s.radius, box[1][a] = s.centre[a] + s.radius;
    for (std::size_t k = 0; s.type == ShapeType::polygon && k < s.vertices.size() / 2; ++k)
      box[0][a] = std::min(box[0][a], s.vertices[2 * k + a]), box[1][a] = std::max(box[1][a], s.vertices[2 * k + a]);
  }
  return box;
}

}  // namespace

const char* side_name(int axis, int side) {
  static const char* names[3][2] = {{"x-", "x+"}, {"y-", "y+"}, {"z-", "z+"}};
  return names[axis][side];
}

// The even-odd rule of ShapeSpec::contains fills a self-intersecting polygon in a way its
// author rarely means (a figure eight loses nothing, a star loses its centre): refused.
void check_simple_polygon(const std::vector<Real>& v, const std::string& path) {
  const std::size_t n = v.size() / 2;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) {
      const Real *a = &v[2 * i], *b = &v[2 * ((i + 1) % n)], *c = &v[2 * j], *d = &v[2 * ((j + 1) % n)];
      const bool adjacent = j == i + 1 || (i == 0 && j == n - 1);
      // Adjacent edges share a vertex; they overlap only when one folds back along the other.
      const bool overlap = adjacent ? cross(a, b, c) == 0 && cross(a, b, d) == 0 &&
                                          (b[0] - a[0]) * (d[0] - c[0]) + (b[1] - a[1]) * (d[1] - c[1]) < 0
                                    : segments_meet(a, b, c, d);
      if (overlap)
        throw InputError(fmt::format("scene key '{}.vertices': the polygon intersects itself (edge {} from ({:g}, {:g}) and "
                                     "edge {} from ({:g}, {:g}) meet); accepted: a simple polygon, its edges meeting only "
                                     "at the vertices they share", path, i, a[0], a[1], j, c[0], c[1]));
    }
}

// Two bodies seeded into the same space would each put particles there and push apart from
// the first step: refused, found on the finer of their unjittered seeding lattices
// (simulation/seeding.h) inside the boxes around both shapes. A solid reaching
// past the domain is seeded only inside it, which changes its mass and shape: a warning,
// since a shape drawn past a wall is a usual way to say "up to the wall"
// (docs/method.md#scene-geometry).
void check_solid_geometry(const SceneSpec& scene) {
  const int dim = scene.dim;
  double cells = 1;
  for (int a = 0; a < dim; ++a) cells *= std::round((scene.domain_max[a] - scene.domain_min[a]) / scene.dx);
  for (std::size_t i = 0; i < scene.solids.size(); ++i) {
    // A body's seeding lattice spans the domain (simulation/seeding.h): the index limit of
    // check_index_range at its own particles_per_axis.
    const double lattice = cells * std::pow(scene.solids[i].particles_per_axis, dim);
    if (lattice > std::numeric_limits<int>::max())
      throw InputError(fmt::format("scene key 'solids[{}].particles_per_axis' = {}: {:.3g} seeding lattice points pass the "
                                   "solver's 32-bit indices (at most {}); accepted: fewer particles per axis or a coarser dx",
                                   i, scene.solids[i].particles_per_axis, lattice, std::numeric_limits<int>::max()));
  }
  for (std::size_t i = 0; i < scene.solids.size(); ++i)
    for (std::size_t si = 0; si < scene.solids[i].shapes.size(); ++si) {
      const ShapeSpec& shape = scene.solids[i].shapes[si];
      const auto box = bounds(shape, dim);
      for (int a = 0; a < dim; ++a) {
        const Real below = scene.domain_min[a] - box[0][a], above = box[1][a] - scene.domain_max[a];
        if (std::max(below, above) > 1e-9 * scene.dx)
          logger()->warn("scene key 'solids[{}].shapes[{}]': reaches {:g} m past the domain's {} side; the body is seeded "
                         "only inside the domain (clipped), so its mass and shape differ from the scene's", i, si,
                         std::max(below, above), side_name(a, below > above ? 0 : 1));
      }
      for (std::size_t j = 0; j < i; ++j)
        for (std::size_t sj = 0; sj < scene.solids[j].shapes.size(); ++sj) {
          const ShapeSpec& other = scene.solids[j].shapes[sj];
          const auto other_box = bounds(other, dim);
          // The finer of the two bodies' lattices: a shared point of either is in it.
          const Real spacing = scene.dx / std::max(scene.solids[i].particles_per_axis, scene.solids[j].particles_per_axis);
          // Lattice points x_k = min + spacing (k + 1/2) inside both boxes and the domain.
          std::array<long long, 3> first{}, last{}, k{};
          bool empty = false;
          for (int a = 0; a < dim; ++a) {
            const Real lo = std::max({box[0][a], other_box[0][a], scene.domain_min[a]});
            const Real hi = std::min({box[1][a], other_box[1][a], scene.domain_max[a]});
            first[a] = k[a] = (long long)std::ceil((lo - scene.domain_min[a]) / spacing - 0.5);
            last[a] = (long long)std::floor((hi - scene.domain_min[a]) / spacing - 0.5);
            empty = empty || !(lo <= hi) || first[a] > last[a];
          }
          while (!empty) {
            Real x[3];
            for (int a = 0; a < dim; ++a) x[a] = scene.domain_min[a] + spacing * (Real(k[a]) + 0.5);
            if (shape.contains(x, dim) && other.contains(x, dim))
              throw InputError(fmt::format("scene key 'solids[{}].shapes[{}]': overlaps solids[{}].shapes[{}] (both hold the "
                                           "point ({:g}, {:g}{}{})); accepted: bodies that do not share space (they may "
                                           "touch), or both shapes in one body", i, si, j, sj, x[0], x[1],
                                           dim == 3 ? ", " : "", dim == 3 ? fmt::format("{:g}", x[2]) : ""));
            int a = dim - 1;  // the next lattice point (odometer)
            while (a >= 0 && ++k[a] > last[a]) k[a] = first[a], --a;
            empty = a < 0;
          }
        }
    }
}

// The grid layouts and the particles are indexed by int (grid/grid.h): the seeding
// lattice (every dual cell's particles_per_axis^dim points, the most particles a scene can
// have) and the velocity components of the nodes must stay below 2^31. Past it the counts
// wrapped and the seeding found no particle (docs/method.md#resource-limits).
void check_index_range(const SceneSpec& scene) {
  const int dim = scene.dim;
  double cells = 1, nodes = 1;
  for (int a = 0; a < dim; ++a) {
    const double n = std::round((scene.domain_max[a] - scene.domain_min[a]) / scene.dx);
    cells *= n;
    nodes *= n + 2;
  }
  const double lattice = cells * std::pow(scene.particles_per_axis, dim), index_limit = std::numeric_limits<int>::max();
  const double worst = std::max(lattice, dim * nodes);
  if (worst > index_limit)
    throw InputError(fmt::format(
        "scene key 'dx' = {:g}: {:.3g} dual cells, {:.3g} seeding lattice points (particles_per_axis = {}) and {:.3g} "
        "node velocity components pass the solver's 32-bit indices (at most {}); accepted: dx >= {:.3g} m at this "
        "particles_per_axis (the memory limit may ask for more)",
        scene.dx, cells, lattice, scene.particles_per_axis, dim * nodes, std::numeric_limits<int>::max(),
        scene.dx * std::pow(worst / index_limit, 1.0 / dim) * 1.001));
}

bool ShapeSpec::contains(const Real* x, int dim) const {
  if (type == ShapeType::box) {
    for (int a = 0; a < dim; ++a)
      if (x[a] < min[a] || x[a] > max[a]) return false;
    return true;
  }
  if (type == ShapeType::sphere) {
    Real r2 = 0;
    for (int a = 0; a < dim; ++a) r2 += (x[a] - centre[a]) * (x[a] - centre[a]);
    return r2 <= radius * radius;
  }
  // polygon: even-odd rule
  bool inside = false;
  const std::size_t n = vertices.size() / 2;
  for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
    const Real xi = vertices[2 * i], yi = vertices[2 * i + 1], xj = vertices[2 * j], yj = vertices[2 * j + 1];
    if ((yi > x[1]) != (yj > x[1]) && x[0] < (xj - xi) * (x[1] - yi) / (yj - yi) + xi) inside = !inside;
  }
  return inside;
}

}  // namespace iqmpm
