// Read-only measurements of a simulation's state after a step (method.md §7): volumes,
// a body's centre, velocity, rotation and interface force, wall forces, and the pressure
// at each particle for output frames. Nothing here changes the state.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "particles/volume_per_cell.h"
#include "simulation/simulation.h"

namespace iqmpm {

// Water volume: the volume of the region the water fills (what interFoam's integral of
// alpha measures). A dual cell whose 3^dim neighbours inside the domain all hold fluid
// particles is full of water (less the solid volume in it), as the projection treats it
// (method.md §4); any other cell holds its particles' volume, at most dx^dim.
template <int dim>
Real fluid_volume(const Simulation<dim>& sim) {
  const Grid<dim>& grid = sim.grid();
  const auto cells = grid.dual_cells();
  const std::vector<Real> fluid = particle_volume_per_cell(grid, sim.fluid(), false);
  const std::vector<Real> solid = sim.has_solids() ? particle_volume_per_cell(grid, sim.solid(), true) : std::vector<Real>(cells.size(), 0);
  const Real cell_volume = grid.cell_volume();
  Real total = 0;
  for (int k = 0; k < cells.size(); ++k) {
    if (fluid[k] == 0) continue;
    const bool interior = is_interior_cell<dim>(cells, cells.multi_index(k), [&](int j) { return fluid[j] > 0; });
    total += interior ? std::max(Real(0), cell_volume - solid[k]) : std::min(fluid[k], cell_volume);
  }
  return total;
}

// Particle measure: sum over dual cells of min(dx^dim, particle volume in the cell). It
// falls when particles cluster and leave gaps inside the water even if the water's region
// keeps its volume; the position correction targets it.
template <int dim>
Real fluid_particle_volume(const Simulation<dim>& sim) {
  const Real cell_volume = sim.grid().cell_volume();
  Real total = 0;
  for (Real v : particle_volume_per_cell(sim.grid(), sim.fluid(), false)) total += std::min(v, cell_volume);
  return total;
}

// Mass-weighted mean over one body's particles of a per-particle vector (position: the
// centre of mass; velocity: momentum / mass).
template <int dim>
Vec<dim> body_mass_average(const Particles<dim>& solid, int body, const std::vector<Vec<dim>>& field) {
  Vec<dim> sum = Vec<dim>::Zero();
  Real mass = 0;
  for (std::size_t p = 0; p < solid.size(); ++p)
    if (solid.body[p] == body) sum += solid.mass[p] * field[p], mass += solid.mass[p];
  return sum / mass;
}

template <int dim>
Vec<dim> body_centre_of_mass(const Simulation<dim>& sim, int body) {
  return body_mass_average(sim.solid(), body, sim.solid().position);
}

template <int dim>
Vec<dim> body_mean_velocity(const Simulation<dim>& sim, int body) {
  return body_mass_average(sim.solid(), body, sim.solid().velocity);
}

// 2-D: the least-squares rotation of a body's particles about its centre of mass since the
// start (rad, counter-clockwise; Kabsch). NaN in 3-D.
template <int dim>
Real body_angle(const Simulation<dim>& sim, int body) {
  if constexpr (dim != 2) {
    return std::nan("");
  } else {
    const Particles<dim>& solid = sim.solid();
    Vec<dim> c = Vec<dim>::Zero(), c0 = Vec<dim>::Zero();
    Real mass = 0;
    for (std::size_t p = 0; p < solid.size(); ++p)
      if (solid.body[p] == body) {
        c += solid.mass[p] * solid.position[p];
        c0 += solid.mass[p] * solid.initial_position[p];
        mass += solid.mass[p];
      }
    c /= mass;
    c0 /= mass;
    Real cross = 0, dot = 0;  // the rotation maximising sum m (R r0) . r
    for (std::size_t p = 0; p < solid.size(); ++p)
      if (solid.body[p] == body) {
        const Vec<dim> r = solid.position[p] - c, r0 = solid.initial_position[p] - c0;
        cross += solid.mass[p] * (r0[0] * r[1] - r0[1] * r[0]);
        dot += solid.mass[p] * r0.dot(r);
      }
    return std::atan2(cross, dot);
  }
}

// Force of the fluid on the particles of a body that `selected(p)` accepts, from the last
// solve (N/m in 2-D, N in 3-D); the ghost matrix adds no net force.
template <int dim, class Selected>
Vec<dim> interface_force(const Simulation<dim>& sim, Selected selected) {
  const auto& force = sim.solid_particle_interface_force();
  Vec<dim> sum = Vec<dim>::Zero();
  for (std::size_t p = 0; p < force.size(); ++p)
    if (selected(p)) sum += force[p];
  return sum;
}

template <int dim>
Vec<dim> body_interface_force(const Simulation<dim>& sim, int body) {
  return interface_force(sim, [&](std::size_t p) { return sim.solid().body[p] == body; });
}

// Force of the fluid on a domain wall along its axis (Simulation::wall_force).
template <int dim>
Real wall_force(const Simulation<dim>& sim, int axis, int side) {
  return sim.wall_force(axis, side);
}

// A dual-cell value at each particle (0 outside the domain).
template <int dim, class ValueOfCell>
std::vector<Real> value_at_particles(const Grid<dim>& grid, const Particles<dim>& particles, ValueOfCell value_of_cell) {
  std::vector<Real> out(particles.size(), 0);
  const auto cells = grid.dual_cells();
  for (std::size_t p = 0; p < particles.size(); ++p) {
    const IVec<dim> c = dual_cell_of<dim>(grid.to_cells(particles.position[p]));
    if (cells.contains(c)) out[p] = value_of_cell(cells.index(c));
  }
  return out;
}

// Pressure of the cell holding each fluid particle (p_f) and each solid particle (p_g).
template <int dim>
std::vector<Real> fluid_particle_pressure(const Simulation<dim>& sim) {
  return value_at_particles(sim.grid(), sim.fluid(), [&](int cell) { return sim.fluid_pressure(cell); });
}

template <int dim>
std::vector<Real> solid_particle_pressure(const Simulation<dim>& sim) {
  return value_at_particles(sim.grid(), sim.solid(), [&](int cell) { return sim.ghost_pressure(cell); });
}

}  // namespace iqmpm
