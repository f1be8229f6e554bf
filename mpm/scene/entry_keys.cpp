#include "scene/entry_keys.h"

#include <fmt/format.h>
#include <limits>
#include <string>
#include <utility>

#include "core/errors.h"
#include "scene/geometry.h"

namespace iqmpm {
namespace {

constexpr Real kInf = std::numeric_limits<Real>::infinity();

}  // namespace

ShapeSpec read_shape(JsonReader& r, int dim) {
  ShapeSpec s;
  s.type = r.option<ShapeType>("type", std::nullopt, {{"box", ShapeType::box}, {"sphere", ShapeType::sphere}, {"polygon", ShapeType::polygon}}, "shape kind");
  const bool doc = r.documenting();
  if (s.type == ShapeType::box || doc) {
    s.min = r.vector("min", std::nullopt, dim, "box: lower corner (m)");
    s.max = r.vector("max", std::nullopt, dim, "box: upper corner (m)");
    for (int a = 0; a < dim && !doc; ++a)
      if (s.max[a] <= s.min[a])
        throw InputError(fmt::format("scene key '{}.max': must exceed min on every axis (axis {}: {} <= {})",
                                     r.path(), a, s.max[a], s.min[a]));
  }
  if (s.type == ShapeType::sphere || doc) {
    s.centre = r.vector("centre", std::nullopt, dim, "sphere (disk in 2-D): centre (m)");
    s.radius = r.number("radius", std::nullopt, 0, kInf, "sphere: radius (m)", true);
  }
  if (s.type == ShapeType::polygon || doc) {
    if (dim != 2 && !doc) throw InputError(fmt::format("scene key '{}.type' = \"polygon\": polygons are 2-D only", r.path()));
    s.vertices = r.numbers("vertices", std::nullopt, 6, "polygon (2-D): flat list x0, y0, x1, y1, ... (m), at least 3 vertices; a simple polygon (edges meet only at the "
                                                        "vertices they share; docs/method.md#scene-geometry)");
    if (!doc && s.vertices.size() % 2 != 0)
      throw InputError(fmt::format("scene key '{}.vertices': expected an even count (x, y pairs), got {}", r.path(), s.vertices.size()));
    if (!doc) check_simple_polygon(s.vertices, r.path());
  }
  r.finish();
  return s;
}

ProbeSpec read_probe(JsonReader& r, int dim, const std::vector<Real>& domain_min, const std::vector<Real>& domain_max) {
  ProbeSpec p;
  const bool doc = r.documenting();
  const std::vector<std::pair<std::string, ProbeType>> types = {
      {"front", ProbeType::front}, {"water_height", ProbeType::water_height}, {"pressure", ProbeType::pressure},
      {"hydrostatic_head", ProbeType::hydrostatic_head}, {"wall_force", ProbeType::wall_force},
      {"max_speed", ProbeType::max_speed}, {"volume", ProbeType::volume}, {"particle_volume", ProbeType::particle_volume},
      {"hydrostatic_pressure_error", ProbeType::hydrostatic_pressure_error}, {"displacement", ProbeType::displacement},
      {"solid_force", ProbeType::solid_force}, {"solid_com", ProbeType::solid_com},
      {"solid_velocity", ProbeType::solid_velocity}, {"solid_angle", ProbeType::solid_angle}};
  p.type = r.option<ProbeType>("type", std::nullopt, types, "what the probe measures (a metrics.csv column per probe)");
  std::string default_name;
  for (const auto& [name, type] : types)
    if (type == p.type) default_name = name;
  switch (p.type) {
    case ProbeType::front: default_name = "front_x"; break;
    case ProbeType::water_height: default_name = "height_left"; break;
    case ProbeType::pressure: default_name = "pressure_right"; break;
    case ProbeType::wall_force: default_name = "wall_force_x"; break;
    case ProbeType::hydrostatic_pressure_error: default_name = "pressure_l2_error"; break;
    default: break;
  }
  p.name = r.text("name", default_name, "column name in metrics.csv (benchmarks.md names)");
  if (p.name.empty() || p.name == "t") throw InputError(fmt::format("scene key '{}.name': must be non-empty and not 't'", r.path()));
  if (p.type == ProbeType::front || doc) {
    p.axis = r.integer("axis", 0, 0, dim - 1, "front: axis along which the front travels (largest coordinate reported); displacement: the component reported (0 = x)");
    p.band = r.number("below", -1, -1, kInf, "front: only fluid particles lower than this height (m) count; -1 = one cell above the floor");
  }
  if (p.type == ProbeType::water_height || doc) {
    p.position = r.number("position", std::nullopt, -kInf, kInf, "water_height: first-axis coordinate of the gauge (m)");
    p.band = r.number("half_width", -1, -1, kInf, "water_height: particles within this distance of the gauge count (m); -1 = one cell. "
                      "The height is the top of the column connected to the floor (3-D: the mean over a row of columns)");
    p.position_to = r.number("to", kNoRange, -kInf, kInf,
                             "water_height: when given, the mean of gauges every dx from position to this coordinate");
    if (!doc && p.position_to != kNoRange && p.position_to < p.position)
      throw InputError(fmt::format("scene key '{}.to': must not be below position ({} m)", r.path(), p.position));
  }
  const bool of_solid = p.type == ProbeType::solid_force || p.type == ProbeType::solid_com ||
                        p.type == ProbeType::solid_velocity || p.type == ProbeType::solid_angle;
  if ((p.type == ProbeType::displacement || (of_solid && p.type != ProbeType::solid_angle)) && !doc)
    p.axis = r.integer("axis", 0, 0, dim - 1, "");
  if (of_solid || doc)
    p.solid = r.text("solid", std::nullopt,
                     "solid_force / solid_com / solid_velocity / solid_angle: the body (solids[].name); force of the fluid "
                     "on it (N/m in 2-D), centre of mass (m), mean velocity (m/s) along axis, or 2-D rotation (rad)");
  if (p.type == ProbeType::solid_angle || doc)
    p.initial_angle = r.number("initial_angle", 0, -kInf, kInf,
                               "solid_angle: the body's orientation at t = 0 (rad, counter-clockwise), added to its rotation");
  if (p.type == ProbeType::solid_force || doc) {
    for (auto& shape : r.objects("region", "solid_force: count only the material of the body that starts inside these "
                                           "shapes (method.md §7); omitted: the whole body"))
      p.region.push_back(read_shape(shape, dim));
    if (doc) {
      Json example = {{"type", "box"}};
      JsonReader shape(example, "probes[].region[]", r.docs());
      read_shape(shape, dim);
    }
  }
  if (p.type == ProbeType::pressure || p.type == ProbeType::hydrostatic_head || p.type == ProbeType::displacement || doc)
    p.point = r.vector("point", std::nullopt, dim,
                       "pressure: mean of the 2^dim dual cells nearest the point (Pa); hydrostatic_head: p / (rho_f |g|) + "
                       "height over those cells that hold water (m); displacement: a material point within dx of a solid (m)");
  if (p.type == ProbeType::pressure || doc)
    p.sensor = r.number("sensor", 0, 0, kInf,
                        "pressure: side of the sensor (m), a box around the point clipped to the domain: the mean over it of "
                        "the pressure interpolated (multilinear) between dual-cell centres, the same footprint at every dx; "
                        "0 = the mean of the 2^dim nearest dual cells (a footprint of about 2 dx)");
  if (p.type == ProbeType::wall_force || doc) {
    std::vector<std::string> sides;
    for (int a = 0; a < dim; ++a) sides.insert(sides.end(), {side_name(a, 0), side_name(a, 1)});
    const std::string wall = r.choice("wall", std::nullopt, sides, "wall_force: which domain wall; the force of the fluid on it along its axis (N/m in 2-D, N in 3-D)");
    for (int a = 0; a < dim; ++a)
      for (int s = 0; s < 2; ++s)
        if (wall == side_name(a, s)) p.wall_axis = a, p.wall_side = s;
  }
  if (p.type == ProbeType::hydrostatic_pressure_error || doc)
    p.surface = r.number("surface", std::nullopt, -kInf, kInf, "hydrostatic_pressure_error: still-water level H (m); relative L2 error of p vs rho g (H - y) over the fluid cells");
  if (!doc && (p.type == ProbeType::pressure || p.type == ProbeType::hydrostatic_head || p.type == ProbeType::displacement))
    for (int a = 0; a < dim; ++a)
      if (p.point[a] < domain_min[a] || p.point[a] > domain_max[a])
        throw InputError(fmt::format("scene key '{}.point': outside the domain on axis {}", r.path(), a));
  r.finish();
  return p;
}

SolidSpec read_solid(JsonReader& r, int dim, int index, int scene_particles_per_axis) {
  SolidSpec s;
  const bool doc = r.documenting();
  s.name = r.text("name", "solid" + std::to_string(index), "name of the body (logs, outputs); default solid<index>");
  s.model = r.option<SolidModel>("model", s.model, {{"fixed_corotated", SolidModel::fixed_corotated}, {"neo_hookean", SolidModel::neo_hookean}},
                                 "hyperelastic model (method.md §1)");
  s.density = r.number("density", s.density, 0, kInf, "solid density rho_s (kg/m^3)", true);
  // Elastic constants: either (youngs_modulus, poisson_ratio) or (mu, lambda).
  const bool young = r.has("youngs_modulus") || r.has("poisson_ratio");
  const bool lame = r.has("mu") || r.has("lambda");
  if (!doc && young == lame)
    throw InputError(fmt::format("scene key '{}': give the elasticity as either youngs_modulus and poisson_ratio, or mu and lambda (exactly one pair)", r.path()));
  if (young || doc) {
    const Real E = r.number("youngs_modulus", std::nullopt, 0, kInf, "Young's modulus E (Pa); with poisson_ratio (or give mu and lambda instead). 2-D is plane strain", true);
    const Real nu = r.number("poisson_ratio", std::nullopt, -1, 0.5, "Poisson ratio nu", true, true);
    s.mu = E / (2 * (1 + nu));
    s.lambda = E * nu / ((1 + nu) * (1 - 2 * nu));
  }
  if (lame || doc) {
    s.mu = r.number("mu", std::nullopt, 0, kInf, "shear modulus mu (Pa); with lambda (or give youngs_modulus and poisson_ratio instead)", true);
    s.lambda = r.number("lambda", std::nullopt, 0, kInf, "first Lame parameter lambda (Pa)");
  }
  s.ghost_stiffness = r.number("ghost_stiffness", s.ghost_stiffness, 0, kInf,
                               "lambda_g (Pa), stiffness of the air-like ghost matrix carried by the solid (method.md §1, §9)", true);
  s.initial_pressure = r.option<InitialPressure>(
      "initial_pressure", s.initial_pressure, {{"zero", InitialPressure::zero}, {"hydrostatic", InitialPressure::hydrostatic}},
      "the ghost matrix's starting pressure: zero, or the still water's, for a body at rest in still water wetted all "
      "round below the water line (docs/method.md#hydrostatic-start)");
  s.particles_per_axis = r.integer(
      "particles_per_axis", scene_particles_per_axis, 1, 8,
      "particles per cell along each axis in this body; default: the scene's particles_per_axis (a body resolved "
      "finer than the water without multiplying the water's particles; docs/method.md#solid-particles)");
  s.initial_velocity = r.vector("initial_velocity", std::vector<Real>(dim, 0), dim, "initial velocity of the body (m/s)");
  for (auto& shape : r.objects("shapes", "regions the body fills; a particle is seeded where any shape contains it. Bodies "
                                         "must not share space (error); a shape reaching past the domain is clipped to it "
                                         "(warning; docs/method.md#scene-geometry)"))
    s.shapes.push_back(read_shape(shape, dim));
  for (auto& shape : r.objects("clamps", "regions held fixed: every velocity node whose dual-cell centre lies in a region or "
                                         "within dx/2 of it along an axis has zero velocity"))
    s.clamps.push_back(read_shape(shape, dim));
  r.also_accepts({"youngs_modulus", "poisson_ratio", "mu", "lambda"});
  r.finish();
  if (!doc && s.shapes.empty())
    throw InputError(fmt::format("scene key '{}.shapes': a solid needs at least one shape", r.path()));
  return s;
}

}  // namespace iqmpm
