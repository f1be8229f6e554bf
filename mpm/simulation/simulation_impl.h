// Implementation of Simulation<dim>; instantiated for 2 and 3 in simulation_2d.cpp and
// simulation_3d.cpp.
#pragma once

#include <cmath>
#include <fmt/format.h>
#include <limits>

#include "core/errors.h"
#include "simulation/seeding.h"
#include "solid/incremental_potential.h"
#include "simulation/simulation.h"

namespace iqmpm {

template <int dim>
Simulation<dim>::Simulation(const SceneSpec& scene) : scene_(scene) {
  Vec<dim> lower, upper;
  for (int a = 0; a < dim; ++a) {
    lower[a] = scene.domain_min[a];
    upper[a] = scene.domain_max[a];
    gravity_[a] = scene.gravity[a];
  }
  grid_ = Grid<dim>(lower, upper, scene.dx);
  gravity_.cwiseAbs().maxCoeff(&up_axis_);
  for (int a = 0; a < dim; ++a)
    for (int s = 0; s < 2; ++s) slip_[a][s] = scene.walls[a][s] == "slip";
  fluid_density_ = scene.fluid.density;
  newton_options_.relative_tolerance = scene.newton.relative_tolerance;
  newton_options_.absolute_tolerance = scene.newton.absolute_tolerance;
  newton_options_.max_iterations = scene.newton.max_iterations;
  newton_options_.cg_max_iterations = scene.newton.cg_max_iterations;
  newton_options_.project_hessian = scene.newton.project_hessian;
  newton_options_.direct = scene.newton.linear_solver == "direct" || (scene.newton.linear_solver == "auto" && dim == 2);

  if (!scene.fluid.shapes.empty()) {
    Vec<dim> v0;
    for (int a = 0; a < dim; ++a) v0[a] = scene.fluid.initial_velocity[a];
    Particles<dim> seeded;
    seed_particles<dim>(grid_, scene.fluid.shapes, scene.particles_per_axis, scene.jitter, scene.seed,
                        fluid_density_, v0, seeded);
    // A solid displaces the fluid it is placed in.
    for (std::size_t p = 0; p < seeded.size(); ++p) {
      bool inside_solid = false;
      for (const auto& solid : scene.solids)
        for (const auto& shape : solid.shapes) inside_solid = inside_solid || shape.contains(seeded.position[p].data(), dim);
      if (!inside_solid) fluid_.add(seeded.position[p], seeded.velocity[p], seeded.mass[p], seeded.initial_volume[p]);
    }
    if (fluid_.empty())
      throw InputError("scene key 'fluid.shapes': no particle was seeded (the shapes lie outside the domain or are thinner than a particle spacing)");
  }
  for (const auto& x : fluid_.position)
    if (!grid_.dual_cells().contains(dual_cell_of<dim>(grid_.to_cells(x))))
      throw InputError("scene key 'fluid.shapes': a shape reaches outside the domain");
  seed_solids();
}

// solids[].initial_pressure = hydrostatic: the still-water level, the top of the fluid
// particles (the highest one plus half a particle spacing), as a height against gravity.
template <int dim>
Real Simulation<dim>::still_water_level(const std::string& key) const {
  if (fluid_.empty() || !(gravity_.norm() > 0))
    throw InputError(fmt::format("scene key '{}.initial_pressure' = \"hydrostatic\": needs fluid and gravity; accepted "
                                 "without them: \"zero\"", key));
  Real top = -std::numeric_limits<Real>::infinity();
  for (const auto& x : fluid_.position) top = std::max(top, height(x));
  return top + Real(0.5) * grid_.dx / scene_.particles_per_axis;
}

// Solid particles: F = I, one body index per solid; clamped nodes from the clamp regions;
// markers of the displacement probes. The ghost matrix starts unstressed (J_g = 1) or, with
// solids[].initial_pressure = hydrostatic, at the still water's pressure rho_f |g| (level -
// height), so that a body at rest in still water starts in balance with it. Unstressed, the
// water squeezes the body through its soft ghost matrix in the first steps: a neutrally
// buoyant block's first-step interface force was 71 N/m against its 196 N/m weight, 175 N/m
// hydrostatic (README, coupling).
template <int dim>
void Simulation<dim>::seed_solids() {
  const GridLayout<dim> nodes = grid_.nodes();
  for (std::size_t b = 0; b < scene_.solids.size(); ++b) {
    const SolidSpec& spec = scene_.solids[b];
    const std::string key = fmt::format("solids[{}]", b);
    SolidMaterial<dim> material;
    material.model = solid_model_from_name(spec.model);
    material.mu = spec.mu;
    material.lambda = spec.lambda;
    materials_.push_back(material);
    ghost_stiffness_.push_back(spec.ghost_stiffness);
    Vec<dim> v0;
    for (int a = 0; a < dim; ++a) v0[a] = spec.initial_velocity[a];
    Particles<dim> seeded;
    seed_particles<dim>(grid_, spec.shapes, scene_.particles_per_axis, scene_.jitter, scene_.seed + unsigned(b) + 1,
                        spec.density, v0, seeded);
    if (seeded.empty())
      throw InputError(fmt::format("scene key '{}.shapes': no particle was seeded (outside the domain or thinner than a particle spacing)", key));
    const bool hydrostatic = spec.initial_pressure == "hydrostatic";
    const Real level = hydrostatic ? still_water_level(key) : 0;
    for (std::size_t p = 0; p < seeded.size(); ++p) {
      if (!grid_.dual_cells().contains(dual_cell_of<dim>(grid_.to_cells(seeded.position[p]))))
        throw InputError(fmt::format("scene key '{}.shapes': a shape reaches outside the domain", key));
      solid_.add(seeded.position[p], seeded.velocity[p], seeded.mass[p], seeded.initial_volume[p]);
      solid_.deformation_gradient.push_back(Mat<dim>::Identity());
      const Real pressure = hydrostatic ? fluid_density_ * gravity_.norm() * std::max(Real(0), level - height(seeded.position[p])) : 0;
      if (!(pressure < spec.ghost_stiffness))
        throw InputError(fmt::format("scene key '{}.initial_pressure' = \"hydrostatic\": the water pressure {:.4g} Pa "
                                     "reaches the ghost stiffness {:.4g} Pa (J_g would not be positive); raise '{}.ghost_stiffness'",
                                     key, pressure, spec.ghost_stiffness, key));
      solid_.ghost_J.push_back(1 - pressure / spec.ghost_stiffness);
      solid_.body.push_back(int(b));
      solid_.initial_position.push_back(seeded.position[p]);
    }
    if (!spec.clamps.empty()) {
      if (clamped_node_.empty()) clamped_node_.assign(nodes.size(), 0);
      int count = 0;
      // A node is fixed when its centre lies in a clamp region or within dx/2 of it along an
      // axis: the quadratic B-spline velocity then vanishes on the whole region when its edges
      // lie on cell faces (a node reaches 1.5 dx), and nowhere outside it, so a clamped
      // beam's free length is the scene's, not one cell longer or shorter.
      const Real reach = Real(0.5) * grid_.dx * (1 + 1e-9);
      for (int k = 0; k < nodes.size(); ++k) {
        const Vec<dim> centre = grid_.dual_cell_centre(nodes.multi_index(k));
        bool inside = false;
        for (const auto& clamp : spec.clamps) {
          inside = inside || clamp.contains(centre.data(), dim);
          for (int a = 0; a < dim && !inside; ++a)
            for (Real shift : {-reach, reach}) {
              Vec<dim> x = centre;
              x[a] += shift;
              inside = inside || clamp.contains(x.data(), dim);
            }
        }
        if (inside && !clamped_node_[k]) {
          clamped_node_[k] = 1;
          ++count;
        }
      }
      if (count == 0)
        throw InputError(fmt::format("scene key '{}.clamps': no velocity node (dual-cell centre) lies inside the clamp regions", key));
    }
  }
  for (std::size_t i = 0; i < scene_.probes.size(); ++i) {
    const ProbeSpec& probe = scene_.probes[i];
    if (probe.type != "solid_force" || probe.region.empty()) continue;
    ForceRegion region;
    region.probe_name = probe.name;
    region.body = body_index(probe.solid);
    region.region = probe.region;
    int count = 0;
    for (std::size_t p = 0; p < solid_.size(); ++p) count += region.contains(solid_, p);
    if (count == 0)
      throw InputError(fmt::format("scene key 'probes[{}].region': holds no particle of solid \"{}\"", i, probe.solid));
    force_regions_.push_back(std::move(region));
  }
  for (std::size_t i = 0; i < scene_.probes.size(); ++i) {
    const ProbeSpec& probe = scene_.probes[i];
    if (probe.type != "displacement") continue;
    Vec<dim> x;
    for (int a = 0; a < dim; ++a) x[a] = probe.point[a];
    Real nearest = std::numeric_limits<Real>::infinity();
    for (const auto& xp : solid_.position) nearest = std::min(nearest, (xp - x).norm());
    if (!(nearest <= grid_.dx))
      throw InputError(fmt::format("scene key 'probes[{}].point': a displacement probe must follow a point of a solid; "
                                   "no solid particle lies within dx of it", i));
    // The point is carried by its nearest particles (all within round-off of the nearest
    // distance, e.g. the two either side of a beam's centre line): recognised later by their
    // initial positions, which travel with them when the particles are sorted.
    Marker marker;
    marker.name = probe.name;
    marker.start = x;
    for (std::size_t p = 0; p < solid_.size(); ++p)
      if ((solid_.position[p] - x).norm() <= nearest * (1 + 1e-9) + 1e-12 * grid_.dx)
        marker.carriers.push_back(solid_.initial_position[p]);
    markers_.push_back(std::move(marker));
  }
}

template <int dim>
Real Simulation<dim>::stable_dt() const {
  Real max_speed = 0;
  for (const auto& v : fluid_.velocity) max_speed = std::max(max_speed, v.norm());
  for (const auto& v : solid_.velocity) max_speed = std::max(max_speed, v.norm());
  // A particle at rest gains sqrt(|g| dx) falling one cell: the floor keeps the first steps safe.
  const Real speed = std::max(max_speed, std::sqrt(gravity_.norm() * grid_.dx));
  Real dt = speed > 0 ? scene_.cfl * grid_.dx / speed : scene_.dt_max;
  return std::min(dt, scene_.dt_max);
}

template <int dim>
void Simulation<dim>::step(Real dt) {
  if (dt < scene_.dt_min)
    throw NumericalFailure(fmt::format("time step {:.3g} s below dt_min {:.3g} s", dt, scene_.dt_min));
  last_.wall_clamps = 0;
  sort_particles();
  if (has_fluid() && has_solids()) find_interface_quadrature();
  particles_to_grid(dt);
  if (has_solids()) solve_solid_momentum(dt);
  if (has_fluid()) build_fluid_operators();
  if (has_solids()) build_solid_operators();
  if (!iq_points_.empty()) build_interface_operators();
  // coupling.interface = unilateral: the fluid may leave a solid, by active sets started
  // from the previous step's released cells.
  released_rows_.clear();
  last_.contact_rounds = 1;
  last_.contact_settled = true;
  last_.modified_solves = 0;
  assemble_pressure_system(dt);
  solve_pressure_system();
  while (scene_.coupling.interface == "unilateral" && update_released_rows()) {
    if (last_.contact_rounds == scene_.coupling.max_contact_rounds) {
      last_.contact_settled = false;  // keep the last solve's (consistent) solution
      break;
    }
    ++last_.contact_rounds;
    system_.release(released_rows_);  // same matrix pattern, released rows decoupled
    // The next solve's matrix differs from the last one in these rows only (an LDL^T
    // solver modifies its factor instead of factorising).
    pressure_solver_->expect_row_changes(std::move(newly_released_rows_), std::move(newly_restored_rows_));
    solve_pressure_system();
  }
  update_grid_velocities();
  grid_to_particles(dt);
  if (has_fluid() && scene_.fluid.position_correction > 0) correct_particle_positions();
}

template <int dim>
void Simulation<dim>::sort_particles() {
  auto scope = timer_.scope("sort");
  if (has_fluid()) fluid_bins_ = sort_particles_by_cell(grid_, fluid_);
  if (has_solids()) solid_bins_ = sort_particles_by_cell(grid_, solid_);
}

// §3 step 1: APIC P2G; gravity enters the grid momentum.
template <int dim>
void Simulation<dim>::particles_to_grid(Real dt) {
  auto scope = timer_.scope("p2g");
  if (has_fluid()) {
    // Lent mass (coupling.borrowed_fluid = "mass") joins the transfer; borrowed volume does not.
    fluid_particles_to_grid(grid_, quadrature_fluid(), quadrature_bins(), corner_momentum_);
    for (std::size_t k = 0; k < corner_momentum_.mass.size(); ++k)
      corner_momentum_.momentum[k] += dt * corner_momentum_.mass[k] * gravity_;
  }
  if (has_solids()) {
    solid_particles_to_grid(grid_, solid_, solid_bins_, node_momentum_);
    for (std::size_t k = 0; k < node_momentum_.mass.size(); ++k)
      node_momentum_.momentum[k] += dt * node_momentum_.mass[k] * gravity_;
  }
}

// §3 step 2: v_s^n -> v_s* by projected Newton on the incremental potential. Clamped nodes
// are Dirichlet; a node whose quadratic support reaches through a slip wall (the outermost
// two node layers) and that moves into the wall has its normal component held at zero:
// free slip, no penetration, and separation allowed (method.md §1 walls).
template <int dim>
void Simulation<dim>::solve_solid_momentum(Real dt) {
  auto scope = timer_.scope("newton");
  const GridLayout<dim> nodes = grid_.nodes();
  SolidNodes<dim> state;
  state.mass = node_momentum_.mass;
  state.velocity.assign(nodes.size(), Vec<dim>::Zero());
  state.clamped = clamped_node_;
  state.fixed_axes.assign(nodes.size(), 0);
  for (int k = 0; k < nodes.size(); ++k) {
    if (!(state.mass[k] > 0)) continue;
    const Vec<dim> v = node_momentum_.momentum[k] / state.mass[k];
    state.velocity[k] = v;
    const IVec<dim> i = nodes.multi_index(k);
    for (int a = 0; a < dim; ++a) {
      if (slip_[a][0] && i[a] <= 0 && v[a] <= 0) state.fixed_axes[k] |= std::uint8_t(1u << a);
      if (slip_[a][1] && i[a] >= grid_.cells[a] - 1 && v[a] >= 0) state.fixed_axes[k] |= std::uint8_t(1u << a);
    }
  }
  // Every node with mass clamped (a fixed obstacle): nothing to solve, v* = 0.
  bool any_free = false;
  for (int k = 0; k < nodes.size() && !any_free; ++k) {
    const bool clamped = !state.clamped.empty() && state.clamped[k];
    any_free = state.mass[k] > 0 && !clamped;
  }
  solid_hessian_nodes_.clear();
  if (!any_free) {
    node_velocity_star_.assign(nodes.size(), Vec<dim>::Zero());
    last_.newton_iterations = last_.newton_cg_iterations = 0;
    wall_held_axes_ = std::move(state.fixed_axes);
    return;
  }
  const SolidIncrementalPotential<dim, SolidMaterial<dim>> potential(grid_, solid_, materials_, solid_.body, state, dt);
  auto v = potential.initial_velocity();
  const NewtonResult result = minimize_projected_newton(potential, v, newton_options_);
  last_.newton_iterations = result.iterations;
  last_.newton_cg_iterations = result.cg_iterations;
  if (!result.converged)
    throw NumericalFailure(fmt::format("solid Newton step did not converge: {}; try a smaller dt_max or cfl, or a "
                                       "larger newton.max_iterations", result.summary()));
  potential.scatter(v, node_velocity_star_);
  wall_held_axes_ = std::move(state.fixed_axes);  // kept at zero by the pressure solve too
  if (scene_.coupling.solid_response == "stiffness") {
    // The linearisation of the step at v* for the coupled solve (pressure_system.h).
    solid_hessian_ = potential.hessian(v, true);
    for (int r = 0; r * dim < potential.unknowns(); ++r) solid_hessian_nodes_.push_back(potential.dense_node(r));
  }
}

template <int dim>
void Simulation<dim>::build_solid_operators() {
  auto scope = timer_.scope("solid operators");
  solid_ops_ = iqmpm::build_solid_operators<dim>(grid_, solid_, solid_bins_, node_momentum_.mass, ghost_stiffness_);
}

// §3 step 3: IQ points and the fluid quadrature that includes the borrowed fluid.
template <int dim>
void Simulation<dim>::find_interface_quadrature() {
  auto scope = timer_.scope("interface quadrature");
  iq_points_ = find_interface_points(grid_, fluid_, fluid_bins_, solid_, scene_.coupling.interface_reach);
  const bool borrowing = !iq_points_.empty() && scene_.coupling.borrowed_fluid != "none";
  lend_mass_ = borrowing && scene_.coupling.borrowed_fluid == "mass";
  borrowed_volume_ = borrowing && !lend_mass_;
  // Borrowed volume: a few massless points beside the (already sorted) fluid particles.
  // Lent mass changes every lender, so the whole quadrature is rebuilt and sorted.
  if (borrowed_volume_) {
    borrowed_points_ = borrowed_fluid_points(grid_, fluid_, solid_, iq_points_, false);
    borrowed_point_bins_ = sort_particles_by_cell(grid_, borrowed_points_);
  } else if (lend_mass_) {
    fluid_quadrature_ = fluid_quadrature_lending_mass(grid_, fluid_, solid_, iq_points_);
    fluid_quadrature_bins_ = sort_particles_by_cell(grid_, fluid_quadrature_);
  }
}

// §4: H^s and H^f rows, after both materials' dofs are numbered.
template <int dim>
void Simulation<dim>::build_interface_operators() {
  auto scope = timer_.scope("interface quadrature");
  iq_ops_ = iqmpm::build_interface_operators(grid_, iq_points_, solid_,
                                             mass_reflected_across_walls<dim>(grid_, node_momentum_.mass, slip_),
                                             solid_ops_.dof_of_node,
                                             ops_.dof_of_corner, solid_ops_.velocity_dofs() * dim);
}

template <int dim>
void Simulation<dim>::build_fluid_operators() {
  auto scope = timer_.scope("fluid operators");
  FluidQuadratureOptions<dim> options;
  options.surface_cells_at_centre = scene_.fluid.surface_quadrature == "centre";
  solid_corners_.clear();
  if (!iq_points_.empty() && !scene_.coupling.interior_fluid_corners) {
    options.real_fluid_bins = &fluid_bins_;
    mark_solid_corners();
    if (!solid_corners_.empty()) options.solid_corners = &solid_corners_;
  }
  if (borrowed_volume_) {
    options.volume_points = &borrowed_points_;
    options.volume_point_bins = &borrowed_point_bins_;
  }
  ops_ = iqmpm::build_fluid_operators<dim>(grid_, quadrature_fluid(), quadrature_bins(), corner_momentum_, fluid_density_, slip_, options);
}

// coupling.solid_corner_fraction: the fluid corners whose N1 support is at least that
// fraction solid. On a flat surface a corner's fraction is 0.5, and 1 - (1 - d)^2 / 2 at a
// depth of d cells inside it (0.75 at d = 0.29). A corner on a slip wall has half its
// support beyond the wall, where the body's mirror image lies (as for the IQ normals,
// mass_reflected_across_walls): its fraction counts twice, per wall it lies on. The caller
// has cleared the mask.
template <int dim>
void Simulation<dim>::mark_solid_corners() {
  const Real threshold = scene_.coupling.solid_corner_fraction;
  if (!(threshold > 0)) return;
  const GridLayout<dim> corners = grid_.corners();
  std::vector<Real> fraction(corners.size(), 0);
  const Real cell_volume = grid_.cell_volume();
  for (std::size_t p = 0; p < solid_.size(); ++p) {
    const auto stencil = linear_stencil<dim>(grid_.to_cells(solid_.position[p]), grid_.dx);
    const Real share = solid_.initial_volume[p] * solid_.deformation_gradient[p].determinant() / cell_volume;
    for_each_offset<dim, 2>([&](const IVec<dim>& offset) { fraction[corners.index(stencil.base + offset)] += stencil.weight(offset) * share; });
  }
  solid_corners_.assign(corners.size(), 0);
  for (int k = 0; k < corners.size(); ++k) {
    const IVec<dim> corner = corners.multi_index(k);
    for (int a = 0; a < dim; ++a)
      if ((corner[a] == 0 && slip_[a][0]) || (corner[a] == grid_.cells[a] && slip_[a][1])) fraction[k] *= 2;
    solid_corners_[k] = fraction[k] >= threshold;
  }
}

// §5: the stacked velocities are the solid nodes' (v_s*, after Newton) then the fluid
// corners' (v_f^n); the blocks are p_g (ghost matrix, G^sT with compliance S/dt and offset
// S p_g^n/dt), p_f (G^fT) and y (B), each present only when the scene needs it. A clamped
// node, or a component held by a wall, gets zero inverse mass: the solve cannot move it.
template <int dim>
void Simulation<dim>::assemble_pressure_system(Real dt) {
  auto scope = timer_.scope("assembly");
  const int ns = has_solids() ? solid_ops_.velocity_dofs() : 0;
  const int nf = has_fluid() ? ops_.velocity_dofs() : 0;
  fluid_column_offset_ = ns * dim;
  Eigen::VectorXd inverse_mass((ns + nf) * dim);
  velocity_star_.resize((ns + nf) * dim);
  for (int d = 0; d < ns; ++d) {
    const int node = solid_ops_.node_of_dof[d];
    const bool clamped = !clamped_node_.empty() && clamped_node_[node];
    const Vec<dim>& v = node_velocity_star_[node];
    for (int a = 0; a < dim; ++a) {
      // A wall-held component is exactly zero after Newton and must stay so.
      const bool held = clamped || (wall_held_axes_[node] & (1u << a));
      inverse_mass[d * dim + a] = held ? 0 : 1 / node_momentum_.mass[node];
      velocity_star_[d * dim + a] = v[a];
    }
  }
  for (int d = 0; d < nf; ++d) {
    const int corner = ops_.corner_of_dof[d];
    // v^n from the APIC transfer (momentum / transferred mass); M^f from the quadrature.
    const Vec<dim> v = corner_momentum_.momentum[corner] / corner_momentum_.mass[corner];
    for (int a = 0; a < dim; ++a) {
      inverse_mass[fluid_column_offset_ + d * dim + a] = 1 / ops_.mass[d];
      velocity_star_[fluid_column_offset_ + d * dim + a] = v[a];
    }
  }
  system_.reset(inverse_mass);
  if (!solid_hessian_nodes_.empty()) set_solid_mass_block();
  ghost_offset_ = pressure_offset_ = wall_offset_ = interface_offset_ = -1;
  if (has_solids()) {
    std::vector<Real> compliance(solid_ops_.pressure_unknowns()), offset(solid_ops_.pressure_unknowns());
    for (int j = 0; j < solid_ops_.pressure_unknowns(); ++j) {
      compliance[j] = solid_ops_.compliance[j] / dt;
      offset[j] = solid_ops_.compliance[j] * solid_ops_.previous_pressure[j] / dt;
    }
    ghost_offset_ = system_.unknowns();
    system_.add_block("p_g", solid_ops_.pressure_unknowns(), solid_ops_.gradient_transpose, compliance, offset);
  }
  if (has_fluid()) {
    pressure_offset_ = system_.unknowns();
    const int block = system_.add_block("p_f", ops_.pressure_unknowns(), ops_.gradient_transpose, {}, {}, fluid_column_offset_);
    // Fluid corners inside a solid take the solid's velocity: their G^fT entries act on it.
    std::vector<Triplet> on_solid;
    for (const auto& entry : ops_.solid_corner_gradient)
      for_each_solid_weight(grid_, grid_.corners().multi_index(entry.corner), solid_ops_.dof_of_node, [&](int dof, Real weight) {
        for (int a = 0; a < dim; ++a) on_solid.emplace_back(entry.row, dof * dim + a, weight * entry.coefficient[a]);
      });
    system_.add_entries(block, on_solid);
    if (!ops_.wall_faces.empty()) {
      wall_offset_ = system_.unknowns();
      system_.add_block("y", int(ops_.wall_faces.size()), ops_.wall_rows, {}, {}, fluid_column_offset_);
    }
  }
  if (!iq_points_.empty()) {  // rows H^f v_f - H^s v_s, columns already stacked
    interface_offset_ = system_.unknowns();
    system_.add_block("h", iq_ops_.multipliers(), iq_ops_.rows);
  }
  system_.assemble(dt);
  if (scene_.coupling.interface == "unilateral") mark_unilateral_rows();
  last_.pressure_unknowns = system_.unknowns();
  last_.velocity_unknowns = (ns + nf) * dim;
}

// coupling.solid_response = stiffness: the free solid velocity entries take the Newton
// Hessian M^s + dt^2 K at v* as their mass in the solve (pressure_system.h). A component
// held by a wall stays out: its inverse mass is zero, the solve cannot move it.
template <int dim>
void Simulation<dim>::set_solid_mass_block() {
  const int n = int(solid_hessian_nodes_.size()) * dim;
  std::vector<int> reduced(n, -1), columns;
  for (int k = 0; k < n; ++k) {
    const int node = solid_hessian_nodes_[k / dim], a = k % dim;
    if (wall_held_axes_[node] & (1u << a)) continue;
    reduced[k] = int(columns.size());
    columns.push_back(solid_ops_.dof_of_node[node] * dim + a);
  }
  std::vector<Triplet> entries;
  for (int row = 0; row < n; ++row)
    for (typename decltype(solid_hessian_)::InnerIterator it(solid_hessian_, row); it; ++it)
      if (reduced[row] >= 0 && reduced[it.col()] >= 0) entries.emplace_back(reduced[row], reduced[it.col()], it.value());
  SparseMatrix mass(int(columns.size()), int(columns.size()));
  mass.setFromTriplets(entries.begin(), entries.end());
  system_.set_mass_block(std::move(columns), std::move(mass));
}

template <int dim>
void Simulation<dim>::solve_pressure_system() {
  auto scope = timer_.scope("solve");
  const Eigen::VectorXd rhs = system_.rhs(velocity_star_);
  // Warm start from the previous step's solution, matched by dual cell and wall face.
  Eigen::VectorXd x = Eigen::VectorXd::Zero(system_.size());
  if (ghost_offset_ >= 0 && !previous_ghost_.empty())
    for (int j = 0; j < solid_ops_.pressure_unknowns(); ++j) x[ghost_offset_ + j] = previous_ghost_[solid_ops_.cell_of_pressure[j]];
  if (pressure_offset_ >= 0 && !previous_pressure_.empty())
    for (int i = 0; i < ops_.pressure_unknowns(); ++i) x[pressure_offset_ + i] = previous_pressure_[ops_.cell_of_pressure[i]];
  if (wall_offset_ >= 0)
    for (std::size_t f = 0; f < ops_.wall_faces.size(); ++f) {
      const auto& face = ops_.wall_faces[f];
      auto it = previous_wall_.find({face.dual_cell, face.wall.axis * 2 + face.wall.side});
      if (it != previous_wall_.end()) x[wall_offset_ + f] = it->second;
    }
  if (interface_offset_ >= 0 && !previous_interface_.empty())
    for (int j = 0; j < iq_ops_.multipliers(); ++j) x[interface_offset_ + j] = previous_interface_[iq_ops_.cell_of_multiplier[j]];
  // One solver kept across solves: a direct one reuses its symbolic analysis while the
  // pattern repeats (the active-set rounds of a step).
  if (!pressure_solver_ || pressure_solver_->name() != linear_solver_name(scene_.solver, system_.size(), dim))
    pressure_solver_ = make_linear_solver(scene_.solver, system_.size(), dim);
  LinearSolver* solver = pressure_solver_.get();
  if (system_.has_mass_block() && !solver->solves_quasi_definite())
    throw InputError(fmt::format("scene key 'coupling.solid_response' = \"stiffness\" needs the LDL^T pressure solve "
                                 "(solver.method = ldlt, or auto in 2-D up to solver.direct_max_unknowns = {}); "
                                 "this system has {} rows. Accepted: mass | stiffness",
                                 scene_.solver.direct_max_unknowns, system_.size()));
  last_.linear = solver->solve(system_.matrix(), rhs, x);
  last_.modified_solves += last_.linear.modified_rows > 0;
  if (!last_.linear.converged || !x.allFinite())
    throw NumericalFailure(fmt::format(
        "pressure solve ({}) did not converge: relative residual {:.3g} after {} iterations (tolerance {:.1g}, {} unknowns); "
        "try solver.method=cholmod, a smaller cfl, or a larger solver.max_iterations",
        last_.linear.method, last_.linear.relative_residual, last_.linear.iterations, scene_.solver.tolerance,
        system_.unknowns()));
  lambda_ = x;
  if (ghost_offset_ >= 0) {
    previous_ghost_.assign(grid_.dual_cells().size(), 0);
    for (int j = 0; j < solid_ops_.pressure_unknowns(); ++j) previous_ghost_[solid_ops_.cell_of_pressure[j]] = x[ghost_offset_ + j];
  }
  if (pressure_offset_ >= 0) {
    previous_pressure_.assign(grid_.dual_cells().size(), 0);
    for (int i = 0; i < ops_.pressure_unknowns(); ++i) previous_pressure_[ops_.cell_of_pressure[i]] = x[pressure_offset_ + i];
  }
  previous_interface_.assign(grid_.dual_cells().size(), 0);
  if (interface_offset_ >= 0)
    for (int j = 0; j < iq_ops_.multipliers(); ++j) previous_interface_[iq_ops_.cell_of_multiplier[j]] = x[interface_offset_ + j];
  previous_wall_.clear();
  if (wall_offset_ >= 0)
    for (std::size_t f = 0; f < ops_.wall_faces.size(); ++f) {
      const auto& face = ops_.wall_faces[f];
      previous_wall_[{face.dual_cell, face.wall.axis * 2 + face.wall.side}] = x[wall_offset_ + f];
    }
}

// coupling.interface = unilateral (method.md §9: the bilateral constraint holds fluid to a
// solid it touches). The rows through which the fluid pulls on a solid are inequalities:
// every h row, and the p_f rows of cells whose corners move with the solid. On the first
// round of a step a row starts released where its cell was released at the end of the
// last step; released rows have zero multiplier (PressureSystem::release). Call after
// the system is assembled.
template <int dim>
void Simulation<dim>::mark_unilateral_rows() {
  const int rows = system_.unknowns();
  unilateral_row_.assign(rows, 0);
  cell_of_row_.assign(rows, -1);
  for (int j = 0; interface_offset_ >= 0 && j < iq_ops_.multipliers(); ++j) {  // iq_ops_ is stale without IQ points
    unilateral_row_[interface_offset_ + j] = 1;
    cell_of_row_[interface_offset_ + j] = iq_ops_.cell_of_multiplier[j];
  }
  for (const auto& entry : ops_.solid_corner_gradient) {
    if (pressure_offset_ < 0) break;
    unilateral_row_[pressure_offset_ + entry.row] = 1;
    cell_of_row_[pressure_offset_ + entry.row] = ops_.cell_of_pressure[entry.row];
  }
  if (released_rows_.empty()) {
    released_rows_.assign(rows, 0);
    for (int i = 0; i < rows; ++i) {
      if (!unilateral_row_[i]) continue;
      const auto& released = i >= interface_offset_ && interface_offset_ >= 0 ? released_h_cells_ : released_p_cells_;
      if (!released.empty()) released_rows_[i] = released[cell_of_row_[i]];
    }
  }
  system_.release(released_rows_);
}

// One round of the active set: an enforced row in tension (multiplier < 0) is released,
// so the fluid may separate there; a released row whose fluid now compresses against the
// solid (row value D v > 0: approach for h, convergence for p_f) is enforced again.
// Returns whether the set changed; remembers the released cells for the next step.
template <int dim>
bool Simulation<dim>::update_released_rows() {
  if (unilateral_row_.empty()) return false;
  const Eigen::VectorXd v = system_.corrected_velocity(velocity_star_, lambda_);
  const Eigen::VectorXd value = system_.full_constraint_times(v), scale = system_.full_row_scale();
  const Real speed = v.size() ? v.cwiseAbs().maxCoeff() : 0;
  std::vector<int> released, restored;
  for (int i = 0; i < system_.unknowns(); ++i) {
    if (!unilateral_row_[i]) continue;
    if (!released_rows_[i] && lambda_[i] < 0) {
      released_rows_[i] = 1;
      released.push_back(i);
    } else if (released_rows_[i] && value[i] > 1e-9 * scale[i] * speed) {
      released_rows_[i] = 0;
      restored.push_back(i);
    }
  }
  const bool changed = !released.empty() || !restored.empty();
  newly_released_rows_ = std::move(released);
  newly_restored_rows_ = std::move(restored);
  released_h_cells_.assign(grid_.dual_cells().size(), 0);
  released_p_cells_.assign(grid_.dual_cells().size(), 0);
  for (int i = 0; i < system_.unknowns(); ++i)
    if (unilateral_row_[i] && released_rows_[i])
      (i >= interface_offset_ && interface_offset_ >= 0 ? released_h_cells_ : released_p_cells_)[cell_of_row_[i]] = 1;
  return changed;
}

// §5: v^{n+1} = v* - dt M^-1 D^T lambda.
template <int dim>
void Simulation<dim>::update_grid_velocities() {
  auto scope = timer_.scope("velocity update");
  velocity_next_ = system_.corrected_velocity(velocity_star_, lambda_);
  if (has_fluid()) {
    corner_velocity_.assign(grid_.corners().size(), Vec<dim>::Zero());
    for (int d = 0; d < ops_.velocity_dofs(); ++d)
      for (int a = 0; a < dim; ++a)
        corner_velocity_[ops_.corner_of_dof[d]][a] = velocity_next_[fluid_column_offset_ + d * dim + a];
  }
  if (has_solids()) {
    node_velocity_ = node_velocity_star_;
    for (int d = 0; d < solid_ops_.velocity_dofs(); ++d)
      for (int a = 0; a < dim; ++a) node_velocity_[solid_ops_.node_of_dof[d]][a] = velocity_next_[d * dim + a];
    // A fluid particle that strayed inside a solid takes the solid's velocity from the
    // corners that move with it (coupling.solid_corner_fraction).
    if (has_fluid() && !solid_corners_.empty()) {
      const GridLayout<dim> corners = grid_.corners();
      for (int k = 0; k < corners.size(); ++k) {
        if (!solid_corners_[k] || ops_.dof_of_corner[k] >= 0) continue;
        Vec<dim> v = Vec<dim>::Zero();
        for_each_solid_weight(grid_, corners.multi_index(k), solid_ops_.dof_of_node,
                              [&](int dof, Real weight) { v += weight * node_velocity_[solid_ops_.node_of_dof[dof]]; });
        corner_velocity_[k] = v;
      }
    }
    measure_interface_forces();
  }
}

// §3 step 5.
template <int dim>
void Simulation<dim>::grid_to_particles(Real dt) {
  auto scope = timer_.scope("g2p");
  if (has_fluid()) {
    fluid_grid_to_particles(grid_, corner_velocity_, dt, fluid_);
    keep_particles_in_domain(fluid_, "fluid");
  }
  if (!has_solids()) return;
  // Solid: v_p, C_p, F_p^{n+1} = (I + dt grad v) F_p^n; J_g = 1 - p_g / lambda_g from the
  // solved matrix pressure of the particle's dual cell (before it moves); then x += dt v.
  std::vector<Mat<dim>> velocity_gradient;
  solid_grid_to_particles(grid_, node_velocity_, solid_, &velocity_gradient);
  const GridLayout<dim> cells = grid_.dual_cells();
  const int n = int(solid_.size());
  Real min_J = std::numeric_limits<Real>::infinity();
#pragma omp parallel for schedule(static) reduction(min : min_J)
  for (int p = 0; p < n; ++p) {
    solid_.deformation_gradient[p] = (Mat<dim>::Identity() + dt * velocity_gradient[p]) * solid_.deformation_gradient[p];
    min_J = std::min(min_J, solid_.deformation_gradient[p].determinant());
    const int cell = cells.index(dual_cell_of<dim>(grid_.to_cells(solid_.position[p])));
    solid_.ghost_J[p] = 1 - ghost_pressure(cell) / ghost_stiffness_[solid_.body[p]];
    solid_.position[p] += dt * solid_.velocity[p];
  }
  last_.solid_min_J = min_J;
  if (!(min_J > 0))
    throw NumericalFailure(fmt::format("a solid particle inverted (det F = {:.3g} <= 0): the step was too large for the "
                                       "solid's stiffness; lower dt_max or cfl", min_J));
  keep_particles_in_domain(solid_, "solid");
}

// A particle pushed through a slip wall by round-off or a large step is put back just
// inside; one more than a cell beyond any side, or beyond a side without a wall, means the
// step was unstable and the run stops (method.md §9).
template <int dim>
void Simulation<dim>::keep_particles_in_domain(Particles<dim>& particles, const char* kind) {
  const Vec<dim> lower = grid_.origin, upper = grid_.upper();
  const Real margin = 1e-4 * grid_.dx;
  int clamps = 0;
  for (std::size_t p = 0; p < particles.size(); ++p) {
    Vec<dim>& x = particles.position[p];
    if (!x.allFinite() || !particles.velocity[p].allFinite())
      throw NumericalFailure(fmt::format("{} particle {} has a non-finite position or velocity (NaN): the step was unstable", kind, p));
    for (int a = 0; a < dim; ++a)
      for (int s = 0; s < 2; ++s) {
        const Real wall = s == 0 ? lower[a] : upper[a];
        const Real outside = s == 0 ? wall - x[a] : x[a] - wall;
        if (outside < -margin) continue;
        if (!slip_[a][s] || outside > grid_.dx)
          throw NumericalFailure(fmt::format(
              "{} particle {} left the domain through side {}{} at {:.4g} m (wall at {:.4g} m){}", kind, p, "xyz"[a],
              s == 0 ? '-' : '+', x[a], wall, slip_[a][s] ? ": more than a cell beyond the wall in one step, lower cfl" : ""));
        x[a] = s == 0 ? wall + margin : wall - margin;
        ++clamps;
      }
  }
  last_.wall_clamps += clamps;
}

// Particles' volume in each dual cell (layout index): V0, or with current_volume the
// current volume V0 det F (solids); particles outside the domain are not counted.
template <int dim>
std::vector<Real> particle_volume_per_cell(const Grid<dim>& grid, const Particles<dim>& particles, bool current_volume) {
  const auto cells = grid.dual_cells();
  std::vector<Real> volume(cells.size(), 0);
  for (std::size_t p = 0; p < particles.size(); ++p) {
    const IVec<dim> c = dual_cell_of<dim>(grid.to_cells(particles.position[p]));
    if (cells.contains(c))
      volume[cells.index(c)] += particles.initial_volume[p] * (current_volume ? particles.deformation_gradient[p].determinant() : Real(1));
  }
  return volume;
}

// Optional position correction (method.md §3 step 6): particles drift into clusters and
// gaps because the projection makes the grid velocity divergence-free, not the particle
// flow. One extra solve with the same operators finds the smallest (mass-weighted)
// displacement field d of the corners with
//   integral over cell i of div d = relaxation (phi_i - 1) dx^dim,  B d = 0,
// phi_i the particles' volume fraction in cell i; cells next to empty space are only
// expanded (phi > 1), never compressed, since they may be partly empty. Particles then
// move by the N1 interpolation of d. The wall rows keep them off the walls.
// With solids, phi counts the solid particles' current volume too (the reference code
// does the same), so water crowded against or into a body is spread back out, and a
// fluid cell's face towards a cell that is at least half solid and holds no fluid gets a
// wall row (no displacement through it), so the correction never pushes water into a body.
template <int dim>
void Simulation<dim>::correct_particle_positions() {
  auto scope = timer_.scope("position correction");
  fluid_bins_ = sort_particles_by_cell(grid_, fluid_);
  fluid_particles_to_grid(grid_, fluid_, fluid_bins_, corner_momentum_);
  const FluidOperators<dim> ops = iqmpm::build_fluid_operators<dim>(grid_, fluid_, fluid_bins_, corner_momentum_,
                                                                    fluid_density_, slip_);
  const int nv = ops.velocity_dofs(), np = ops.pressure_unknowns();
  const Real cell_volume = grid_.cell_volume();
  const GridLayout<dim> cells = grid_.dual_cells();
  const std::vector<Real> solid_volume = has_solids() ? particle_volume_per_cell(grid_, solid_, true) : std::vector<Real>();
  // Faces between a fluid cell and a (mostly) solid cell without fluid: no displacement.
  std::vector<Triplet> solid_face_rows;
  int solid_faces = 0;
  if (has_solids()) {
    const GridLayout<dim> corners = grid_.corners();
    const Real face_weight = cell_volume / grid_.dx / Real(1 << (dim - 1));
    for (int i = 0; i < np; ++i) {
      const IVec<dim> cell = cells.multi_index(ops.cell_of_pressure[i]);
      for (int axis = 0; axis < dim; ++axis)
        for (int side = 0; side < 2; ++side) {
          IVec<dim> neighbour = cell;
          neighbour[axis] += side == 0 ? -1 : 1;
          if (!cells.contains(neighbour)) continue;
          const int k = cells.index(neighbour);
          if (ops.pressure_of_cell[k] >= 0 || solid_volume[k] < Real(0.5) * cell_volume) continue;
          const Real normal = side == 0 ? -1 : 1;
          const std::size_t before = solid_face_rows.size();
          for_each_offset<dim, 2>([&](const IVec<dim>& offset) {
            if (offset[axis] != side) return;
            const int dof = ops.dof_of_corner[corners.index(cell + offset)];
            if (dof >= 0) solid_face_rows.emplace_back(solid_faces, dof * dim + axis, face_weight * normal);
          });
          if (solid_face_rows.size() > before) ++solid_faces;  // an empty row would be singular
        }
    }
  }
  std::vector<Real> target(np + ops.wall_faces.size() + solid_faces, 0);
  for (int i = 0; i < np; ++i) {
    const int cell = ops.cell_of_pressure[i];
    Real volume = solid_volume.empty() ? 0 : solid_volume[cell];
    for (int p = fluid_bins_.begin(cell); p < fluid_bins_.end(cell); ++p) volume += fluid_.initial_volume[p];
    Real excess = volume / cell_volume - 1;
    if (!ops.interior[i]) excess = std::max(excess, Real(0));
    // G^fT d = -integral of div d.
    target[i] = -scene_.fluid.position_correction * excess * cell_volume;
  }
  Eigen::VectorXd inverse_mass(nv * dim);
  for (int d = 0; d < nv; ++d)
    for (int a = 0; a < dim; ++a) inverse_mass[d * dim + a] = 1 / ops.mass[d];
  PressureSystem correction;
  correction.reset(inverse_mass);
  correction.add_block("p_f", np, ops.gradient_transpose);
  if (!ops.wall_faces.empty()) correction.add_block("y", int(ops.wall_faces.size()), ops.wall_rows);
  if (solid_faces > 0) correction.add_block("solid faces", solid_faces, solid_face_rows);
  correction.assemble(1);
  // d = 0 - M^-1 D^T q with A q = -target gives D d = target.
  Eigen::VectorXd rhs = -Eigen::Map<const Eigen::VectorXd>(target.data(), Eigen::Index(target.size()));
  Eigen::VectorXd q;
  auto solver = make_linear_solver(scene_.solver, correction.unknowns(), dim);
  const auto stats = solver->solve(correction.matrix(), rhs, q);
  if (!stats.converged || !q.allFinite())
    throw NumericalFailure(fmt::format("position correction solve did not converge (relative residual {:.3g})", stats.relative_residual));
  const Eigen::VectorXd displacement = correction.corrected_velocity(Eigen::VectorXd::Zero(nv * dim), q);
  std::vector<Vec<dim>> corner_displacement(grid_.corners().size(), Vec<dim>::Zero());
  for (int d = 0; d < nv; ++d)
    for (int a = 0; a < dim; ++a) corner_displacement[ops.corner_of_dof[d]][a] = displacement[d * dim + a];
  const GridLayout<dim> corners = grid_.corners();
  const int n = int(fluid_.size());
#pragma omp parallel for schedule(static)
  for (int p = 0; p < n; ++p) {
    const auto stencil = linear_stencil<dim>(grid_.to_cells(fluid_.position[p]), grid_.dx);
    Vec<dim> shift = Vec<dim>::Zero();
    for_each_offset<dim, 2>([&](const IVec<dim>& offset) { shift += stencil.weight(offset) * corner_displacement[corners.index(stencil.base + offset)]; });
    fluid_.position[p] += shift;
  }
  keep_particles_in_domain(fluid_, "fluid");
}

template <int dim>
bool Simulation<dim>::has_fluid_pressure(int dual_cell) const {
  return pressure_offset_ >= 0 && !ops_.pressure_of_cell.empty() && lambda_.size() > 0 && ops_.pressure_of_cell[dual_cell] >= 0;
}

template <int dim>
Real Simulation<dim>::fluid_pressure(int dual_cell) const {
  if (pressure_offset_ < 0 || ops_.pressure_of_cell.empty() || lambda_.size() == 0) return 0;
  const int i = ops_.pressure_of_cell[dual_cell];
  return i >= 0 ? lambda_[pressure_offset_ + i] : 0;
}

template <int dim>
Real Simulation<dim>::ghost_pressure(int dual_cell) const {
  if (ghost_offset_ < 0 || solid_ops_.pressure_of_cell.empty() || lambda_.size() == 0) return 0;
  const int j = solid_ops_.pressure_of_cell[dual_cell];
  return j >= 0 ? lambda_[ghost_offset_ + j] : 0;
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

template <int dim>
std::vector<Real> Simulation<dim>::solid_particle_pressure() const {
  return value_at_particles(grid_, solid_, [&](int cell) { return ghost_pressure(cell); });
}

template <int dim>
Vec<dim> Simulation<dim>::interface_force(int body) const {
  return body < int(interface_force_.size()) ? interface_force_[body] : Vec<dim>::Zero();
}

// Force of the fluid on each solid (method.md §7): -D^T lambda on the solid nodes over the
// rows that couple them to the fluid (h, and p_f where fluid corners inside a solid move with
// it); the ghost-matrix rows are internal to the solid. Each node's force is shared among
// the particles around it by their mass there (N2 weight x mass / node mass), so that a
// node shared by bodies, or by a region and the rest of a body, is split consistently.
// Evaluated once per step, before the particles move, so that the split uses the same
// particle positions as the node masses.
template <int dim>
Vec<dim> Simulation<dim>::region_interface_force(const std::string& probe_name) const {
  for (const auto& region : force_regions_)
    if (region.probe_name == probe_name) return region.force;
  return Vec<dim>::Constant(std::nan(""));
}

template <int dim>
void Simulation<dim>::measure_interface_forces() {
  interface_force_.assign(scene_.solids.size(), Vec<dim>::Zero());
  for (auto& region : force_regions_) region.force.setZero();
  if (interface_offset_ < 0) return;
  Eigen::VectorXd coupling = Eigen::VectorXd::Zero(system_.unknowns());
  coupling.segment(interface_offset_, iq_ops_.multipliers()) = lambda_.segment(interface_offset_, iq_ops_.multipliers());
  if (!ops_.solid_corner_gradient.empty())
    coupling.segment(pressure_offset_, ops_.pressure_unknowns()) = lambda_.segment(pressure_offset_, ops_.pressure_unknowns());
  const Eigen::VectorXd nodal = -(system_.constraint().transpose() * coupling);
  const GridLayout<dim> nodes = grid_.nodes();
  std::vector<Vec<dim>> node_force(nodes.size(), Vec<dim>::Zero());
  for (int d = 0; d < solid_ops_.velocity_dofs(); ++d) node_force[solid_ops_.node_of_dof[d]] = nodal.template segment<dim>(d * dim);
  for (std::size_t p = 0; p < solid_.size(); ++p) {
    const auto stencil = quadratic_stencil<dim>(grid_.to_cells(solid_.position[p]), grid_.dx);
    Vec<dim> share = Vec<dim>::Zero();
    for_each_offset<dim, 3>([&](const IVec<dim>& offset) {
      const int node = nodes.index(stencil.base + offset);
      if (node_momentum_.mass[node] > 0) share += stencil.weight(offset) * solid_.mass[p] / node_momentum_.mass[node] * node_force[node];
    });
    interface_force_[solid_.body[p]] += share;
    for (auto& region : force_regions_)
      if (region.contains(solid_, p)) region.force += share;
  }
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
Vec<dim> Simulation<dim>::solid_centre_of_mass(int body) const {
  return body_mass_average(solid_, body, solid_.position);
}

template <int dim>
Vec<dim> Simulation<dim>::solid_mean_velocity(int body) const {
  return body_mass_average(solid_, body, solid_.velocity);
}

template <int dim>
Real Simulation<dim>::solid_angle(int body) const {
  if constexpr (dim != 2) {
    return std::nan("");
  } else {
    Vec<dim> c = Vec<dim>::Zero(), c0 = Vec<dim>::Zero();
    Real mass = 0;
    for (std::size_t p = 0; p < solid_.size(); ++p)
      if (solid_.body[p] == body) {
        c += solid_.mass[p] * solid_.position[p];
        c0 += solid_.mass[p] * solid_.initial_position[p];
        mass += solid_.mass[p];
      }
    c /= mass;
    c0 /= mass;
    Real cross = 0, dot = 0;  // 2-D Kabsch: the rotation maximising sum m (R r0) . r
    for (std::size_t p = 0; p < solid_.size(); ++p)
      if (solid_.body[p] == body) {
        const Vec<dim> r = solid_.position[p] - c, r0 = solid_.initial_position[p] - c0;
        cross += solid_.mass[p] * (r0[0] * r[1] - r0[1] * r[0]);
        dot += solid_.mass[p] * r0.dot(r);
      }
    return std::atan2(cross, dot);
  }
}

template <int dim>
int Simulation<dim>::body_index(const std::string& name) const {
  for (std::size_t b = 0; b < scene_.solids.size(); ++b)
    if (scene_.solids[b].name == name) return int(b);
  return -1;
}

template <int dim>
Vec<dim> Simulation<dim>::tracked_displacement(const std::string& probe_name) const {
  // The material point X moves with its carrier particles' local affine motion,
  // x = x_p + F_p (X - X_p), averaged over the carriers (exact for an affine motion). A
  // marker moved by the interpolated grid velocity instead lagged at a body's edge, where
  // the stencil reaches empty nodes, and fell off a deflecting gate's tip.
  for (const auto& marker : markers_) {
    if (marker.name != probe_name) continue;
    Vec<dim> sum = Vec<dim>::Zero();
    int found = 0;
    for (std::size_t p = 0; p < solid_.size(); ++p)
      for (const auto& X : marker.carriers)
        if (solid_.initial_position[p] == X) {
          sum += solid_.position[p] + solid_.deformation_gradient[p] * (marker.start - X);
          ++found;
        }
    return found > 0 ? Vec<dim>(sum / found - marker.start) : Vec<dim>::Constant(std::nan(""));
  }
  return Vec<dim>::Constant(std::nan(""));
}

template <int dim>
Real Simulation<dim>::wall_force(int axis, int side) const {
  if (lambda_.size() == 0 || wall_offset_ < 0) return 0;
  // Force on the wall = sum_k y_k |face_k| n_k (n: outward normal of the fluid).
  const Real face_area = grid_.cell_volume() / grid_.dx;
  const int np = wall_offset_;
  Real force = 0;
  for (std::size_t f = 0; f < ops_.wall_faces.size(); ++f)
    if (ops_.wall_faces[f].wall.axis == axis && ops_.wall_faces[f].wall.side == side)
      force += lambda_[np + f] * face_area * (side == 0 ? -1 : 1);
  return force;
}

template <int dim>
std::vector<Real> Simulation<dim>::fluid_particle_pressure() const {
  return value_at_particles(grid_, fluid_, [&](int cell) { return fluid_pressure(cell); });
}

template <int dim>
Real Simulation<dim>::fluid_particle_volume() const {
  const Real cell_volume = grid_.cell_volume();
  Real total = 0;
  for (Real v : particle_volume_per_cell(grid_, fluid_, false)) total += std::min(v, cell_volume);
  return total;
}

template <int dim>
Real Simulation<dim>::fluid_volume() const {
  const auto cells = grid_.dual_cells();
  const std::vector<Real> fluid = particle_volume_per_cell(grid_, fluid_, false);
  const std::vector<Real> solid = has_solids() ? particle_volume_per_cell(grid_, solid_, true) : std::vector<Real>(cells.size(), 0);
  const Real cell_volume = grid_.cell_volume();
  Real total = 0;
  for (int k = 0; k < cells.size(); ++k) {
    if (fluid[k] == 0) continue;
    const bool interior = is_interior_cell<dim>(cells, cells.multi_index(k), [&](int j) { return fluid[j] > 0; });
    total += interior ? std::max(Real(0), cell_volume - solid[k]) : std::min(fluid[k], cell_volume);
  }
  return total;
}

}  // namespace iqmpm
