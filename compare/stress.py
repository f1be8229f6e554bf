"""``compare stress``: the stability map of issue 24 (item 4).

One command runs a grid of short runs -- CFL x dt_max x rho_s/rho_f x E x two resolutions
on the floating block, the elastic gate and the dam break (which has no solid: only CFL x
dt_max x resolution) -- and sorts every cell into one class:

* **stable** (*stable and plausible*): ``status: ok``, exit 0, every physics check below
  passes, no step retried;
* **stopped** (*stopped with a diagnosis*): the solver refused the input (exit 2, e.g.
  ``cfl > 1``, which the solver's ``keys`` list refuses today) or stopped the run (exit 3)
  and said why: the message (its log's last line, or ``summary.json``'s status) is the
  reason;
* **adapted**: ``status: ok``, the checks pass, and ``summary.json`` reports
  ``dt_retries > 0`` (steps the solver's health checks retried with a smaller dt; read with
  a default of 0, since older binaries do not write it);
* **wrong**: ``status: ok`` but a physics check fails: the silent wrong answer that issue
  24 wants gone;
* **no result**: a crash (any other exit code), an interrupt or a timeout: no diagnosis.
  Not one of the issue's four classes, but a crash is neither a diagnosis nor a result,
  so it is shown rather than folded into one of them.

Why physics checks of our own: the point is to catch what the solver's own checks miss,
so every check here is computed from the outputs (``metrics.csv``, ``summary.json``, the
first and last particle frames) and from the scene as run (``summary.json`` ``scene``,
after ``--set``), never from the solver's verdicts. The thresholds, and why:

* **volume** (every scene): the area (volume in 3-D) of the bins of size dx (the grid
  spacing, from ``domain.min``) that hold at least one fluid particle, last frame against
  first: ``|drift|`` below a bound per scene, a few times the drift of the validated
  default run over the same time so that only a gross loss is *wrong*: floating block 3 %
  (default run +0.53 % at 0.5 s; +0.65 % at the coarse dx), elastic gate 10 % (+1.70 % at
  0.12 s; +2.68 % coarse), dam break 10 % (-3.47 % at 0.3 s; -3.13 % coarse: the particles
  crowd in the surge, up to 15 in a bin at 0.3 s for 4 at the start). Measured with
  ``fluid_bin_volume`` on the scene files as they are, end time and ``frame_rate 0`` set
  (2026-12-02). 58 cells of the grid sampled around the wrong ones of the 8d97ea2 map
  (the 39 of them that ran to the end) stayed within -3.0..-6.1 % (dam break; -6.1 % at
  CFL 1, dt_max 1e-2), -0.2..+1.6 % (floating block), +0.1..+2.5 % (gate). What it
  sees: a bin counts whole as soon as it holds one particle, so particles moving within
  their bins change nothing, water squeezed into fewer bins (compressed) or
  gone (lost) counts less, and a bin cut by the free surface or holding a splashing sheet
  counts whole, so spray and thin sheets raise the measure: the check guards against lost
  or compressed water; a gain within the bound is the surface's and the splashes' bins
  (beyond it: water spread into many more bins than it filled, also not physical).
  Why not the solver's own ``volume_drift`` (a region measure on the grid): the map does
  not trust the solver's measures, and that one counts the cells next to a solid short:
  on the heavy soft block (rho_s 10000, E 1e4, dx 0.02, CFL 1, dt_max 1e-2, 0.5 s) it fell
  5.1-5.8 % while the water's bins went 0.4960 -> 0.4952 m^2 (-0.16 %; 0.4976 in the map run). The check's detail
  shows it, as information only.
* **energy** (every scene): kinetic energy of the last frame <= kinetic + potential
  energy released since the first frame, + 0.5 % of the first frame's potential energy
  above the floor. Elastic energy and dissipation are >= 0 and the walls and clamps do no
  work, so any physical run satisfies it; the 0.5 % covers the ghost matrix's small
  starting energy and particle masses taken as rho (dx/ppa)^dim (the frames carry none).
  Energy created beyond it is a numerical source, not physics.
* **integrity** (each solid): the solid's particles in the last frame form one cluster
  when particles closer than 3 particle spacings (dx / particles_per_axis) are linked. A
  hyperelastic body does not fracture; a gap of 3 spacings is a stretch of 3 between
  neighbours, far past anything these loads make, so a second cluster is a torn body.
* **Archimedes** (floating block, rigid-body reading of ``com_y`` and ``water_level``;
  draft = water level - (com_y - h/2), h the block's height): rho_s < rho_f: the mean
  draft over the second half of the run lies within ``|d0 - d_eq| + dx`` of
  d_eq = (rho_s/rho_f) h (d0 the initial draft: without an energy source the heave
  amplitude cannot exceed the initial offset; dx for the probes' resolution);
  rho_s = rho_f: the mean draft over the second half is at least half-way from d0 to h,
  less dx (a neutral body that starts above the water sinks until submerged, about a
  quarter heave period, 0.2 s, and has no force to lift it again); rho_s > rho_f: it
  sinks: the final centre is at least h below the start (a free fall in water covers that
  in about 0.2 s) and the body is not below the floor by more than dx.
* **gate** (elastic gate, at the end of the run, quasi-static): the water height behind
  the gate H, from the last frame's particles and the gate where it is now, not where it
  started: the gate's particles are binned by height in bands of one particle spacing
  (dx / particles_per_axis) from the floor, and per band the least x of its particles is
  the gate's position there (a band without gate particles: interpolated between its
  neighbours); a fluid particle is upstream when it lies left of that position in its band
  (below the gate's lowest band: of the lowest band; above its top band: of the top band),
  and H is the level to which the upstream particles' area (count x spacing^2) fills the
  region from the left wall to the gate's upstream face (per band its least x less half a
  spacing): area = sum over the bands below H of (face - x_min) x band height,
  interpolated within the band where H ends. (The initial face and width hold for a gate
  that has not moved: a gate swinging back into the water puts its own material left of
  its initial face, which then reads as missing water: 0.127 m for 0.130 m in the test.
  A gate bent downstream with still water gives the same H either way: the water's level
  is the same left and right of the initial face.) H loads the free part (length L, clamp to floor) with the hydrostatic
  force F_h = rho_f g int_0^L (H - y)+ dy and would bend a linear cantilever (plane
  strain E' = E / (1 - nu^2), I = t^3/12) to w_lin = int q(s) s^2 (3L - s) ds / (6 E' I).
  The means over the last 20 % of the run of ``gate_force_x`` and ``gate_tip_dx`` must
  satisfy: force <= 2 F_h0 always, F_h0 the load of the first frame's level H0 (water
  released at rest is a step load, and the level behind the gate only falls, so F_h0 is
  the largest static load of the run; on a linear elastic gate of mass m_g with the
  water's added mass m_a, x = x_s (1 - cos wt) and the interface force m_g x'' + k x =
  F_h0 (1 - m_a / (m_a + m_g) cos wt) never exceeds 2 F_h0. A heavy gate swinging back
  into the water pushes on it, so the bound is not one on the current level's F_h: the
  heavy soft gate (rho_s 10 000, E 1 MPa) reads 137-150 N/m at the end with H 0.128 m,
  F_h 68.5 and F_h0 77.9 N/m, the water's x momentum reversing from +0.65 to -0.73 N s/m
  between 0.09 and 0.12 s); while the gate holds the water (w_lin <= L/2, where the
  linear theory holds) force >= 0.5 F_h and 0.25 w_lin - 0.1 dx <= tip <= 3 w_lin +
  0.1 dx (a suddenly applied load overshoots the static deflection by at most 2; the
  default run sits at force 0.9 F_h and tip 1.1-1.3 w_lin from 0.08 s on; a gate that
  stays shut under its load -- issue 24: dt_max 1e-3, tip 2.3 mm for 37 mm, force 8 for
  75 N/m -- fails both); a soft gate (w_lin > L/2) must be open: L/8 <= tip <= 1.5 L.
  Skipped when less than L/4 of water is left behind it (not loaded).
* **front** (dam break): the surge front never outruns Ritter's ideal dry-bed front,
  ``front_x - a <= 2 sqrt(g H0) t + 2 dx`` (a, H0 the column's width and height; the
  upper bound of an inviscid collapse), and by the end it has moved at least a quarter
  of ``min(2 sqrt(g H0) T, tank length - a)`` (a column that does not collapse).

Outputs under ``--out``: ``stress_map.md`` and ``stress_map.csv`` (every cell: its
parameters, class, reason and check values), ``<scene>_map.png`` (heat map: E across,
rho_s/rho_f up, one panel per CFL, dt_max and resolution; colour per class), and the run
folders ``runs/<scene>/<cell>/``. Exit status 0 when no cell is *wrong* or *no result*,
1 otherwise, 2 for bad input.
"""

from __future__ import annotations

import argparse
import csv
import itertools
import json
import math
import re
import shutil
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from compare.io import (REPO_ROOT, RUN_RECORD, CompareError, Metrics, read_frame_times,
                        read_metrics, read_particle_frame, read_summary)

STABLE, STOPPED, ADAPTED, WRONG, NO_RESULT = "stable", "stopped", "adapted", "wrong", "no result"
CLASSES = (STABLE, ADAPTED, STOPPED, WRONG, NO_RESULT)
CLASS_LABELS = {STABLE: "stable and plausible", ADAPTED: "adapted (dt retried)",
                STOPPED: "stopped with a diagnosis", WRONG: "wrong (a physics check failed)",
                NO_RESULT: "no result (crash, interrupt, timeout)"}
CLASS_MARKS = {STABLE: "S", ADAPTED: "A", STOPPED: "D", WRONG: "W", NO_RESULT: "N"}  # heat map
CLASS_COLOURS = {STABLE: "#4daf4a", ADAPTED: "#377eb8", STOPPED: "#ffbf00", WRONG: "#e41a1c",
                 NO_RESULT: "#6a3d9a"}

VOLUME_BOUND = {"floating_block": 0.03, "elastic_gate": 0.10, "dam_break": 0.10}  # |drift| of fluid bins
ENERGY_TOLERANCE = 0.005  # of the first frame's potential energy above the floor
INTEGRITY_LINK = 3.0  # particle spacings
FIRST_FRAME, LAST_FRAME = 0, -1


# --------------------------------------------------------------------------- the grid


@dataclass(frozen=True)
class Resolution:
    label: str
    dx: float  # m
    seconds_per_step: float  # measured, one thread (benchmarks/stress/README.md): the ETA


@dataclass(frozen=True)
class StressScene:
    """A scene of the map: its file, the short end time and the two cell sizes run."""

    name: str
    path: str  # relative to the repository root
    end_time: float  # s
    resolutions: tuple[Resolution, ...]
    has_solid: bool
    typical_speed: float  # m/s, for the CFL step in the cost estimate

    def resolution(self, label: str) -> Resolution:
        return next(r for r in self.resolutions if r.label == label)


# End times: long enough for each check to mean something, short enough for the default
# grid to fit in 30 minutes on 2 cores (benchmarks/stress/README.md has the measurements):
# the block gets 0.6 of a heave period (0.8 s) and a heavy block 2x the time it needs to
# sink its height; the gate reaches its quasi-static balance from 0.08 s on; the dam
# break's front reaches the far wall at 0.27 s. Resolutions: the benchmark's dx and twice it.
SCENES: dict[str, StressScene] = {
    "floating_block": StressScene(
        "floating_block", "benchmarks/floating_block/floating_block.json", 0.5,
        (Resolution("coarse", 0.02, 0.0104), Resolution("default", 0.01, 0.055)), True, 1.0),
    "elastic_gate": StressScene(
        "elastic_gate", "benchmarks/elastic_gate/elastic_gate.json", 0.12,
        (Resolution("coarse", 0.005, 0.0106), Resolution("default", 0.0025, 0.05)), True, 1.5),
    "dam_break": StressScene(
        "dam_break", "benchmarks/dam_break/dam_break.json", 0.3,
        (Resolution("coarse", 0.009125, 0.0035), Resolution("default", 0.0045625, 0.0127)),
        False, 2.5),
}


@dataclass(frozen=True)
class Grid:
    cfl: tuple[float, ...]
    dt_max: tuple[float, ...]  # s
    density_ratio: tuple[float, ...]  # rho_s / rho_f
    youngs_modulus: tuple[float, ...]  # Pa
    resolutions: tuple[str, ...]  # labels of StressScene.resolutions


# dt_max: 1e-2 s is the solver's default, where the CFL number governs the step; 1e-3 s is
# the floating block's own value and ten times the gate's validated 1e-4 s, where issue 24
# found the gate silently wrong. A third value (1e-4) would double the cost for cells
# where dt_max, not CFL, sets the step, and the gate's default run already covers it.
DEFAULT_GRID = Grid(cfl=(0.2, 0.5, 1.0, 2.0), dt_max=(1e-3, 1e-2), density_ratio=(0.1, 1.0, 10.0),
                    youngs_modulus=(1e4, 1e6, 1e8, 1e10), resolutions=("coarse", "default"))
# Two cells per scene at the coarse resolution: one that runs, one the solver refuses.
QUICK_GRID = Grid(cfl=(0.5, 2.0), dt_max=(1e-2,), density_ratio=(10.0,), youngs_modulus=(1e6,),
                  resolutions=("coarse",))


@dataclass(frozen=True)
class Cell:
    scene: str
    cfl: float
    dt_max: float
    resolution: str
    dx: float
    end_time: float
    density_ratio: float | None = None  # None: the scene has no solid
    youngs_modulus: float | None = None

    @property
    def name(self) -> str:
        """Folder name: every parameter, e.g. cfl0.5_dt0.01_coarse_rho10_E1e+06."""
        text = f"cfl{self.cfl:g}_dt{self.dt_max:g}_{self.resolution}"
        if self.density_ratio is not None:
            text += f"_rho{self.density_ratio:g}_E{self.youngs_modulus:g}"
        return text

    def sets(self, fluid_density: float) -> list[str]:
        """The ``--set`` overrides of this cell. frame_rate 0: the first and last frames
        only, which is all the checks read."""
        values = [f"cfl={self.cfl:g}", f"dt_max={self.dt_max:g}", f"dx={self.dx:.10g}",
                  f"end_time={self.end_time:g}", "frame_rate=0"]
        if self.density_ratio is not None:
            values += [f"solids.0.density={self.density_ratio * fluid_density:g}",
                       f"solids.0.youngs_modulus={self.youngs_modulus:g}"]
        return [a for v in values for a in ("--set", v)]

    def cost(self) -> float:
        """Estimated seconds on one thread: steps at the CFL step of the scene's typical
        speed (or dt_max) times the measured seconds per step. It orders the runs (longest
        first) and gives the ETA; a cell the solver refuses (cfl > 1) costs nothing."""
        if self.cfl > 1.0:
            return 0.0
        scene = SCENES[self.scene]
        speed = max(scene.typical_speed, math.sqrt(9.81 * self.dx))
        dt = min(self.dt_max, self.cfl * self.dx / speed)
        return self.end_time / dt * scene.resolution(self.resolution).seconds_per_step


def expand_grid(grid: Grid, scene_names: Sequence[str]) -> list[Cell]:
    """Every cell of ``grid`` on each scene; a scene without a solid has no rho or E axis."""
    cells = []
    for name in scene_names:
        scene = SCENES[name]
        solid_axes = (list(itertools.product(grid.density_ratio, grid.youngs_modulus))
                      if scene.has_solid else [(None, None)])
        for cfl, dt_max, res in itertools.product(grid.cfl, grid.dt_max, grid.resolutions):
            for ratio, youngs in solid_axes:
                cells.append(Cell(name, cfl, dt_max, res, scene.resolution(res).dx,
                                  scene.end_time, ratio, youngs))
    return cells


# --------------------------------------------------------------------------- physics checks


@dataclass
class Check:
    name: str
    ok: bool
    detail: str


@dataclass
class SceneFacts:
    """What the checks need from the scene as run (``summary.json`` ``scene``)."""

    scene: dict[str, Any]
    dim: int
    dx: float
    particle_spacing: float
    gravity: np.ndarray
    fluid_density: float

    @classmethod
    def of(cls, scene: dict[str, Any]) -> "SceneFacts":
        dim = int(scene.get("dim", 2))
        dx = float(scene["dx"])
        gravity = np.array(scene.get("gravity", [0.0, -9.81] if dim == 2 else [0.0, -9.81, 0.0]),
                           dtype=float)
        fluid = scene.get("fluid") or {}
        return cls(scene, dim, dx, dx / int(scene.get("particles_per_axis", 2)), gravity,
                   float(fluid.get("density", 1000.0)))

    def solid(self, index: int = 0) -> dict[str, Any]:
        return self.scene["solids"][index]

    def density_of(self, material: np.ndarray) -> np.ndarray:
        """Material id -> density (0 fluid, 1 + i solid i)."""
        table = [self.fluid_density] + [float(s.get("density", 1000.0))
                                        for s in self.scene.get("solids", [])]
        return np.asarray(table)[material]


def _box(shape: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    return np.asarray(shape["min"], dtype=float), np.asarray(shape["max"], dtype=float)


def _tail_mean(metrics: Metrics, name: str, fraction: float) -> float:
    """Mean of a column over the last ``fraction`` of the run."""
    t = metrics.t
    keep = t >= t[-1] - fraction * (t[-1] - t[0])
    return float(np.nanmean(metrics.column(name)[keep]))


def fluid_bin_volume(frame, facts: SceneFacts) -> float:
    """Area (volume in 3-D) of the bins of size dx (``facts.dx``, the grid spacing; from
    ``domain.min``) that hold at least one fluid particle (material 0) of ``frame``.

    Independent of the solver's own measures. A bin counts whole as soon as it holds one
    particle, so moving particles within their bins changes nothing, while water squeezed
    into fewer bins (compressed) or gone (lost) counts less; a bin cut by a free surface
    or holding a splashing sheet counts whole too, so spray and thin sheets raise it."""
    points = frame.points[frame.material == 0, :facts.dim]
    if len(points) == 0:
        return 0.0
    origin = np.asarray(facts.scene["domain"]["min"], dtype=float)[:facts.dim]
    bins = np.floor((points - origin) / facts.dx).astype(np.int64)
    return len(np.unique(bins, axis=0)) * facts.dx ** facts.dim


def check_volume(first, last, facts: SceneFacts, kind: str,
                 summary: dict[str, Any] | None = None) -> Check:
    """Fluid volume of the last frame against the first (``fluid_bin_volume``), relative
    drift within the scene's bound (module docstring). The solver's own ``volume_drift``
    is shown in the detail, as information only."""
    bound = VOLUME_BOUND.get(kind, 0.05)
    v0, v1 = fluid_bin_volume(first, facts), fluid_bin_volume(last, facts)
    solver = (summary or {}).get("volume_drift")
    info = (f"; solver's volume_drift {solver:+.2%}, not checked"
            if isinstance(solver, (int, float)) and math.isfinite(solver) else "")
    if not v0 > 0:
        return Check("volume", False, f"no fluid particle in the first frame{info}")
    drift = (v1 - v0) / v0
    return Check("volume", abs(drift) <= bound,
                 f"fluid bins {v0:.5g} -> {v1:.5g}: drift {drift:+.2%} (bound {bound:.0%}){info}")


def check_energy(first, last, facts: SceneFacts) -> Check:
    """Kinetic energy of the last frame against the energy released since the first."""
    def energies(frame):
        mass = facts.density_of(frame.material) * facts.particle_spacing ** facts.dim
        x = frame.points[:, :facts.dim]
        kinetic = 0.5 * float(np.sum(mass * np.sum(frame.velocity[:, :facts.dim] ** 2, axis=1)))
        potential = -float(np.sum(mass * (x @ facts.gravity)))
        return kinetic, potential, mass, x

    k0, p0, mass0, x0 = energies(first)
    k1, p1, _, _ = energies(last)
    up = -facts.gravity / np.linalg.norm(facts.gravity)
    floor = min(float(np.dot(np.asarray(facts.scene["domain"]["min"], dtype=float), up)),
                float(np.dot(np.asarray(facts.scene["domain"]["max"], dtype=float), up)))
    above_floor = float(np.sum(mass0 * np.linalg.norm(facts.gravity) * (x0 @ up - floor)))
    available = k0 + (p0 - p1)
    tolerance = ENERGY_TOLERANCE * above_floor
    ok = math.isfinite(k1) and k1 <= available + tolerance
    return Check("energy", ok, f"kinetic {k1:.4g} J vs released {available:.4g} J "
                               f"(+ tolerance {tolerance:.3g} J)")


def check_integrity(last, facts: SceneFacts) -> list[Check]:
    """Each solid's particles in the last frame form one cluster (links < 3 spacings)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    checks = []
    link = INTEGRITY_LINK * facts.particle_spacing
    for index, solid in enumerate(facts.scene.get("solids", [])):
        name = f"integrity {solid.get('name', f'solid{index}')}"
        points = last.points[last.material == index + 1, :facts.dim]
        if len(points) == 0:
            checks.append(Check(name, False, "no particle of this solid in the last frame"))
            continue
        pairs = cKDTree(points).query_pairs(link, output_type="ndarray")
        graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                           shape=(len(points), len(points)))
        count, labels = connected_components(graph, directed=False)
        if count == 1:
            checks.append(Check(name, True, f"one piece ({len(points)} particles)"))
            continue
        largest = np.bincount(labels).argmax()
        gap, _ = cKDTree(points[labels == largest]).query(points[labels != largest])
        checks.append(Check(name, False, f"{count} pieces; the nearest is {gap.min():.3g} m "
                                         f"from the largest (link {link:.3g} m)"))
    return checks


def check_archimedes(metrics: Metrics, facts: SceneFacts) -> Check:
    """Floating block: draft against Archimedes (see the module docstring)."""
    solid = facts.solid()
    lo, hi = _box(solid["shapes"][0])
    height = float(hi[1] - lo[1])
    ratio = float(solid.get("density", 1000.0)) / facts.fluid_density
    com_y = metrics.column("com_y")
    draft = metrics.column("water_level") - (com_y - height / 2)
    second_half = metrics.t >= metrics.t[0] + 0.5 * (metrics.t[-1] - metrics.t[0])
    mean_draft = float(np.nanmean(draft[second_half]))
    d0 = float(draft[0])
    if ratio < 1.0:
        d_eq = ratio * height
        bound = abs(d0 - d_eq) + facts.dx
        return Check("Archimedes", abs(mean_draft - d_eq) <= bound,
                     f"floats: mean draft {mean_draft:.4f} m vs {d_eq:.4f} m (within {bound:.4f})")
    if math.isclose(ratio, 1.0):
        least = d0 + 0.5 * (height - d0) - facts.dx
        return Check("Archimedes", mean_draft >= least,
                     f"neutral: mean draft {mean_draft:.4f} m (at least {least:.4f}, h {height:g})")
    sunk = float(com_y[0] - com_y[-1])
    floor = float(facts.scene["domain"]["min"][1])
    least = min(height, float(com_y[0]) - height / 2 - floor - facts.dx)  # or on the floor
    return Check("Archimedes", sunk >= least, f"sinks: centre {sunk:.4f} m lower than at the "
                                              f"start (at least {least:.4f})")


def _cantilever(facts: SceneFacts) -> dict[str, float]:
    solid = facts.solid()
    lo, hi = _box(solid["shapes"][0])
    clamp_lo, _ = _box(solid["clamps"][0])
    return {"x_face": float(lo[0]), "floor": float(lo[1]), "length": float(clamp_lo[1] - lo[1]),
            "thickness": float(hi[0] - lo[0]), "E": float(solid["youngs_modulus"]),
            "nu": float(solid["poisson_ratio"])}


def hydrostatic_gate_load(water_height: float, gate: dict[str, float], rho: float,
                          g: float) -> tuple[float, float]:
    """(force on the free part, linear tip deflection) under still water of this height.

    s runs from the clamp (s = 0) to the tip (s = L); the depth at s is H - (L - s).
    """
    length = gate["length"]
    s = np.linspace(0.0, length, 801)
    q = rho * g * np.clip(water_height - (length - s), 0.0, None)
    force = float(np.trapz(q, s))
    stiffness = gate["E"] / (1 - gate["nu"] ** 2) * gate["thickness"] ** 3 / 12
    tip = float(np.trapz(q * s ** 2 * (3 * length - s), s) / (6 * stiffness))
    return force, tip


def gate_band_faces(last, facts: SceneFacts) -> tuple[float, np.ndarray]:
    """The gate's current position per height band: (floor, x of each band).

    The gate's particles (solid 0) are binned by y in bands of one particle spacing from
    the floor (``domain.min`` y); per band the least x of its gate particles (the centres
    of the upstream layer). Bands between the lowest and the top band that hold no gate
    particle take the value interpolated between their neighbours; bands below the
    lowest take the lowest band's, bands above the top the top band's."""
    spacing = facts.particle_spacing
    floor = float(facts.scene["domain"]["min"][1])
    gate = last.points[last.material == 1, :2]
    if len(gate) == 0:
        raise CompareError("no particle of the gate in the last frame")
    band = np.maximum(np.floor((gate[:, 1] - floor) / spacing).astype(int), 0)  # below: 0
    least = np.full(band.max() + 1, np.inf)
    np.minimum.at(least, band, gate[:, 0])
    held = np.flatnonzero(np.isfinite(least))
    faces = np.interp(np.arange(len(least)), held, least[held])
    return floor, faces


def upstream_water_height(last, facts: SceneFacts) -> tuple[float, int]:
    """(H, number of upstream fluid particles): the level of the water behind the gate
    in its current, possibly bent, position (module docstring, gate).

    A fluid particle is upstream when it lies left of the gate's particles of its height
    band (below the gate's lowest band: of the lowest band; above its top: of the top
    band). H is the level to which their area (count x spacing^2) fills the region between
    the left wall and the gate's current upstream face, per band the band's least gate x
    less half a spacing: area = sum over the bands below H of (face - x_min) x spacing,
    interpolated within the band that H ends in (above the gate's top band: that band's
    width)."""
    spacing = facts.particle_spacing
    x_min = float(facts.scene["domain"]["min"][0])
    floor, faces = gate_band_faces(last, facts)
    fluid = last.points[last.material == 0, :2]
    band = np.clip(np.floor((fluid[:, 1] - floor) / spacing).astype(int), 0, len(faces) - 1)
    count = int(np.count_nonzero(fluid[:, 0] < faces[band]))
    area = count * spacing ** 2
    widths = np.clip(faces - 0.5 * spacing - x_min, 0.0, None)
    filled = np.concatenate([[0.0], np.cumsum(widths * spacing)])  # area below band k
    k = int(np.searchsorted(filled, area, side="right")) - 1  # the band H ends in
    if k >= len(widths):  # above the gate's top band: at its width
        return floor + len(widths) * spacing + (area - filled[-1]) / max(widths[-1], 1e-300), count
    return floor + k * spacing + (area - filled[k]) / max(widths[k], 1e-300), count


def check_gate(metrics: Metrics, first, last, facts: SceneFacts) -> list[Check]:
    """Elastic gate: force and tip against the water still behind it (module docstring)."""
    gate = _cantilever(facts)
    length, dx = gate["length"], facts.dx
    water_height, _ = upstream_water_height(last, facts)
    if water_height < length / 4:
        return [Check("gate", True, f"not loaded: {water_height:.3f} m of water behind it")]
    g = float(np.linalg.norm(facts.gravity))
    force_h, tip_lin = hydrostatic_gate_load(water_height, gate, facts.fluid_density, g)
    force_h0, _ = hydrostatic_gate_load(upstream_water_height(first, facts)[0], gate, facts.fluid_density, g)
    force = _tail_mean(metrics, "gate_force_x", 0.2)
    tip = _tail_mean(metrics, "gate_tip_dx", 0.2)
    state = (f"H {water_height:.3f} m, F_h {force_h:.3g} N/m, F_h0 {force_h0:.3g} N/m, "
             f"w_lin {tip_lin * 1e3:.3g} mm")
    if tip_lin <= length / 2:  # holds the water: hydrostatic load and linear bending
        force_ok = 0.5 * force_h <= force <= 2 * force_h0
        tip_low, tip_high = 0.25 * tip_lin - 0.1 * dx, 3 * tip_lin + 0.1 * dx
        force_text = f"force {force:.3g} N/m in [{0.5 * force_h:.3g}, {2 * force_h0:.3g}]"
    else:  # a soft gate must be open
        force_ok = force <= 2 * force_h0
        tip_low, tip_high = length / 8, 1.5 * length
        force_text = f"force {force:.3g} N/m <= {2 * force_h0:.3g}"
    tip_ok = tip_low <= tip <= tip_high
    return [Check("gate force", force_ok and math.isfinite(force), f"{force_text} ({state})"),
            Check("gate tip", tip_ok and math.isfinite(tip),
                  f"tip {tip * 1e3:.3g} mm in [{tip_low * 1e3:.3g}, {tip_high * 1e3:.3g}] ({state})")]


def check_front(metrics: Metrics, facts: SceneFacts) -> Check:
    """Dam break: front between a quarter of Ritter's distance and Ritter's front."""
    lo, hi = _box(facts.scene["fluid"]["shapes"][0])
    width, height = float(hi[0] - lo[0]), float(hi[1] - lo[1])
    tank = float(facts.scene["domain"]["max"][0] - lo[0])
    speed = 2 * math.sqrt(float(np.linalg.norm(facts.gravity)) * height)
    t, front = metrics.t, metrics.column("front_x") - lo[0]
    excess = float(np.nanmax(front - width - speed * (t - t[0]) - 2 * facts.dx))
    moved = float(front[-1] - width)
    least = 0.25 * min(speed * (t[-1] - t[0]), tank - width)
    ok = excess <= 0 and moved >= least
    return Check("front", ok, f"moved {moved:.3g} m (at least {least:.3g}); ahead of Ritter's "
                              f"front by {max(excess, 0):.3g} m (none allowed)")


def physics_checks(run_dir: Path, kind: str, summary: dict[str, Any]) -> list[Check]:
    """Every check of this scene kind, computed from the run's outputs."""
    scene = summary.get("scene")
    if not isinstance(scene, dict) or "dx" not in scene:
        return [Check("outputs", False, "summary.json has no 'scene' with 'dx'")]
    facts = SceneFacts.of(scene)
    checks: list[Check] = []
    try:
        metrics = read_metrics(run_dir)
        times = read_frame_times(run_dir)
        if len(times) < 2:
            raise CompareError(f"{run_dir / 'frames' / 'times.csv'}: fewer than two frames")
        first, last = (read_particle_frame(run_dir / "frames" / f"frame_{f:05d}.xdmf", t)
                       for f, t in (times[FIRST_FRAME], times[LAST_FRAME]))
    except CompareError as exc:
        return checks + [Check("outputs", False, str(exc))]
    checks.append(check_volume(first, last, facts, kind, summary))
    checks.append(check_energy(first, last, facts))
    checks += check_integrity(last, facts)
    try:
        if kind == "floating_block":
            checks.append(check_archimedes(metrics, facts))
        elif kind == "elastic_gate":
            checks += check_gate(metrics, first, last, facts)
        elif kind == "dam_break":
            checks.append(check_front(metrics, facts))
    except (CompareError, KeyError, IndexError) as exc:
        checks.append(Check(kind, False, f"cannot check: {exc}"))
    return checks


# --------------------------------------------------------------------------- classification


@dataclass
class Verdict:
    cls: str
    reason: str
    checks: list[Check] = field(default_factory=list)


def _log_reason(run_dir: Path) -> str:
    """The solver's last log line, without its "[hh:mm:ss] " stamp."""
    from compare.validate import _last_log_line

    line = _last_log_line(run_dir / "iqmpm.log")
    return re.sub(r"^\[\d\d:\d\d:\d\d\]\s*", "", line) or "no message"


def classify(run_dir: Path, kind: str, returncode: int | None = None,
             timed_out: bool = False, timeout: float | None = None) -> Verdict:
    """The class of one finished run folder. ``returncode`` None: read from the run record
    (``compare_run.json``) if there is one."""
    run_dir = Path(run_dir)
    if returncode is None and (run_dir / RUN_RECORD).is_file():
        try:
            returncode = json.loads((run_dir / RUN_RECORD).read_text()).get("returncode")
        except (OSError, json.JSONDecodeError, AttributeError):
            returncode = None
    if timed_out:
        return Verdict(NO_RESULT, f"timed out after {timeout:g} s" if timeout else "timed out")
    if not (run_dir / "summary.json").is_file():
        if returncode == 2:
            return Verdict(STOPPED, f"refused (exit 2): {_log_reason(run_dir)}")
        return Verdict(NO_RESULT, f"exit {returncode}, no summary.json: {_log_reason(run_dir)}")
    try:
        summary = read_summary(run_dir / "summary.json")
    except CompareError as exc:
        return Verdict(NO_RESULT, f"exit {returncode}: {exc}")
    status = str(summary.get("status", "missing status"))
    if status.strip().lower() != "ok":
        if returncode in (2, 3, None):
            return Verdict(STOPPED, f"exit {returncode if returncode is not None else '?'}: {status}")
        return Verdict(NO_RESULT, f"exit {returncode}: {status}")
    if returncode not in (0, None):
        return Verdict(NO_RESULT, f"status ok but exit {returncode}")
    checks = physics_checks(run_dir, kind, summary)
    failed = [c for c in checks if not c.ok]
    retries = summary.get("dt_retries", 0)
    retries = int(retries) if isinstance(retries, (int, float)) else 0
    if failed:
        adapted = f" (after {retries} dt retries)" if retries else ""
        return Verdict(WRONG, "; ".join(f"{c.name}: {c.detail}" for c in failed) + adapted, checks)
    if retries > 0:
        return Verdict(ADAPTED, f"{retries} step(s) retried with a smaller dt; checks pass", checks)
    return Verdict(STABLE, "checks pass: " + ", ".join(c.name for c in checks), checks)


# --------------------------------------------------------------------------- running


@dataclass
class Settings:
    repo: Path
    out: Path
    solver_bin: Path
    scenes: list[str]
    grid: Grid
    jobs: int
    timeout: float


@dataclass
class CellResult:
    cell: Cell
    verdict: Verdict
    elapsed: float
    run_dir: Path


def run_solver(s: Settings, cell: Cell, progress):
    """Run one cell's solver (in a worker thread) into an emptied folder; record it.
    Returns (ChildResult, run folder). The classification is left to the main thread:
    compare.io reads frames with stdout and stderr redirected (meshio prints), which is
    not safe in two threads at once."""
    from compare.validate import run_child

    scene = SCENES[cell.scene]
    scene_path = s.repo / scene.path
    fluid_density = float((json.loads(scene_path.read_text()).get("fluid") or {})
                          .get("density", 1000.0))
    run_dir = s.out / "runs" / cell.scene / cell.name
    if run_dir.exists():
        shutil.rmtree(run_dir)  # our own folder: no older run's files beside the new ones
    run_dir.mkdir(parents=True)
    cmd = [str(s.solver_bin), "run", str(scene_path), "--out", str(run_dir), "--threads", "1",
           *cell.sets(fluid_density)]
    res = run_child(cmd, run_dir / "iqmpm.log", progress, cell.scene, cell.name, s.timeout, s.repo)
    (run_dir / RUN_RECORD).write_text(json.dumps(
        {"solver": "iqmpm", "command": cmd, "threads": 1, "elapsed_s": res.elapsed,
         "cpu_s": res.cpu, "returncode": res.returncode, "stress_cell": asdict(cell)}, indent=1))
    return res, run_dir


def _duration(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 120 else f"{seconds / 60:.1f} min"


def run_map(s: Settings, progress=None) -> list[CellResult]:
    """Run every cell, ``jobs`` at a time, the costliest first; one line per finished cell
    with runs done / total and an ETA from the cost of what is left."""
    from compare.validate import Progress

    progress = progress or Progress()
    if not s.solver_bin.is_file():
        raise CompareError(f"solver binary {s.solver_bin} not found (--binary or $IQMPM_BIN)")
    cells = sorted(expand_grid(s.grid, s.scenes), key=lambda c: -c.cost())
    total_cost = sum(c.cost() for c in cells) or 1.0
    progress.line("stress", "plan", f"{len(cells)} runs on {', '.join(s.scenes)}; jobs {s.jobs}; "
                  f"about {_duration(total_cost / s.jobs)} on an idle machine; binary "
                  f"{s.solver_bin}; runs in {s.out / 'runs'}")
    results: list[CellResult] = []
    done_cost = 0.0
    with ThreadPoolExecutor(max_workers=s.jobs) as pool:
        futures = {pool.submit(run_solver, s, c, progress): c for c in cells}
        for future in as_completed(futures):
            cell = futures[future]
            res, run_dir = future.result()
            verdict = classify(run_dir, cell.scene, res.returncode, res.timed_out, s.timeout)
            result = CellResult(cell, verdict, res.elapsed, run_dir)
            results.append(result)
            done_cost += result.cell.cost()
            elapsed = progress.elapsed()
            eta = elapsed * (total_cost - done_cost) / done_cost if done_cost > 0 else math.nan
            eta_text = f"ETA {_duration(eta)}" if math.isfinite(eta) else "ETA unknown"
            progress.line(result.cell.scene, result.cell.name,
                          f"{result.verdict.cls} in {result.elapsed:.1f} s: "
                          f"{result.verdict.reason[:160]} ({len(results)}/{len(cells)} runs, "
                          f"{eta_text})")
    order = {c: i for i, c in enumerate(expand_grid(s.grid, s.scenes))}
    return sorted(results, key=lambda r: order[r.cell])


# --------------------------------------------------------------------------- outputs


def _param(value: float | None) -> str:
    return "-" if value is None else f"{value:g}"


TABLE_HEADER = ("scene", "cfl", "dt_max", "resolution", "dx", "rho_s/rho_f", "E (Pa)",
                "class", "reason", "wall (s)")


def _row(r: CellResult) -> list[str]:
    c = r.cell
    return [c.scene, f"{c.cfl:g}", f"{c.dt_max:g}", c.resolution, f"{c.dx:g}",
            _param(c.density_ratio), _param(c.youngs_modulus), r.verdict.cls, r.verdict.reason,
            f"{r.elapsed:.1f}"]


def counts_per_scene(results: Sequence[CellResult]) -> dict[str, dict[str, int]]:
    counts: dict[str, dict[str, int]] = {}
    for r in results:
        per = counts.setdefault(r.cell.scene, {k: 0 for k in CLASSES})
        per[r.verdict.cls] += 1
    return counts


def write_table(results: Sequence[CellResult], out: Path, settings: dict[str, Any]) -> tuple[Path, Path]:
    """``stress_map.csv`` (every cell) and ``stress_map.md`` (counts, then every cell)."""
    out.mkdir(parents=True, exist_ok=True)
    csv_path = out / "stress_map.csv"
    with open(csv_path, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(TABLE_HEADER)
        writer.writerows(_row(r) for r in results)
    lines = ["# Stability map (compare stress)", ""]
    lines += [f"- {k}: {v}" for k, v in settings.items()]
    lines += ["", "Classes and checks: compare/README.md (stress) and compare/stress.py.", "",
              "## Counts per scene", "", "| scene | " + " | ".join(CLASSES) + " | total |",
              "|---|" + "---|" * (len(CLASSES) + 1)]
    for scene, per in counts_per_scene(results).items():
        lines.append(f"| {scene} | " + " | ".join(str(per[k]) for k in CLASSES)
                     + f" | {sum(per.values())} |")
    lines += ["", "## Every cell", "", "| " + " | ".join(TABLE_HEADER) + " |",
              "|" + "---|" * len(TABLE_HEADER)]
    for r in results:
        lines.append("| " + " | ".join(x.replace("|", "/") for x in _row(r)) + " |")
    md_path = out / "stress_map.md"
    md_path.write_text("\n".join(lines) + "\n")
    return md_path, csv_path


def _class_grid(ax, results: Sequence[CellResult], column_of, row_of, columns: list,
                rows: list) -> None:
    """Squares coloured by class (with its mark) at (column_of(cell), row_of(cell))."""
    from matplotlib.colors import ListedColormap

    image = np.full((len(rows), len(columns)), np.nan)
    for r in results:
        i, j = rows.index(row_of(r.cell)), columns.index(column_of(r.cell))
        image[i, j] = CLASSES.index(r.verdict.cls)
        ax.text(j, i, CLASS_MARKS[r.verdict.cls], ha="center", va="center", fontsize=8)
    ax.imshow(image, cmap=ListedColormap([CLASS_COLOURS[k] for k in CLASSES]), vmin=-0.5,
              vmax=len(CLASSES) - 0.5, origin="lower", aspect="auto")


def write_heat_maps(results: Sequence[CellResult], out: Path) -> list[Path]:
    """One PNG per scene, each square a cell coloured by its class, with its mark.
    With a solid: E across, rho_s/rho_f up, a panel per (dt_max, resolution) row and CFL
    column. Without (dam break): one panel, CFL across, (dt_max, resolution) up."""
    from compare import plots  # noqa: F401  (sets the Agg backend)
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for scene in dict.fromkeys(r.cell.scene for r in results):
        mine = [r for r in results if r.cell.scene == scene]
        cfls = sorted({r.cell.cfl for r in mine})
        rows = sorted({(r.cell.dt_max, r.cell.resolution) for r in mine})
        row_labels = [f"dt_max {dt:g} s, {res}" for dt, res in rows]
        if all(r.cell.youngs_modulus is None for r in mine):
            fig, ax = plt.subplots(figsize=(max(7.0, 1.4 * len(cfls) + 2.5), 0.7 * len(rows) + 2.2))
            _class_grid(ax, mine, lambda c: c.cfl, lambda c: (c.dt_max, c.resolution), cfls, rows)
            ax.set_xticks(range(len(cfls)), [f"{v:g}" for v in cfls], fontsize=8)
            ax.set_yticks(range(len(rows)), row_labels, fontsize=8)
            ax.set_xlabel("CFL", fontsize=8)
            legend_columns, bottom = 2, 0.22
        else:
            youngs = sorted({r.cell.youngs_modulus for r in mine})
            ratios = sorted({r.cell.density_ratio for r in mine})
            fig, axes = plt.subplots(len(rows), len(cfls), squeeze=False,
                                     figsize=(max(9.0, 2.3 * len(cfls) + 1.5), 2.0 * len(rows) + 1.8))
            for i, row in enumerate(rows):
                for j, cfl in enumerate(cfls):
                    ax = axes[i][j]
                    panel = [r for r in mine if (r.cell.dt_max, r.cell.resolution) == row
                             and r.cell.cfl == cfl]
                    _class_grid(ax, panel, lambda c: c.youngs_modulus, lambda c: c.density_ratio,
                                youngs, ratios)
                    ax.set_xticks(range(len(youngs)), [f"{v:.0e}" for v in youngs], fontsize=7)
                    ax.set_yticks(range(len(ratios)), [f"{v:g}" for v in ratios], fontsize=7)
                    ax.set_title(f"CFL {cfl:g}, {row_labels[i]}", fontsize=8)
                    if i == len(rows) - 1:
                        ax.set_xlabel("E (Pa)", fontsize=8)
                    if j == 0:
                        ax.set_ylabel("rho_s / rho_f", fontsize=8)
            legend_columns, bottom = 3, 0.08
        fig.legend(handles=[Patch(color=CLASS_COLOURS[k], label=f"{CLASS_MARKS[k]}: {CLASS_LABELS[k]}")
                            for k in CLASSES], loc="lower center", ncol=legend_columns, fontsize=8)
        fig.suptitle(f"{scene}: stability map", fontsize=10)
        fig.tight_layout(rect=(0, bottom, 1, 0.96))
        path = out / f"{scene}_map.png"
        fig.savefig(path, dpi=100)
        plt.close(fig)
        paths.append(path)
    return paths


# --------------------------------------------------------------------------- command line


def add_parser(sub: Any) -> None:
    p = sub.add_parser("stress", help="stability map: a grid of short runs, each classified "
                                      "stable / stopped / adapted / wrong by physics checks")
    p.add_argument("--scene", action="append", default=[], metavar="NAME",
                   help=f"scene of the map: {', '.join(SCENES)} (repeatable; default: all)")
    p.add_argument("--quick", action="store_true",
                   help="a tiny grid (two coarse cells per scene, one refused) for tests and CI")
    p.add_argument("--jobs", type=int, default=2, help="runs at a time (default 2)")
    p.add_argument("--out", type=Path, default=REPO_ROOT / "out" / "stress",
                   help="folder for the table, the heat maps and runs/ (default <repo>/out/stress)")
    p.add_argument("--binary", "--solver", dest="binary", type=Path, default=None,
                   help="IQ-MPM binary (default $IQMPM_BIN or <repo>/build/iqmpm)")
    p.add_argument("--timeout", type=float, default=600.0, help="seconds per run (default 600)")
    p.add_argument("--repo", type=Path, default=REPO_ROOT, help="repository root")


def command(args: argparse.Namespace) -> int:
    import os

    if args.jobs < 1:
        raise CompareError(f"--jobs {args.jobs}: give 1 or more")
    if not args.timeout > 0:
        raise CompareError(f"--timeout {args.timeout:g}: give a positive number of seconds")
    repo = args.repo.resolve()
    binary = args.binary or Path(os.environ.get("IQMPM_BIN", repo / "build" / "iqmpm"))
    scenes = list(dict.fromkeys(args.scene)) or list(SCENES)
    unknown = [n for n in scenes if n not in SCENES]
    if unknown:
        raise CompareError(f"--scene {', '.join(unknown)}: not a scene of the map "
                           f"({', '.join(SCENES)})")
    for name in scenes:
        if not (repo / SCENES[name].path).is_file():
            raise CompareError(f"scene file {repo / SCENES[name].path} not found")
    s = Settings(repo, args.out.resolve(), Path(binary).resolve(), scenes,
                 QUICK_GRID if args.quick else DEFAULT_GRID, args.jobs, args.timeout)
    started = time.monotonic()
    results = run_map(s)
    grid = s.grid
    settings = {"binary": str(s.solver_bin), "scenes": ", ".join(scenes),
                "grid": f"cfl {list(grid.cfl)} x dt_max {list(grid.dt_max)} x rho_s/rho_f "
                        f"{list(grid.density_ratio)} x E {list(grid.youngs_modulus)} x "
                        f"resolutions {list(grid.resolutions)}",
                "end times": ", ".join(f"{n} {SCENES[n].end_time:g} s" for n in scenes),
                "runs": len(results), "jobs": s.jobs,
                "minutes": f"{(time.monotonic() - started) / 60:.1f}"}
    md_path, csv_path = write_table(results, s.out, settings)
    maps = write_heat_maps(results, s.out)
    for scene, per in counts_per_scene(results).items():
        print(f"stress | {scene}: " + ", ".join(f"{k} {v}" for k, v in per.items()))
    print(f"stress | table: {md_path}\nstress | csv: {csv_path}")
    for path in maps:
        print(f"stress | heat map: {path}")
    bad = [r for r in results if r.verdict.cls in (WRONG, NO_RESULT)]
    for r in bad:
        print(f"stress | {r.verdict.cls.upper()}: {r.cell.scene} {r.cell.name}: {r.verdict.reason}")
    print(f"stress | FAILED: {len(bad)} cell(s) wrong or without a result" if bad
          else "stress | no cell wrong")
    return 1 if bad else 0
