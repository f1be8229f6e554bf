#include "scene/scene.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <fmt/format.h>
#include <fstream>
#include <limits>
#include <sstream>

#include "core/errors.h"
#include "core/log.h"
#include "scene/entry_keys.h"
#include "scene/geometry.h"
#include "scene/solver_keys.h"

namespace iqmpm {
namespace {

constexpr Real kInf = std::numeric_limits<Real>::infinity();

SceneSpec read(const Json& document, std::vector<KeyDoc>* docs) {
  SceneSpec scene;
  scene.document = document;
  JsonReader root(document, "", docs);
  scene.name = root.text("name", "", "scene name, shown in logs and summary.json");
  scene.description = root.text("description", "", "free text");
  scene.dim = root.integer("dim", std::nullopt, 2, 3, "spatial dimension");
  const int dim = scene.dim;
  {
    JsonReader domain = root.object("domain", "the simulation box; its sides are the walls");
    scene.domain_min = domain.vector("min", std::nullopt, dim, "lower corner (m)");
    scene.domain_max = domain.vector("max", std::nullopt, dim, "upper corner (m)");
    domain.finish();
  }
  scene.dx = root.number("dx", std::nullopt, 0, kInf, "grid spacing (m); the domain extent must be a whole number of cells, and the "
                           "cells x particles_per_axis^dim below 2^31; the run's estimated memory and output must stay below "
                           "--max-memory and --max-output (docs/method.md#resource-limits)", true);
  if (!docs)
    for (int a = 0; a < dim; ++a) {
      const Real extent = scene.domain_max[a] - scene.domain_min[a];
      if (extent <= 0) throw InputError(fmt::format("scene key 'domain.max': must exceed domain.min on axis {}", a));
      const Real cells = extent / scene.dx;
      if (std::abs(cells - std::round(cells)) > 1e-6 * cells || std::round(cells) < 4)
        throw InputError(fmt::format("scene key 'dx' = {:g}: the domain extent {:g} m on axis {} is {:.4f} cells; "
                                     "accepted: dx that divides every extent into a whole number (>= 4) of cells",
                                     scene.dx, extent, a, cells));
    }
  scene.particles_per_axis = root.integer("particles_per_axis", 2, 1, 8, "particles per cell along each axis (2 gives 4 per cell in 2-D, 8 in 3-D)");
  if (!docs) check_index_range(scene);  // before anything is sized by dx (scene/geometry.h)
  scene.jitter = root.number("jitter", 0, 0, 1, "random displacement of seeded particles, as a fraction of their spacing");
  scene.seed = unsigned(root.integer("seed", 1, 0, std::numeric_limits<int>::max(), "random seed of the jitter"));
  std::vector<Real> default_gravity(dim, 0);
  default_gravity[1] = -9.81;
  scene.gravity = root.vector("gravity", default_gravity, dim, "gravitational acceleration (m/s^2); 'up' is opposite to its largest component");
  scene.gravity_ramp = root.number(
      "gravity_ramp", 0, 0, kInf,
      "time (s) over which gravity grows smoothly from zero to its full value, (1 - cos(pi t / T)) / 2: a "
      "quasi-static load for a static result (docs/method.md#gravity-ramp); 0 = full gravity from the start. The health checks, probes and a "
      "hydrostatic start use the full gravity");
  scene.end_time = root.number("end_time", std::nullopt, 0, kInf, "simulated time to run (s)", true);
  scene.frame_rate = root.number("frame_rate", 0, 0, kInf, "particle frames written per simulated second; 0 = only the first and the last");
  scene.write_frames = root.boolean("write_frames", true, "write particle frames (HDF5 + XDMF) at all");
  scene.write_pressure_fields = root.boolean(
      "write_pressure_fields", false,
      "write every step's solved pressure fields as dense grid tensors to pressure_fields.h5 (MPMNet's dataset, mpmnet/README.md)");
  {
    JsonReader checkpoint = root.object("checkpoint", "when checkpoint.h5 is written, from which `iqmpm resume` continues "
                                                      "(docs/method.md#checkpoints); always at the end and on SIGINT / SIGTERM");
    scene.checkpoint.every_frames = checkpoint.integer("every_frames", scene.checkpoint.every_frames, 0, 1000000,
                                                       "also after every this many frames; 0 = not by frames");
    scene.checkpoint.every_minutes = checkpoint.number("every_minutes", scene.checkpoint.every_minutes, 0, kInf,
                                                       "also after this much wall time (minutes) since the last one; 0 = not by time");
    checkpoint.finish();
  }
  {
    JsonReader health = root.object("health", "checks after every step; a step that fails one, or fails in a solver, is "
                                              "taken again with half the dt (docs/method.md#health-checks)");
    scene.health.checks = health.boolean("checks", scene.health.checks,
                                         "check every step's energy balance and each body's integrity (false: only the solvers' own checks)");
    scene.health.energy_growth = health.number("energy_growth", scene.health.energy_growth, 0, kInf,
                                               "largest growth of kinetic + gravitational + elastic energy in one step, as a "
                                               "fraction of the run's energy scale (its potential energy above the floor and "
                                               "kinetic energy at the start)");
    scene.health.max_retries = health.integer("max_retries", scene.health.max_retries, 0, 20,
                                              "halvings of dt for a step that fails a check or a solver, before the run stops (exit 3)");
    health.finish();
  }
  scene.cfl = root.number("cfl", 0.5, 0, 1, "CFL number: dt = cfl dx / max(particle speed, sqrt(|g| dx))", true);
  scene.spray_cfl = root.number("spray_cfl", std::max(scene.cfl, std::min(2 * scene.cfl, Real(0.8))), 0, 1,
                                "CFL number of spray: a fluid particle whose cell holds at most half a cell of water "
                                "and solid moves at most spray_cfl cells a step; default twice cfl, at most 0.8, never "
                                "below cfl (spray_cfl = cfl: every particle at cfl)",
                                true);
  scene.dt_min = root.number("dt_min", 1e-7, 0, kInf, "smallest time step (s); a smaller one needed stops the run", true);
  scene.dt_max = root.number("dt_max", 1e-2, 0, kInf, "largest time step (s)", true);
  if (!docs && scene.dt_min > scene.dt_max) throw InputError("scene key 'dt_min': must not exceed dt_max");
  scene.solid_time_integration = root.option<SolidTimeIntegration>(
      "solid_time_integration", scene.solid_time_integration,
      {{"implicit_euler", SolidTimeIntegration::implicit_euler}, {"midpoint", SolidTimeIntegration::midpoint}},
      "time integration of the solids' elasticity: implicit_euler (first order, robust; a vibration loses about "
      "2 pi^2 / N of its amplitude a period at N steps a period) or midpoint (second order, keeps a vibration's "
      "energy; undamped, it needs steps that resolve the solid's motion: at large rotation against a wall at the "
      "CFL step it can create energy, which the health checks stop; docs/method.md#solid-time-integration)");
  scene.solid_step_error = root.number(
      "solid_step_error", 0, 0, 1,
      "largest local error of a solid particle's position a step, relative to its body's largest displacement "
      "since seeding (at least dx / 10), estimated from the change of its acceleration (dt^2 / 12 |a^{n+1} - a^n|, "
      "Zienkiewicz and Xie); the time step follows it, growing at most 2x a step: a time step that resolves the "
      "solids' motion (docs/method.md#solid-time-step). A harmonic vibration about the seeded shape takes about "
      "2 pi / (12 e)^(1/3) steps a period (3.2e-4: 40); the cantilever released from rest, with its higher modes, 49 "
      "at 1e-3. Only with solid_time_integration = midpoint. 0 = not estimated, the solids do not limit dt");
  if (!docs && scene.solid_step_error > 0 && scene.solid_time_integration != SolidTimeIntegration::midpoint)
    throw InputError(fmt::format("scene key 'solid_step_error' = {:g}: the estimate is the midpoint rule's; accepted: 0 "
                                 "with solid_time_integration = implicit_euler, or solid_time_integration = midpoint",
                                 scene.solid_step_error));
  scene.extend_weak_solid_nodes = root.option<bool>(
      "solid_weak_nodes", scene.extend_weak_solid_nodes, {{"extended", true}, {"free", false}},
      "the solids' weak nodes, whose quadratic support holds no cell the solid fills: extended (their velocity the "
      "quadratic extrapolation of the nearest block of inner nodes, extended B-splines; a body across the grid "
      "bends as stiffly as one along it) or free (unknowns of their own: at 2 particles per axis a beam across "
      "the grid is 10-13 % too soft; docs/method.md#weak-solid-nodes)");
  if (!docs && scene.end_time < scene.dt_min)
    throw InputError(fmt::format("scene key 'end_time' = {:g}: shorter than one smallest step (dt_min = {:g} s); accepted: "
                                 "end_time >= dt_min", scene.end_time, scene.dt_min));
  {
    JsonReader walls = root.object("walls", "boundary condition on each domain side (x-, x+, y-, y+, z-, z+)");
    for (int a = 0; a < 3; ++a)
      for (int s = 0; s < 2; ++s) {
        if (a >= dim) continue;
        scene.slip_walls[a][s] = walls.option<bool>(side_name(a, s), true, {{"slip", true}, {"none", false}},
                                                    "slip: free-slip wall (method.md §4); none: no wall, a particle crossing it stops the run");
      }
    walls.finish();
  }
  {
    JsonReader fluid = root.object("fluid", "the incompressible fluid (absent: no fluid)");
    scene.fluid.density = fluid.number("density", 1000, 0, kInf, "fluid density rho_f (kg/m^3)", true);
    scene.fluid.surface_quadrature = fluid.option<SurfaceQuadrature>(
        "surface_quadrature", SurfaceQuadrature::automatic,
        {{"auto", SurfaceQuadrature::automatic}, {"centre", SurfaceQuadrature::centre}, {"particles", SurfaceQuadrature::particles}},
        "quadrature of G^f and M^f in fluid cells next to empty ones: one point at the cell centre weighted by the "
        "particles' volume, or the particles (method.md §4); auto: centre with solids, particles without");
    scene.fluid.wall_constraint = fluid.option<WallConstraint>(
        "wall_constraint", scene.fluid.wall_constraint,
        {{"auto", WallConstraint::automatic}, {"corners", WallConstraint::corners}, {"faces", WallConstraint::faces}},
        "free-slip walls: corners holds the normal velocity of each fluid corner on a wall; faces adds one multiplier "
        "row per wall face (badly conditioned); auto: corners in 3-D, faces in 2-D (docs/method.md#walls-on-corners)");
    scene.fluid.inertia = fluid.option<FluidInertia>(
        "inertia", scene.fluid.inertia,
        {{"auto", FluidInertia::automatic}, {"quadrature", FluidInertia::quadrature}, {"transfer", FluidInertia::transfer}},
        "mass of the fluid corners in the projection: quadrature, M^f of the pressure quadrature; transfer, the mass "
        "the particles carry to a corner (P2G) where it is larger than M^f and every cell of the corner is interior "
        "(no empty neighbour, no borrowed volume), "
        "with gravity still weighted by M^f so that water at rest stays in hydrostatic balance; auto: transfer without "
        "solids, quadrature with them (docs/method.md#fluid-inertia)");
    scene.fluid.initial_velocity = fluid.vector("initial_velocity", std::vector<Real>(dim, 0), dim, "initial velocity of the fluid (m/s)");
    for (auto& shape : fluid.objects("shapes", "regions filled with fluid; a particle is seeded where any shape contains it"))
      scene.fluid.shapes.push_back(read_shape(shape, dim));
    if (docs) {
      Json example = {{"type", "box"}};
      JsonReader shape(example, "fluid.shapes[]", docs);
      read_shape(shape, dim);
    }
    fluid.finish();
  }
  {
    int index = 0;
    for (auto& solid : root.objects("solids", "elastic bodies (absent: no solid); each its own material, outputs and ghost matrix"))
      scene.solids.push_back(read_solid(solid, dim, index++, scene.particles_per_axis));
    if (docs) {
      Json example = {{"type", "box"}};
      JsonReader solid(example, "solids[]", docs);
      read_solid(solid, dim, 0, scene.particles_per_axis);
      JsonReader shape(example, "solids[].shapes[]", docs);
      read_shape(shape, dim);
      JsonReader clamp(example, "solids[].clamps[]", docs);
      read_shape(clamp, dim);
    }
  }
  {
    JsonReader coupling = root.object("coupling", "fluid-solid interface (method.md §3 step 3, §4)");
    auto& c = scene.coupling;
    c.interface = coupling.option<InterfaceConstraint>(
        "interface", c.interface, {{"bilateral", InterfaceConstraint::bilateral}, {"unilateral", InterfaceConstraint::unilateral}},
        "bilateral: normal velocities match everywhere; unilateral: the fluid may leave a solid (active sets, one "
        "pressure solve per round; docs/method.md#unilateral-interface)");
    c.solid_corner_fraction = coupling.number(
        "solid_corner_fraction", c.solid_corner_fraction, 0, 1,
        "a fluid velocity corner whose N1 support is at least this fraction solid moves with the solid; 0 = off, "
        "else above 0.5 (docs/method.md#solid-corners)");
    c.interface_reach = coupling.number(
        "interface_reach", c.interface_reach, 0.5, 0.7,
        "IQ points are the solid particles within this distance (in dx) of a fluid particle (docs/method.md#interface-reach)");
    if (c.solid_corner_fraction > 0 && c.solid_corner_fraction <= 0.5 && !docs)
      throw InputError(fmt::format("scene key 'coupling.solid_corner_fraction' = {}: accepted 0 (off) or above 0.5 up to 1 "
                                   "(at 0.5 or below, corners on a solid's surface would move with it)",
                                   c.solid_corner_fraction));
    coupling.finish();
  }
  {
    JsonReader newton = root.object("newton", "projected Newton of the implicit solid step (method.md §3 step 2)");
    auto& o = scene.newton;
    o.relative_tolerance = newton.number("relative_tolerance", o.relative_tolerance, 0, 1,
                                         "with direct directions: stop when |gradient| <= this x the first gradient norm of the step; "
                                         "with either, a gradient stalled at the round-off floor within 100 times this counts as converged",
                                         true);
    o.cg_relative_tolerance = newton.number(
        "cg_relative_tolerance", o.cg_relative_tolerance, 0, 1,
        "the same stop with CG directions, tighter: a CG step ends just below it where an exact step overshoots "
        "(docs/method.md#solid-step)",
        true);
    o.absolute_tolerance = newton.number("absolute_tolerance", o.absolute_tolerance, 0, 1,
                                         "also stop when |gradient| <= this x |m| (max |v^n| + dx/dt), a momentum scale: "
                                         "a body in free fall has a gradient at the roundoff floor");
    o.max_iterations = newton.integer("max_iterations", o.max_iterations, 1, 10000, "Newton iterations per step; reaching it without convergence stops the run");
    o.cg_max_iterations = newton.integer("cg_max_iterations", o.cg_max_iterations, 1, 1000000, "inner (diagonally preconditioned) CG iterations per Newton iteration");
    o.direction = newton.option<NewtonDirection>(
        "linear_solver", o.direction, {{"auto", NewtonDirection::automatic}, {"direct", NewtonDirection::direct}, {"cg", NewtonDirection::cg}},
        "Newton direction: direct (sparse LDL^T), cg (diagonal PCG on Hessian products), auto = direct in 2-D, cg in 3-D");
    o.project_hessian = newton.boolean("project_hessian", o.project_hessian, "per-particle PSD projection of dP/dF (projected Newton); false: plain Newton with gradient fallback");
    newton.finish();
  }
  {
    JsonReader solver = root.object("solver", "linear solver of the pressure system");
    read_solver_keys(solver, scene.solver, scene.warm_start, docs);
    solver.finish();
  }
  {
    JsonReader experimental = root.object("experimental", "options kept for studies; a validated scene uses one only where docs/method.md#experimental-options says why");
    auto& e = scene.experimental;
    e.position_correction = experimental.number(
        "position_correction", e.position_correction, 0, 1,
        "relaxation of the fluid particle position correction after each step (method.md §3 step 6); 0 = off");
    e.solid_response = experimental.option<SolidResponse>(
        "solid_response", e.solid_response, {{"mass", SolidResponse::mass}, {"stiffness", SolidResponse::stiffness}},
        "the solid in the coupled solve: its lumped mass (method.md §5) or the Newton Hessian M + dt^2 K at v* "
        "(needs solver.method = ldlt, or auto in 2-D)");
    e.max_contact_rounds = experimental.integer(
        "max_contact_rounds", e.max_contact_rounds, 1, 100,
        "unilateral interface: pressure solves per step at most; the last one's solution is kept");
    e.trapped_air = experimental.option<bool>(
        "trapped_air", false, {{"none", false}, {"incompressible", true}},
        "air that the water encloses (a set of empty cells of at least 2^dim cells, apart from the open air at the "
        "top of the domain): none, every empty cell is air at p = 0 and water closing over a cavity falls into it; "
        "incompressible, each pocket gets one uniform pressure that holds the flow into it at zero in each step, "
        "as in the incompressible air of a two-phase solver such as interFoam, but a volume lost as particles "
        "stray into it is not given back (docs/method.md#trapped-air)");
    experimental.finish();
    const bool ldlt = scene.solver.method == LinearSolverMethod::ldlt ||
                      (scene.solver.method == LinearSolverMethod::automatic && dim == 2);
    if (!docs && e.solid_response == SolidResponse::stiffness && !ldlt)
      throw InputError("scene key 'experimental.solid_response' = \"stiffness\": needs the LDL^T pressure solve; accepted "
                       "with solver.method = \"ldlt\", or \"auto\" in 2-D");
    if (!docs && e.solid_response == SolidResponse::stiffness && scene.extend_weak_solid_nodes)
      throw InputError("scene key 'experimental.solid_response' = \"stiffness\": not with solid_weak_nodes = \"extended\" "
                       "(the Hessian in the solve is over every node); accepted: solid_weak_nodes = \"free\" with it");
  }
  for (auto& probe : root.objects("probes", "metrics written to metrics.csv every step"))
    scene.probes.push_back(read_probe(probe, dim, scene.domain_min, scene.domain_max));
  if (docs) {
    Json example = {{"type", "front"}};
    JsonReader probe(example, "probes[]", docs);
    read_probe(probe, dim, scene.domain_min, scene.domain_max);
  }
  root.finish();
  if (!docs) {
    for (std::size_t i = 0; i < scene.probes.size(); ++i)
      for (std::size_t j = 0; j < i; ++j)
        if (scene.probes[i].name == scene.probes[j].name)
          throw InputError(fmt::format("scene key 'probes[{}].name' = \"{}\": already used by probes[{}]", i, scene.probes[i].name, j));
    for (std::size_t i = 0; i < scene.probes.size(); ++i) {
      if (scene.probes[i].solid.empty()) continue;
      bool known = false;
      std::string names;
      for (const auto& solid : scene.solids) {
        known = known || solid.name == scene.probes[i].solid;
        names += (names.empty() ? "" : ", ") + solid.name;
      }
      if (!known)
        throw InputError(fmt::format("scene key 'probes[{}].solid' = \"{}\": no solid of that name; accepted: {}", i,
                                     scene.probes[i].solid, names.empty() ? "(the scene has no solids)" : names));
      if (scene.probes[i].type == ProbeType::solid_angle && dim != 2)
        throw InputError(fmt::format("scene key 'probes[{}].type' = \"solid_angle\": 2-D only", i));
    }
    for (std::size_t i = 0; i < scene.probes.size(); ++i)
      if (scene.probes[i].type == ProbeType::hydrostatic_head &&
          (scene.fluid.shapes.empty() || std::all_of(scene.gravity.begin(), scene.gravity.end(), [](Real g) { return g == 0; })))
        throw InputError(fmt::format("scene key 'probes[{}].type' = \"hydrostatic_head\": needs fluid (fluid.shapes) and gravity", i));
    const bool no_gravity = std::all_of(scene.gravity.begin(), scene.gravity.end(), [](Real g) { return g == 0; });
    for (std::size_t i = 0; i < scene.solids.size(); ++i)
      if (scene.solids[i].initial_pressure == InitialPressure::hydrostatic && (scene.fluid.shapes.empty() || no_gravity))
        throw InputError(fmt::format("scene key 'solids[{}].initial_pressure' = \"hydrostatic\": needs fluid (fluid.shapes) "
                                     "and gravity; accepted without them: \"zero\"", i));
    if (scene.experimental.trapped_air && no_gravity)
      throw InputError("scene key 'experimental.trapped_air' = \"incompressible\": needs gravity (the open air is the top of the domain, "
                       "opposite to gravity); accepted without it: \"none\"");
    if (scene.fluid.shapes.empty() && scene.solids.empty())
      throw InputError("scene key 'fluid.shapes': the scene has no material (give at least one fluid shape or a solid in 'solids')");
    for (std::size_t i = 0; i < scene.solids.size(); ++i)
      for (std::size_t j = 0; j < i; ++j)
        if (scene.solids[i].name == scene.solids[j].name)
          throw InputError(fmt::format("scene key 'solids[{}].name' = \"{}\": already used by solids[{}]", i, scene.solids[i].name, j));
    check_solid_geometry(scene);
  }
  return scene;
}

}  // namespace

SceneSpec read_scene(const Json& document) { return read(document, nullptr); }

SceneSpec load_scene(const std::string& path, const std::vector<std::string>& overrides) {
  std::ifstream in(path);
  if (!in) throw InputError(fmt::format("cannot open scene file '{}'", path));
  std::stringstream buffer;
  buffer << in.rdbuf();
  Json document;
  try {
    document = Json::parse(buffer.str());
  } catch (const Json::exception& e) {  // syntax, or a number beyond double (1e999)
    throw InputError(fmt::format("scene file '{}' is not valid JSON: {}", path, e.what()));
  }
  for (const auto& assignment : overrides) apply_override(document, assignment);
  return read_scene(document);
}

std::vector<KeyDoc> document_scene_keys() {
  std::vector<KeyDoc> docs;
  read(Json::object(), &docs);
  return docs;
}

}  // namespace iqmpm
