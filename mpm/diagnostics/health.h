// Health checks after every step (docs/method.md#health-checks): cheap physics a right
// step cannot violate, so that a run that ends `ok` is right by its own checks. A step
// that fails one is taken again from its start with half the dt (run/runner.cpp) before
// the run stops with the diagnosis.
//   - Energy: kinetic + gravitational + elastic energy of the particles must not grow.
//     Slip walls do no work, the projection and implicit Euler only dissipate, so growth
//     beyond round-off and transfer error is the signature of an unstable step.
//   - Integrity: a body stays in as many pieces as it was seeded in, its particles linked
//     when closer than three seeding spacings (a stretch of 3 between neighbours). MPM's
//     numerical fracture (particles drifting apart) is a body that is under-resolved for
//     how it deforms, never a result.
//   - Constraints: the new grid velocities meet the pressure system's rows (divergence,
//     walls, interface) to the solver's accuracy; a direct solve that needed a shifted
//     factorisation, or an iterative one that stopped short, shows here.
//   - Body volume (det F against the load): a body's volume change sum V0 det F / sum V0 - 1
//     stays within what its bulk modulus allows under the loads it can feel: the mean
//     stress of a body is its surface tractions' and body forces' virial, bounded by the
//     largest fluid pressure, its weight over its height and the stress of stopping it
//     (rho c_p v, an impact; the volumetric strain of an elastic wave is v / c_p).
#pragma once

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <string>
#include <utility>
#include <vector>

#include "simulation/simulation.h"

namespace iqmpm {

// Kinetic, gravitational (relative to the origin) and elastic energy of all particles
// (J; J/m in 2-D).
template <int dim>
Real mechanical_energy(const Simulation<dim>& sim) {
  const Vec<dim> g = sim.gravity();
  auto motion = [&](const Particles<dim>& p) {
    Real sum = 0;
    const int n = int(p.size());
#pragma omp parallel for reduction(+ : sum) schedule(static)
    for (int i = 0; i < n; ++i) sum += p.mass[i] * (Real(0.5) * p.velocity[i].squaredNorm() - g.dot(p.position[i]));
    return sum;
  };
  const Particles<dim>& solid = sim.solid();
  Real elastic = 0;
  const int n = int(solid.size());
#pragma omp parallel for reduction(+ : elastic) schedule(static)
  for (int i = 0; i < n; ++i)
    elastic += solid.initial_volume[i] * sim.materials()[solid.body[i]].energy_density(solid.deformation_gradient[i]);
  return motion(sim.fluid()) + motion(solid) + elastic;
}

// The number of pieces of each body: its particles linked when closer than `link`.
// Union-find over groups rather than particles: a group is a body's particles in one bin
// of side a little below link / sqrt(dim), all closer than link to each other, so a
// group is joined as a whole; two groups of a body within reach (2 bins along each axis)
// are joined when some pair of their particles is closer than link, and the pair search
// stops at the first. The pieces are those of the particle graph, at one root comparison
// for most pairs of groups instead of a distance per pair of particles.
template <int dim>
std::vector<int> pieces_by_body(const std::vector<Vec<dim>>& position, const std::vector<int>& body_of, int bodies, Real link) {
  std::vector<int> pieces(bodies, 0);
  const int n = int(position.size());
  if (n == 0) return pieces;
  // Particles closer than link lie at most ceil(link / side) = 2 bins apart along an axis
  // (link / side = sqrt(dim) (1 + 1e-9) < 2 for dim <= 3).
  constexpr int reach = 2;
  const Real side = link / std::sqrt(Real(dim)) * (1 - 1e-9);
  IVec<dim> lo = IVec<dim>::Constant(std::numeric_limits<int>::max()), hi = IVec<dim>::Constant(std::numeric_limits<int>::min());
  std::vector<IVec<dim>> bin(n);
  for (int p = 0; p < n; ++p) {
    for (int a = 0; a < dim; ++a) bin[p][a] = int(std::floor(position[p][a] / side));
    lo = lo.cwiseMin(bin[p]);
    hi = hi.cwiseMax(bin[p]);
  }
  // Bin keys in 64 bits, first axis outermost (bodies far apart span many empty bins).
  std::array<std::int64_t, dim> stride{};
  std::int64_t bin_count = 1;
  for (int a = dim - 1; a >= 0; --a) {
    stride[a] = bin_count;
    bin_count *= hi[a] - lo[a] + 1;
  }
  auto key_of = [&](const IVec<dim>& b) {
    std::int64_t k = 0;
    for (int a = 0; a < dim; ++a) k += (b[a] - lo[a]) * stride[a];
    return k;
  };
  std::vector<std::int64_t> key(n);
  for (int p = 0; p < n; ++p) key[p] = key_of(bin[p]);
  // Particles by (bin, body); group g holds order[group_start[g] .. group_start[g + 1]).
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int p, int q) {
    return key[p] != key[q] ? key[p] < key[q] : body_of[p] != body_of[q] ? body_of[p] < body_of[q] : p < q;
  });
  std::vector<int> group_start;
  std::vector<std::int64_t> group_key;
  for (int i = 0; i < n; ++i)
    if (i == 0 || key[order[i]] != key[order[i - 1]] || body_of[order[i]] != body_of[order[i - 1]]) {
      group_start.push_back(i);
      group_key.push_back(key[order[i]]);
    }
  const int groups = int(group_start.size());
  group_start.push_back(n);
  // The first group of a bin, by a search over the groups' keys (no table over empty space).
  auto first_group_of = [&](std::int64_t k) {
    const auto it = std::lower_bound(group_key.begin(), group_key.end(), k);
    return it != group_key.end() && *it == k ? int(it - group_key.begin()) : -1;
  };
  std::vector<int> parent(groups);
  std::iota(parent.begin(), parent.end(), 0);
  auto root = [&](int g) {
    while (parent[g] != g) g = parent[g] = parent[parent[g]];
    return g;
  };
  const Real link2 = link * link;
  auto linked = [&](int g, int h) {
    for (int i = group_start[g]; i < group_start[g + 1]; ++i)
      for (int j = group_start[h]; j < group_start[h + 1]; ++j)
        if ((position[order[i]] - position[order[j]]).squaredNorm() < link2) return true;
    return false;
  };
  for (int g = 0; g < groups; ++g) {
    const int first = order[group_start[g]];
    const int body = body_of[first];
    for_each_offset<dim, 2 * reach + 1>([&](const IVec<dim>& offset) {
      const IVec<dim> b = bin[first] + offset - IVec<dim>::Constant(reach);
      for (int a = 0; a < dim; ++a)
        if (b[a] < lo[a] || b[a] > hi[a]) return;
      const std::int64_t k = key_of(b);
      if (k <= group_key[g]) return;  // each pair of bins once; a bin's groups are of different bodies
      for (int h = first_group_of(k); h >= 0 && h < groups && group_key[h] == k; ++h) {
        if (body_of[order[group_start[h]]] != body) continue;
        const int rg = root(g), rh = root(h);
        if (rg != rh && linked(g, h)) parent[rh] = rg;
      }
    });
  }
  for (int g = 0; g < groups; ++g)
    if (root(g) == g) ++pieces[body_of[order[group_start[g]]]];
  return pieces;
}

// The fewest particles per axis of any body (solids[].particles_per_axis): the link of
// body_pieces is three of that body's spacings, lenient for bodies seeded finer.
inline int coarsest_solid_seeding(const SceneSpec& scene) {
  int fewest = scene.particles_per_axis;
  if (!scene.solids.empty()) {
    fewest = scene.solids.front().particles_per_axis;
    for (const auto& solid : scene.solids) fewest = std::min(fewest, solid.particles_per_axis);
  }
  return fewest;
}

template <int dim>
std::vector<int> body_pieces(const Simulation<dim>& sim, Real link) {
  return pieces_by_body<dim>(sim.solid().position, sim.solid().body, int(sim.materials().size()), link);
}

// Safety factor and floor of the body-volume check (docs/method.md#health-checks): the
// virial bound is an order of magnitude, and a stiff body's volume drifts with the F
// update's error (up to 2.6e-4 over the floating block's 5 s); 1e-3 leaves a margin of 4.
constexpr Real kVolumeLoadFactor = 10;
constexpr Real kVolumeFloor = 1e-3;

// Per body: (volume change |sum V0 det F / sum V0 - 1|, the change its stiffness allows).
// speed_limit caps the bodies' speeds in the impact term: the fastest a load can make a
// body (a fall through the domain's height, or the fastest initial speed), so that a body
// that an unstable step sets in motion does not loosen its own bound.
template <int dim>
std::vector<std::pair<Real, Real>> body_volume_changes(const Simulation<dim>& sim, Real speed_limit) {
  const Particles<dim>& solid = sim.solid();
  const std::size_t bodies = sim.materials().size();
  if (solid.empty()) return std::vector<std::pair<Real, Real>>(bodies, {0, 0});
  std::vector<Real> volume0(bodies, 0), volume(bodies, 0), speed(bodies, 0);
  const Real inf = std::numeric_limits<Real>::infinity();
  std::vector<Vec<dim>> lo(bodies, Vec<dim>::Constant(inf)), hi(bodies, Vec<dim>::Constant(-inf));
  for (std::size_t p = 0; p < solid.size(); ++p) {
    const int b = solid.body[p];
    volume0[b] += solid.initial_volume[p];
    volume[b] += solid.initial_volume[p] * solid.deformation_gradient[p].determinant();
    speed[b] = std::max(speed[b], solid.velocity[p].norm());
    lo[b] = lo[b].cwiseMin(solid.position[p]);
    hi[b] = hi[b].cwiseMax(solid.position[p]);
  }
  Real pressure = 0;  // the largest fluid pressure anywhere bounds the load on any surface
  for (int k : sim.fluid_cells()) pressure = std::max(pressure, std::abs(sim.fluid_pressure(k)));
  const Real g = sim.gravity().norm();
  const Vec<dim> down = g > 0 ? Vec<dim>(sim.gravity() / g) : Vec<dim>::Zero();
  std::vector<std::pair<Real, Real>> changes(bodies, {0, 0});
  for (std::size_t b = 0; b < bodies; ++b) {
    if (volume0[b] == 0) continue;
    const SolidMaterial<dim>& material = sim.materials()[b];
    const Real density = sim.scene().solids[b].density;
    const Real bulk = material.lambda + 2 * material.mu / dim;
    const Real wave_speed = std::sqrt((material.lambda + 2 * material.mu) / density);
    const Real height = std::abs((hi[b] - lo[b]).dot(down));
    const Real impact = std::min(speed[b], speed_limit) / wave_speed;
    const Real allowed = kVolumeLoadFactor * ((pressure + density * g * height) / bulk + impact) + kVolumeFloor;
    changes[b] = {std::abs(volume[b] / volume0[b] - 1), allowed};
  }
  return changes;
}

// A body as the diagnoses name it: 'name', or its index when it has none.
template <int dim>
std::string body_label(const Simulation<dim>& sim, std::size_t body) {
  const std::string& name = sim.scene().solids[body].name;
  return name.empty() ? std::to_string(body) : "'" + name + "'";
}

template <int dim>
class HealthChecks {
 public:
  // energy_growth: the largest growth of the mechanical energy in one step, as a fraction
  // of the run's energy scale (the potential energy above the domain's floor and the
  // kinetic energy at the start).
  HealthChecks(const Simulation<dim>& sim, Real energy_growth)
      : energy_growth_(energy_growth),
        link_(3 * sim.grid().dx / coarsest_solid_seeding(sim.scene())),
        seeded_pieces_(body_pieces(sim, link_)),
        energy_(mechanical_energy(sim)) {
    const Vec<dim> g = sim.gravity();
    Real floor = 0;  // the lowest potential energy per unit mass the domain allows
    for (int a = 0; a < dim; ++a) floor += -g[a] * (g[a] < 0 ? sim.grid().origin[a] : sim.grid().origin[a] + sim.grid().dx * sim.grid().cells[a]);
    Real scale = 0;
    for (const Particles<dim>* p : {&sim.fluid(), &sim.solid()})
      for (std::size_t i = 0; i < p->size(); ++i)
        scale += p->mass[i] * (Real(0.5) * p->velocity[i].squaredNorm() - g.dot(p->position[i]) - floor);
    energy_scale_ = std::max(scale, std::numeric_limits<Real>::min());
    residual_tolerance_ = std::max(Real(1e-6), 100 * sim.options().pressure_solver.tolerance);
    Real height = 0, fastest = 0;  // the domain's extent along g; the fastest initial particle
    for (int a = 0; a < dim; ++a) height += std::abs(g[a]) * sim.grid().dx * sim.grid().cells[a];
    height /= std::max(g.norm(), std::numeric_limits<Real>::min());
    for (const Particles<dim>* p : {&sim.fluid(), &sim.solid()})
      for (const auto& v : p->velocity) fastest = std::max(fastest, v.norm());
    speed_limit_ = std::max(fastest, std::sqrt(2 * g.norm() * height));
  }

  // The diagnosis of the step just taken; empty when it passes. `accept` then makes its
  // state the next step's reference.
  std::string violation(const Simulation<dim>& sim) {
    constraint_residual_ = sim.pressure_system().unknowns() == 0 ? 0 :
        sim.pressure_system().relative_constraint_residual(sim.grid_velocity_before_projection(),
                                                           sim.grid_velocity_after_projection(), sim.pressure_solution());
    if (!(constraint_residual_ <= residual_tolerance_))
      return fmt::format("the new velocities miss the pressure system's constraints by {:.3g} of its right-hand side "
                         "(accepted: {:.1g}; the {} solve's own relative residual {:.3g}{})", constraint_residual_,
                         residual_tolerance_, sim.last_step().linear.method, sim.last_step().linear.relative_residual,
                         sim.last_step().linear.shifted ? ", after a zero pivot shifted its factorisation" : "");
    candidate_energy_ = mechanical_energy(sim);
    const Real growth = (candidate_energy_ - energy_) / energy_scale_;
    if (growth > energy_growth_)
      return fmt::format("the step created mechanical energy: {:.3g} J ({:.3g} of the run's energy scale {:.3g} J; "
                         "accepted: at most health.energy_growth = {:.3g})", candidate_energy_ - energy_, growth,
                         energy_scale_, energy_growth_);
    const std::vector<int> pieces = body_pieces(sim, link_);
    for (std::size_t b = 0; b < pieces.size(); ++b)
      if (pieces[b] > seeded_pieces_[b])
        return fmt::format("solid {} came apart: {} pieces (seeded as {}), more than three particle spacings apart (numerical fracture: "
                           "the body deforms more than its particles resolve; try a smaller dt_max or cfl, a larger "
                           "particles_per_axis or a stiffer material)", body_label(sim, b), pieces[b], seeded_pieces_[b]);
    const auto volumes = body_volume_changes(sim, speed_limit_);
    for (std::size_t b = 0; b < volumes.size(); ++b)
      if (!(volumes[b].first <= volumes[b].second))
        return fmt::format("solid {} changed its volume by {:.3g} %, more than its stiffness allows under the loads it feels "
                           "({:.3g} %: docs/method.md#health-checks): its det F is out of balance with its loads, a step "
                           "that is unstable or a drift built up over steps; try a smaller dt_max or cfl",
                           body_label(sim, b), 100 * volumes[b].first, 100 * volumes[b].second);
    return {};
  }
  void accept() { energy_ = candidate_energy_; }
  // The next step's reference from the state as it is (a run resumed from a checkpoint).
  void measure_reference(const Simulation<dim>& sim) { energy_ = mechanical_energy(sim); }
  Real energy() const { return energy_; }
  Real constraint_residual() const { return constraint_residual_; }  // of the last step checked
  Real energy_scale() const { return energy_scale_; }

 private:
  Real energy_growth_;
  Real link_;  // particles closer than this belong to one piece: 3 seeding spacings
  std::vector<int> seeded_pieces_;
  Real energy_ = 0, candidate_energy_ = 0, energy_scale_ = 1;
  Real constraint_residual_ = 0;
  // A solve to solver.tolerance (PCG) leaves a residual of that order; direct solves leave
  // round-off (1e-14 .. 7e-14 on the benchmarks; 5e-9 for a block at rest, measured
  // against the floor of its terms).
  Real residual_tolerance_ = 1e-6;
  Real speed_limit_ = 0;  // of the body-volume check's impact term (body_volume_changes)
};

}  // namespace iqmpm
