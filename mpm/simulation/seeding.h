// Particle seeding: particles_per_axis^dim points per cell on a regular sub-lattice
// (optionally jittered), kept where a shape contains them.
#pragma once

#include <random>

#include "grid/grid.h"
#include "particles/particles.h"
#include "scene/scene.h"

namespace iqmpm {

template <int dim>
void seed_particles(const Grid<dim>& grid, const std::vector<ShapeSpec>& shapes, int per_axis, Real jitter,
                    unsigned seed, Real density, const Vec<dim>& velocity, Particles<dim>& out) {
  const Real spacing = grid.dx / per_axis;
  const Real volume = std::pow(spacing, dim);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<Real> uniform(-0.5, 0.5);
  IVec<dim> count = grid.cells * per_axis;
  GridLayout<dim> lattice(IVec<dim>::Zero(), count);
  for (int k = 0; k < lattice.size(); ++k) {
    const IVec<dim> i = lattice.multi_index(k);
    Vec<dim> x = grid.origin + spacing * (i.template cast<Real>() + Vec<dim>::Constant(0.5));
    if (jitter > 0)
      for (int a = 0; a < dim; ++a) x[a] += jitter * spacing * uniform(rng);
    for (const auto& shape : shapes)
      if (shape.contains(x.data(), dim)) {
        out.add(x, velocity, density * volume, volume);
        break;
      }
  }
}

}  // namespace iqmpm
