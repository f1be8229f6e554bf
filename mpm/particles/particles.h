// Material points stored as one array per attribute (structure of arrays).
#pragma once

#include <vector>

#include "core/buckets.h"
#include "core/types.h"
#include "grid/grid.h"
#include "grid/kernels.h"

namespace iqmpm {

template <int dim>
struct Particles {
  std::vector<Vec<dim>> position;
  std::vector<Vec<dim>> velocity;
  std::vector<Mat<dim>> affine;  // APIC C_p (method.md §6)
  std::vector<Real> mass;
  std::vector<Real> initial_volume;
  // Solid-only attributes (empty for fluid particles).
  std::vector<Mat<dim>> deformation_gradient;
  std::vector<Real> ghost_J;  // ghost-matrix J_g (method.md §1)
  std::vector<int> body;      // which solid
  std::vector<Vec<dim>> initial_position;  // solid: where it was seeded (rotation probes)
  std::vector<Vec<dim>> acceleration;      // solid: the last step's mean acceleration (solid_step_error; else empty)

  std::size_t size() const { return position.size(); }
  bool empty() const { return position.empty(); }

  void add(const Vec<dim>& x, const Vec<dim>& v, Real m, Real volume) {
    position.push_back(x);
    velocity.push_back(v);
    affine.push_back(Mat<dim>::Zero());
    mass.push_back(m);
    initial_volume.push_back(volume);
  }

  // Reorders every attribute by `order` (new[i] = old[order[i]]). With `previous`, the
  // attributes as they were end up there (their old buffers are reused for the new
  // order), so a caller keeps the unsorted state without copying it.
  void permute(const std::vector<int>& order, Particles* previous = nullptr) {
    apply(position, order, previous ? &previous->position : nullptr);
    apply(velocity, order, previous ? &previous->velocity : nullptr);
    apply(affine, order, previous ? &previous->affine : nullptr);
    apply(mass, order, previous ? &previous->mass : nullptr);
    apply(initial_volume, order, previous ? &previous->initial_volume : nullptr);
    apply(deformation_gradient, order, previous ? &previous->deformation_gradient : nullptr);
    apply(ghost_J, order, previous ? &previous->ghost_J : nullptr);
    apply(body, order, previous ? &previous->body : nullptr);
    apply(initial_position, order, previous ? &previous->initial_position : nullptr);
    apply(acceleration, order, previous ? &previous->acceleration : nullptr);
  }

 private:
  template <class T>
  static void apply(std::vector<T>& values, const std::vector<int>& order, std::vector<T>* previous) {
    std::vector<T> sorted;
    if (previous) sorted.swap(*previous);
    sorted.resize(values.size());
    const int n = int(values.size());
#pragma omp parallel for schedule(static)
    for (int i = 0; i < n; ++i) sorted[i] = values[order[i]];
    values.swap(sorted);
    if (previous) previous->swap(sorted);
  }
};

// Particles sorted by dual cell (first axis outermost), with the range of particles of
// every cell. Sorting gives cache locality and the slabs of the coloured parallel P2G.
template <int dim>
struct ParticleBins {
  std::vector<int> cell_start;  // size cells+1: particles of cell k are [cell_start[k], cell_start[k+1])
  GridLayout<dim> layout;

  int begin(int cell) const { return cell_start[cell]; }
  int end(int cell) const { return cell_start[cell + 1]; }
  int count(int cell) const { return cell_start[cell + 1] - cell_start[cell]; }
  // Particle range of the slab of first-axis cells [first, last).
  int slab_begin(int first) const { return cell_start[first * layout.slab_size()]; }
  int slab_end(int last) const { return cell_start[last * layout.slab_size()]; }
};

// Numbers the cells k < cells with occupied(k) in order: of_cell[k] (-1 elsewhere) and its inverse.
template <class Occupied>
void number_cells_where(int cells, Occupied&& occupied, std::vector<int>& of_cell, std::vector<int>& cell_of) {
  of_cell.assign(cells, -1);
  cell_of.clear();
  for (int k = 0; k < cells; ++k)
    if (occupied(k)) {
      of_cell[k] = int(cell_of.size());
      cell_of.push_back(k);
    }
}

// Numbers the dual cells that hold particles (pressure-like unknowns, method.md §2):
// of_cell[k] = number or -1 for an empty cell; cell_of lists the cells in order.
template <int dim>
void number_occupied_cells(const ParticleBins<dim>& bins, std::vector<int>& of_cell, std::vector<int>& cell_of) {
  number_cells_where(bins.layout.size(), [&](int k) { return bins.count(k) > 0; }, of_cell, cell_of);
}

// Counting sort of the particles by dual cell; particles must lie inside the domain.
// `unsorted`, if given, receives the particles as they were.
template <int dim>
ParticleBins<dim> sort_particles_by_cell(const Grid<dim>& grid, Particles<dim>& particles, Particles<dim>* unsorted = nullptr) {
  ParticleBins<dim> bins;
  bins.layout = grid.dual_cells();
  const int cells = bins.layout.size();
  const int n = int(particles.size());
  std::vector<int> cell_of(n);
#pragma omp parallel for schedule(static)
  for (int p = 0; p < n; ++p) cell_of[p] = bins.layout.index(dual_cell_of<dim>(grid.to_cells(particles.position[p])));
  Buckets by_cell = bucket_by_key(cell_of, cells);
  bins.cell_start = std::move(by_cell.start);
  particles.permute(by_cell.items, unsorted);
  return bins;
}

}  // namespace iqmpm
