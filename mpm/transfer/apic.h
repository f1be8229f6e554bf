// APIC particle-to-grid and grid-to-particle transfers (method.md §3 steps 1 and 5, §6):
// fluid on the cell corners with N1, solid on the nodes with N2.
//
// Race-free parallel P2G by colouring: particles are sorted by cell, the first axis is cut
// into slabs of kSlabWidth cells, and slabs of one colour (even, then odd) never touch the
// same grid point (a particle of cell i reaches grid points i-1 .. i+2 at most), so each
// colour runs in parallel without locks or per-thread copies of the grid.
#pragma once

#include <vector>

#include "core/types.h"
#include "grid/grid.h"
#include "grid/kernels.h"
#include "particles/particles.h"

namespace iqmpm {

inline constexpr int kSlabWidth = 4;

// Runs body(p) for every particle, slab colour by slab colour, in parallel.
template <int dim, class Body>
void for_each_particle_coloured(const ParticleBins<dim>& bins, Body&& body) {
  const int first_axis_cells = bins.layout.extent()[0];
  const int slabs = (first_axis_cells + kSlabWidth - 1) / kSlabWidth;
  for (int colour = 0; colour < 2; ++colour) {
#pragma omp parallel for schedule(dynamic, 1)
    for (int slab = colour; slab < slabs; slab += 2) {
      const int first = slab * kSlabWidth;
      const int last = std::min(first_axis_cells, first + kSlabWidth);
      for (int p = bins.slab_begin(first); p < bins.slab_end(last); ++p) body(p);
    }
  }
}

// Grid momentum and mass, dense over a layout (corners for the fluid, nodes for the solid).
template <int dim>
struct GridMomentum {
  std::vector<Real> mass;
  std::vector<Vec<dim>> momentum;

  void reset(int size) {
    mass.assign(size, 0);
    momentum.assign(size, Vec<dim>::Zero());
  }
};

// APIC P2G with a kernel of `width` points per axis: m_i = sum w m_p,
// (mv)_i = sum w m_p (v_p + C_p (x_i - x_p)).
template <int dim, int width, class StencilOf, class PositionOf>
void particles_to_grid(const Grid<dim>& grid, const GridLayout<dim>& layout, StencilOf stencil_of,
                       PositionOf position_of, const Particles<dim>& particles, const ParticleBins<dim>& bins,
                       GridMomentum<dim>& out) {
  out.reset(layout.size());
  for_each_particle_coloured(bins, [&](int p) {
    const Vec<dim>& xp = particles.position[p];
    const auto stencil = stencil_of(grid.to_cells(xp), grid.dx);
    const Vec<dim> affine_velocity_base = particles.velocity[p] - particles.affine[p] * xp;
    for_each_offset<dim, width>([&](const IVec<dim>& offset) {
      const IVec<dim> point = stencil.base + offset;
      const int k = layout.index(point);
      const Real wm = stencil.weight(offset) * particles.mass[p];
      out.mass[k] += wm;
      out.momentum[k] += wm * (affine_velocity_base + particles.affine[p] * position_of(point));
    });
  });
}

// Fluid P2G on the corners (N1).
template <int dim>
void fluid_particles_to_grid(const Grid<dim>& grid, const Particles<dim>& particles,
                             const ParticleBins<dim>& bins, GridMomentum<dim>& out) {
  particles_to_grid<dim, 2>(
      grid, grid.corners(), [](const Vec<dim>& xi, Real dx) { return linear_stencil<dim>(xi, dx); },
      [&](const IVec<dim>& c) { return grid.corner_position(c); }, particles, bins, out);
}

// Fluid G2P: v_p = sum w v_c, C_p = sum v_c grad w^T (gradient form, exact for affine
// fields with multilinear weights), then x_p += dt v_p.
template <int dim>
void fluid_grid_to_particles(const Grid<dim>& grid, const std::vector<Vec<dim>>& corner_velocity,
                             Real dt, Particles<dim>& particles) {
  const GridLayout<dim> corners = grid.corners();
  const int n = int(particles.size());
#pragma omp parallel for schedule(static)
  for (int p = 0; p < n; ++p) {
    const auto stencil = linear_stencil<dim>(grid.to_cells(particles.position[p]), grid.dx);
    Vec<dim> v = Vec<dim>::Zero();
    Mat<dim> C = Mat<dim>::Zero();
    for_each_offset<dim, 2>([&](const IVec<dim>& offset) {
      const Vec<dim>& vc = corner_velocity[corners.index(stencil.base + offset)];
      v += stencil.weight(offset) * vc;
      C += vc * stencil.gradient(offset).transpose();
    });
    particles.velocity[p] = v;
    particles.affine[p] = C;
    particles.position[p] += dt * v;
  }
}

// Solid P2G on the quadratic nodes (N2).
template <int dim>
void solid_particles_to_grid(const Grid<dim>& grid, const Particles<dim>& particles,
                             const ParticleBins<dim>& bins, GridMomentum<dim>& out) {
  particles_to_grid<dim, 3>(
      grid, grid.nodes(), [](const Vec<dim>& xi, Real dx) { return quadratic_stencil<dim>(xi, dx); },
      [&](const IVec<dim>& i) { return grid.dual_cell_centre(i); }, particles, bins, out);
}

// Solid G2P: v_p = sum w v_i, C_p = 4/dx^2 sum w v_i (x_i - x_p)^T (method.md §6), and the
// velocity gradient sum v_i grad w^T returned for the F update.
template <int dim>
void solid_grid_to_particles(const Grid<dim>& grid, const std::vector<Vec<dim>>& node_velocity,
                             Particles<dim>& particles, std::vector<Mat<dim>>* velocity_gradient) {
  const GridLayout<dim> nodes = grid.nodes();
  const int n = int(particles.size());
  if (velocity_gradient) velocity_gradient->resize(n);
  const Real scale = 4 / (grid.dx * grid.dx);
#pragma omp parallel for schedule(static)
  for (int p = 0; p < n; ++p) {
    const Vec<dim>& xp = particles.position[p];
    const auto stencil = quadratic_stencil<dim>(grid.to_cells(xp), grid.dx);
    Vec<dim> v = Vec<dim>::Zero();
    Mat<dim> B = Mat<dim>::Zero();
    Mat<dim> grad_v = Mat<dim>::Zero();
    for_each_offset<dim, 3>([&](const IVec<dim>& offset) {
      const IVec<dim> node = stencil.base + offset;
      const Vec<dim>& vi = node_velocity[nodes.index(node)];
      const Real w = stencil.weight(offset);
      v += w * vi;
      B += w * vi * (grid.dual_cell_centre(node) - xp).transpose();
      grad_v += vi * stencil.gradient(offset).transpose();
    });
    particles.velocity[p] = v;
    particles.affine[p] = scale * B;
    if (velocity_gradient) (*velocity_gradient)[p] = grad_v;
  }
}

// A nodal velocity field at the solid particles: v(x_p) = sum w v_i and its gradient
// sum v_i grad w^T (the midpoint rule's mean velocity, simulation/transfer_stages.h).
template <int dim>
void interpolate_solid_velocity(const Grid<dim>& grid, const std::vector<Vec<dim>>& node_velocity,
                                const Particles<dim>& particles, std::vector<Vec<dim>>& velocity,
                                std::vector<Mat<dim>>& velocity_gradient) {
  const GridLayout<dim> nodes = grid.nodes();
  const int n = int(particles.size());
  velocity.resize(n);
  velocity_gradient.resize(n);
#pragma omp parallel for schedule(static)
  for (int p = 0; p < n; ++p) {
    const auto stencil = quadratic_stencil<dim>(grid.to_cells(particles.position[p]), grid.dx);
    Vec<dim> v = Vec<dim>::Zero();
    Mat<dim> grad_v = Mat<dim>::Zero();
    for_each_offset<dim, 3>([&](const IVec<dim>& offset) {
      const Vec<dim>& vi = node_velocity[nodes.index(stencil.base + offset)];
      v += stencil.weight(offset) * vi;
      grad_v += vi * stencil.gradient(offset).transpose();
    });
    velocity[p] = v;
    velocity_gradient[p] = grad_v;
  }
}

}  // namespace iqmpm
