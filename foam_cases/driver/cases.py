"""The registry of OpenFOAM reference cases: per-level parameters, setup
commands and metric extraction. Geometry and materials follow
docs/benchmarks.md; the template folders hold the OpenFOAM dictionaries."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from . import metrics as m
from .parse import read_internal_field, read_sets

G = 9.81
RHO_W = 1000.0

Params = dict[str, object]

# caseParams entries with a closed set of values, checked before a run
# (`--set system/caseParams:ENTRY=VALUE`). wallVelocity: the velocity condition of
# the tank's walls (and the obstacle) in the dam-break cases; slip is the model
# under test (docs/method.md section 1), noSlip a viscous wall.
CASE_PARAM_CHOICES: dict[str, tuple[str, ...]] = {"wallVelocity": ("slip", "noSlip")}


@dataclass
class Extracted:
    times: np.ndarray
    columns: dict[str, np.ndarray]
    scalars: dict[str, object] = field(default_factory=dict)


@dataclass(frozen=True)
class CaseSpec:
    name: str
    folder: str                       # template folder under foam_cases/
    solver: str
    end_time: float
    levels: tuple[int, ...]
    params: Callable[[int], Params]   # values written to system/caseParams
    setup: tuple[tuple[str, ...], ...]  # meshing / initialisation commands
    extract: Callable[[Path, Params, Path], Extracted]
    vtk_fields: tuple[str, ...]
    summary: str


def _cells_2d(p: Params) -> int:
    return int(p["cells"])  # type: ignore[arg-type]


# --------------------------------------------------------------------------
# dam_break: Koshizuka & Oka tank, no obstacle
# --------------------------------------------------------------------------
A = 0.146          # column width (m)
TANK = 4 * A       # 0.584 m


def dam_break_params(level: int) -> Params:
    n = 40 * 2 ** (level - 1)
    dx = TANK / n
    return {
        "level": level, "nx": n, "ny": n, "cells": n * n,
        "dz": 0.0146, "zMid": 0.0073,
        "endTime": 0.6, "writeInterval": 0.1, "sampleInterval": 0.002,
        "yFloor": dx / 2, "xLeft": dx / 2, "wallVelocity": "slip",
    }


def _tank_series(case: Path, p: Params) -> dict[str, m.Series]:
    dz = float(p["dz"])  # type: ignore[arg-type]
    return {
        "front_x": m.front_x(case, "lines", "floor"),
        "height_left": m.column_height(case, "lines", "leftColumn"),
        "pressure_right": m.probe(case, "wallProbes", "p"),
        "volume": m.volume(case, dz),
        "max_speed": m.max_speed(case),
    }


def _volume_scalars(cols: dict[str, np.ndarray]) -> dict[str, object]:
    v = cols.get("volume")
    if v is None or len(v) == 0:
        return {}
    return {"volume_initial": float(v[0]), "volume_final": float(v[-1]),
            "volume_drift": float((v[-1] - v[0]) / v[0])}


# The right wall's pressure probes above pressure_right (0.01 m), in the order of the
# controlDict's probeLocations.
DAM_WALL_PROBES = (("pressure_right_3cm", 1), ("pressure_right_6cm", 2), ("pressure_right_10cm", 3))


def dam_break_extract(case: Path, p: Params, log: Path) -> Extracted:
    series = _tank_series(case, p)
    series.update({name: m.probe(case, "wallProbes", "p", index) for name, index in DAM_WALL_PROBES})
    t, cols = m.merge(series)
    sc = _volume_scalars(cols)
    sc.update(koshizuka_oka_error(t, cols.get("front_x")))
    return Extracted(t, cols, sc)


KO_DATA = "koshizuka_oka_1996_surge_front_pysph.csv"


def koshizuka_oka_error(t: np.ndarray, xf: np.ndarray | None) -> dict[str, object]:
    """Relative L2 of Z = x_f/a vs T = t sqrt(2g/a) against Koshizuka & Oka,
    over the data points with T in [0, 2.5]; the simulation is interpolated
    onto the data times, with its initial state (Z = 1 at T = 0) prepended."""
    data_file = _data_file(KO_DATA)
    if xf is None or len(t) == 0 or data_file is None:
        return {}
    d = np.loadtxt(data_file, delimiter=",", comments="#", skiprows=4)
    T_data, Z_data = d[:, 0], d[:, 1]
    T_sim = np.concatenate([[0.0], t * math.sqrt(2 * G / A)])
    Z_sim = np.concatenate([[1.0], xf / A])
    sel = (T_data >= 0) & (T_data <= 2.5) & (T_data <= T_sim[-1])
    Z_i = np.interp(T_data[sel], T_sim, Z_sim)
    err = np.linalg.norm(Z_i - Z_data[sel]) / np.linalg.norm(Z_data[sel])
    return {"front_l2_vs_koshizuka_oka": float(err),
            "front_l2_points": int(sel.sum())}


DATA_DIR = Path(__file__).resolve().parents[2] / "data"  # <repo>/data, shipped with it


def _data_file(name: str) -> Path | None:
    """A reference-data file: ``$IQMPM_DATA_DIR/name``, else ``<repo>/data/name``."""
    env = os.environ.get("IQMPM_DATA_DIR")
    for root in ([Path(env)] if env else []) + [DATA_DIR]:
        if (root / name).exists():
            return root / name
    return None


# --------------------------------------------------------------------------
# dam_break_obstacle: the interFoam damBreak tutorial, obstacle as own patch
# --------------------------------------------------------------------------
def dam_break_obstacle_params(level: int) -> Params:
    r = 2 ** (level - 1)
    nxl, nxo, nxr, nyl, nyu = 23 * r, 4 * r, 19 * r, 8 * r, 42 * r
    scale = 0.146
    return {
        "level": level, "nxLeft": nxl, "nxObstacle": nxo, "nxRight": nxr,
        "nyLower": nyl, "nyUpper": nyu,
        "cells": (nxl + nxr) * nyl + (nxl + nxo + nxr) * nyu,
        "dz": 0.1 * scale, "zMid": 0.05 * scale,
        "endTime": 1.0, "writeInterval": 0.1, "sampleInterval": 0.002,
        "yFloor": 0.32876 * scale / nyl / 2, "xLeft": 2 * scale / nxl / 2,
        "wallVelocity": "slip",
    }


def dam_break_obstacle_extract(case: Path, p: Params, log: Path) -> Extracted:
    s = _tank_series(case, p)
    s["obstacle_force_x"] = m.force(case, "obstacleForces", 0, float(p["dz"]))  # type: ignore[arg-type]
    t, cols = m.merge(s)
    sc = _volume_scalars(cols)
    f = cols["obstacle_force_x"]
    if len(f):
        k = int(np.argmax(f))
        sc.update({"obstacle_force_x_peak": float(f[k]),
                   "obstacle_force_x_peak_time": float(t[k])})
    return Extracted(t, cols, sc)


# --------------------------------------------------------------------------
# hydrostatic: 1 m box, H = 0.5 m, open top at 1.0 m
# --------------------------------------------------------------------------
H_HYDRO = 0.5


def hydrostatic_params(level: int) -> Params:
    n = 20 * 2 ** (level - 1)
    return {
        "level": level, "nx": n, "ny": n, "cells": n * n,
        "dz": 0.01, "zMid": 0.005,
        "endTime": 2.0, "writeInterval": 1.0, "sampleInterval": 0.01,
        "xLeft": 0.5 / n,
    }


def hydrostatic_extract(case: Path, p: Params, log: Path) -> Extracted:
    dz = float(p["dz"])  # type: ignore[arg-type]
    s = {
        "wall_force_x": m.force(case, "wallForce", 0, dz),
        "height_left": m.column_height(case, "lines", "leftColumn"),
        "volume": m.volume(case, dz),
        "max_speed": m.max_speed(case),
    }
    t, cols = m.merge(s)
    sc = _volume_scalars(cols)
    ref = RHO_W * G * H_HYDRO ** 2 / 2
    if len(t):
        f_end = float(cols["wall_force_x"][-1])
        sc.update({"wall_force_x_final": f_end, "wall_force_x_reference": ref,
                   "wall_force_x_rel_error": (f_end - ref) / ref,
                   "max_speed_final": float(cols["max_speed"][-1])})
    sc.update(hydrostatic_pressure_error(case, p))
    return Extracted(t, cols, sc)


def hydrostatic_pressure_error(case: Path, p: Params) -> dict[str, object]:
    """Relative L2 of p against rho g (H - y) over the cells with alpha > 0.5
    at the last written time (single block: cell i + nx*j has centre
    ((i+1/2)dx, (j+1/2)dy))."""
    times = sorted((d for d in case.iterdir() if _is_time(d.name) and (d / "p").exists()),
                   key=lambda d: float(d.name))
    if not times:
        return {}
    last = times[-1]
    nx, ny = int(p["nx"]), int(p["ny"])  # type: ignore[arg-type]
    pf = read_internal_field(last / "p")[:, 0]
    al = read_internal_field(last / "alpha.water")[:, 0]
    if pf.size != nx * ny or al.size != nx * ny:
        return {}
    y = (np.arange(nx * ny) // nx + 0.5) * (1.0 / ny)
    ref = RHO_W * G * (H_HYDRO - y)
    wet = al > 0.5
    err = np.linalg.norm(pf[wet] - ref[wet]) / np.linalg.norm(ref[wet])
    return {"pressure_l2_error": float(err), "pressure_l2_time": float(last.name)}


def _is_time(name: str) -> bool:
    try:
        float(name)
        return True
    except ValueError:
        return False


# --------------------------------------------------------------------------
# registry
# --------------------------------------------------------------------------
TANK_FIELDS = ("alpha.water", "p", "p_rgh", "U")

CASES: dict[str, CaseSpec] = {}


def register(spec: CaseSpec) -> None:
    CASES[spec.name] = spec


register(CaseSpec(
    name="dam_break", folder="dam_break", solver="interFoam", end_time=0.6,
    levels=(1, 2, 3, 4), params=dam_break_params,
    setup=(("blockMesh",), ("setFields",)),
    extract=dam_break_extract, vtk_fields=TANK_FIELDS,
    summary="collapsing column a = 0.146 m in a 0.584 m tank"))

register(CaseSpec(
    name="dam_break_obstacle", folder="dam_break_obstacle", solver="interFoam",
    end_time=1.0, levels=(1, 2, 3), params=dam_break_obstacle_params,
    setup=(("blockMesh",), ("setFields",)),
    extract=dam_break_obstacle_extract, vtk_fields=TANK_FIELDS,
    summary="interFoam damBreak tutorial with the obstacle as its own patch"))

register(CaseSpec(
    name="hydrostatic", folder="hydrostatic", solver="interFoam", end_time=2.0,
    levels=(1, 2, 3, 4), params=hydrostatic_params,
    setup=(("blockMesh",), ("setFields",)),
    extract=hydrostatic_extract, vtk_fields=TANK_FIELDS,
    summary="water at rest, H = 0.5 m in a 1 m box"))


# --------------------------------------------------------------------------
# floating_block: 0.2 x 0.1 m block in a 1 m tank, water depth 0.5 m
# --------------------------------------------------------------------------
BLOCK_W, BLOCK_H = 0.2, 0.1
BLOCK_C0 = (0.5, 0.52)        # centre at release (bottom at y = 0.47)
WATER_DEPTH0 = 0.5


@dataclass(frozen=True)
class FloatingVariant:
    rho_solid: float
    tilt_deg: float
    # Partitioned-coupling settings that run to 5 s (README.md: how found).
    acceleration_relaxation: float
    n_outer: int


FLOATING = {
    "floating_block": FloatingVariant(500.0, 0.0, 0.3, 4),
    "floating_block_roll": FloatingVariant(500.0, 10.0, 0.3, 4),
    "floating_block_light": FloatingVariant(200.0, 0.0, 0.15, 6),
}


def floating_params(variant: FloatingVariant, level: int) -> Params:
    """caseParams of the overset formulation (README: floating_block)."""
    h = 0.02 / 2 ** (level - 1)
    n = lambda length: int(round(length / h))  # noqa: E731
    dz = 0.01
    mass = variant.rho_solid * BLOCK_W * BLOCK_H * dz
    th = math.radians(variant.tilt_deg)
    c, s = math.cos(th), math.sin(th)
    n_bg, nx_body, ny_body = n(1.0), n(0.4), n(0.3)
    return {
        "level": level,
        # background + body mesh minus the cut-out block
        "cells": n_bg ** 2 + nx_body * ny_body - n(BLOCK_W) * n(BLOCK_H),
        "dz": dz, "zMid": dz / 2,
        "endTime": 5.0, "writeInterval": 0.5, "sampleInterval": 0.01,
        "nBg": n_bg, "nxBody": nx_body, "nyBody": ny_body,
        # background cell centres, sampled for the water volume
        "bgPoints": tuple((round((i + 0.5) * h, 9), round((j + 0.5) * h, 9), dz / 2)
                          for j in range(n_bg) for i in range(n_bg)),
        "tiltDeg": variant.tilt_deg,
        "rhoSolid": variant.rho_solid, "mass": mass,
        "Ixx": mass * (BLOCK_H ** 2 + dz ** 2) / 12,
        "Iyy": mass * (BLOCK_W ** 2 + dz ** 2) / 12,
        "Izz": mass * (BLOCK_W ** 2 + BLOCK_H ** 2) / 12,
        "comX": BLOCK_C0[0], "comY": BLOCK_C0[1],
        "orientation": (c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0),
        "accelerationRelaxation": variant.acceleration_relaxation,
        "accelerationDamping": 1.0,
        "nOuterCorrectors": variant.n_outer,
        "maxCo": 0.5, "maxAlphaCo": 0.5, "maxDeltaT": 0.005,
    }


def floating_setup(variant: FloatingVariant) -> tuple[tuple[str, ...], ...]:
    """Overset meshing: body mesh (folder body/), cut, tilt, place, merge."""
    return (
        ("blockMesh", "-case", "body"),
        ("topoSet", "-case", "body"),
        ("subsetMesh", "-case", "body", "-overwrite", "c0", "-patch", "floatingObject"),
        ("transformPoints", "-case", "body", "-rotate-angle",
         f"((0 0 1) {variant.tilt_deg:.12g})"),
        ("transformPoints", "-case", "body", "-translate",
         f"({BLOCK_C0[0]:.12g} {BLOCK_C0[1]:.12g} 0)"),
        ("blockMesh",),
        ("mergeMeshes", ".", "body", "-overwrite"),
        ("topoSet",),
        ("setFields",),
        ("setAlphaField",),
    )


def oscillation(t: np.ndarray, y: np.ndarray, window: float = 1.0) -> dict[str, object]:
    """Period and decay of y(t) about its mean over the last `window` s.

    Crossings of the mean-removed signal (linear interpolation); period =
    2 x mean spacing of successive crossings; the peaks are the extremes of
    |y - mean| between successive crossings (half cycles), kept while they
    exceed 5 % of the first one; decay_ratio = mean ratio of successive peak
    amplitudes (per half cycle), decay_ratio_per_period = its square.
    """
    ref = float(np.mean(y[t >= t[-1] - window]))
    d = y - ref
    idx = np.nonzero(np.sign(d[1:]) * np.sign(d[:-1]) < 0)[0]
    tc = t[idx] - d[idx] * (t[idx + 1] - t[idx]) / (d[idx + 1] - d[idx])
    peaks: list[list[float]] = []
    for a, b in zip(idx[:-1], idx[1:]):
        k = a + 1 + int(np.argmax(np.abs(d[a + 1:b + 1])))
        peaks.append([float(t[k]), float(d[k])])
    if peaks:
        a0 = abs(peaks[0][1])
        keep = [q for q in peaks if abs(q[1]) > 0.05 * a0]
        n = len(keep)
        peaks = keep
    else:
        n = 0
    res: dict[str, object] = {"mean": ref, "crossings": len(tc), "peaks": peaks,
                              "period": None, "period_first_cycle": None,
                              "decay_ratio": None, "decay_ratio_per_period": None}
    if len(tc) >= 3:
        # before waves reflected from the tank walls come back
        res["period_first_cycle"] = float(tc[2] - tc[0])
        nc = min(len(tc), n + 1) if n >= 2 else len(tc)
        res["period"] = float(2 * np.mean(np.diff(tc[:max(nc, 3)])))
    if n >= 2:
        r = [abs(peaks[k + 1][1]) / abs(peaks[k][1]) for k in range(n - 1)]
        res["decay_ratio"] = float(np.mean(r))
        res["decay_ratio_per_period"] = float(np.mean(r)) ** 2
    return res


BODY_BOX = (0.2, 0.15)   # half sizes of the body mesh (body/system/blockMeshDict)


def _clip_area(poly: np.ndarray, x0: float, y0: float, x1: float, y1: float) -> float:
    """Area of a convex polygon (k x 2, counter-clockwise) inside a box."""
    pts = [tuple(p) for p in poly]
    for axis, val, keep_ge in ((0, x0, True), (0, x1, False), (1, y0, True), (1, y1, False)):
        out = []
        for k in range(len(pts)):
            a, b = pts[k - 1], pts[k]
            ina = (a[axis] >= val) if keep_ge else (a[axis] <= val)
            inb = (b[axis] >= val) if keep_ge else (b[axis] <= val)
            if ina != inb:
                f = (val - a[axis]) / (b[axis] - a[axis])
                out.append((a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])))
            if inb:
                out.append(b)
        pts = out
        if not pts:
            return 0.0
    xs, ys = np.array([q[0] for q in pts]), np.array([q[1] for q in pts])
    return float(0.5 * abs(np.dot(xs, np.roll(ys, -1)) - np.dot(ys, np.roll(xs, -1))))


def overset_volume(case: Path, p: Params, s: dict[str, m.Series]) -> m.Series:
    """Water area per unit depth without double counting the overlap:
    body-mesh integral (it tiles the moving box around the block exactly)
    plus, for every background cell, its alpha times the part of its square
    outside the moving box (box pose from com_x, com_y, angle at that time)."""
    dz, n = float(p["dz"]), int(p["nBg"])  # type: ignore[arg-type]
    h = 1.0 / n
    tb, vb = m.volume(case, dz, "bodyWater")
    times, snaps = read_sets(case, "bgCells", "bg_alpha.water.xy")
    pose = {round(float(t), 9): i for i, t in enumerate(s["com_x"][0])}
    hx, hy = BODY_BOX
    out_t, out_v = [], []
    body = {round(float(t), 9): v for t, v in zip(tb, vb)}
    for t, arr in zip(times, snaps):
        k = round(float(t), 9)
        if k not in pose or k not in body or arr.shape[0] != n * n:
            continue
        i = pose[k]
        cx, cy, th = s["com_x"][1][i], s["com_y"][1][i], s["angle"][1][i]
        c, sn = math.cos(th), math.sin(th)
        box = np.array([(cx + c * dx - sn * dy, cy + sn * dx + c * dy)
                        for dx, dy in ((-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy))])
        x, y, a = arr[:, 0], arr[:, 1], np.clip(arr[:, 3], 0.0, 1.0)
        area = np.full(len(x), h * h)          # part of each cell outside the box
        near = ((x + h / 2 > box[:, 0].min()) & (x - h / 2 < box[:, 0].max())
                & (y + h / 2 > box[:, 1].min()) & (y - h / 2 < box[:, 1].max()))
        for q in np.nonzero(near)[0]:
            area[q] -= _clip_area(box, x[q] - h / 2, y[q] - h / 2, x[q] + h / 2, y[q] + h / 2)
        out_t.append(float(t))
        out_v.append(body[k] + float(np.sum(a * area)))
    return np.array(out_t), np.array(out_v)


def floating_extract(case: Path, p: Params, log: Path) -> Extracted:
    dz = float(p["dz"])  # type: ignore[arg-type]
    s = m.rigid_body(case, log)
    s["block_force_x"] = m.force(case, "blockForces", 0, dz)
    s["block_force_y"] = m.force(case, "blockForces", 1, dz)
    s["volume"] = overset_volume(case, p, s)
    s["max_speed"] = m.max_speed(case)
    tl, hl = m.column_height(case, "lines", "levelLeft")
    tr, hr = m.column_height(case, "lines", "levelRight")
    s["water_level"] = (tl, 0.5 * (hl + hr))
    t, cols = m.merge(s)
    sc = _volume_scalars(cols)
    if len(t) == 0:
        return Extracted(t, cols, sc)
    rho_s = float(p["rhoSolid"])  # type: ignore[arg-type]
    last = t >= t[-1] - 1.0
    com_y = float(np.mean(cols["com_y"][last]))
    level = float(np.mean(cols["water_level"][last]))
    draft = level - (com_y - BLOCK_H / 2)
    d_ref = rho_s / RHO_W * BLOCK_H                     # Archimedes
    v_water = float(cols["volume"][0])
    level_ref = v_water + BLOCK_W * d_ref               # tank 1 m wide
    sc.update({
        "equilibrium_draft": draft, "equilibrium_draft_reference": d_ref,
        "equilibrium_draft_rel_error": (draft - d_ref) / d_ref,
        "equilibrium_com_y": com_y,
        "equilibrium_com_y_reference": level_ref - d_ref + BLOCK_H / 2,
        "equilibrium_water_level": level, "equilibrium_window_s": [float(t[-1] - 1.0), float(t[-1])],
        "final_angle_deg": float(np.degrees(cols["angle"][-1])),
        # com_y-based draft: the still-water level from the water area
        # (1 m wide tank) with the block at equilibrium, vs com_y - H/2.
        "equilibrium_draft_from_com_y": None,
        "block_force_y_final": float(np.mean(cols["block_force_y"][last])),
        "block_weight_per_depth": rho_s * BLOCK_W * BLOCK_H * G,
    })
    heave = oscillation(t, cols["com_y"])
    sc.update({"heave_period": heave["period"],
               "heave_period_first_cycle": heave["period_first_cycle"],
               "heave_decay_ratio": heave["decay_ratio"],
               "heave_decay_ratio_per_period": heave["decay_ratio_per_period"],
               "heave_peaks": heave["peaks"]})
    # Linear estimate 2 pi sqrt((m + m_a) / (rho g A_wp)), m_a ~ rho pi b^2 / 8.
    m_a = RHO_W * math.pi * BLOCK_W ** 2 / 8
    sc["heave_period_linear_estimate"] = 2 * math.pi * math.sqrt(
        (rho_s * BLOCK_W * BLOCK_H + m_a) / (RHO_W * G * BLOCK_W))
    # still-water level of the final water area with the block at its draft d:
    # level = V + b d  ->  com_y = V + b d - d + H/2
    v_end = float(np.mean(cols["volume"][last]))
    sc["equilibrium_draft_from_com_y"] = (v_end - (com_y - BLOCK_H / 2)) / (1.0 - BLOCK_W)
    if abs(float(np.degrees(cols["angle"][0]))) > 1.0:
        roll = oscillation(t, cols["angle"])
        sc.update({"roll_period": roll["period"],
                   "roll_period_first_cycle": roll["period_first_cycle"],
                   "roll_decay_ratio": roll["decay_ratio"],
                   "roll_decay_ratio_per_period": roll["decay_ratio_per_period"],
                   "roll_peaks_deg": [[q[0], math.degrees(q[1])] for q in roll["peaks"]]})
    return Extracted(t, cols, sc)


FLOAT_FIELDS = ("alpha.water", "p", "p_rgh", "U")
for _name, _variant in FLOATING.items():
    register(CaseSpec(
        name=_name, folder="floating_block", solver="overInterDyMFoam", end_time=5.0,
        levels=(1, 2, 3),
        params=(lambda lv, v=_variant: floating_params(v, lv)),
        setup=floating_setup(_variant),
        extract=floating_extract, vtk_fields=FLOAT_FIELDS,
        summary=f"floating block rho_s = {_variant.rho_solid:g}, tilt {_variant.tilt_deg:g} deg"))


# --------------------------------------------------------------------------
# cantilever: solidDisplacementFoam, plane strain, gravity as traction
# --------------------------------------------------------------------------
BEAM_L, BEAM_T = 0.5, 0.05
RHO_S, E_S, NU_S = 1000.0, 1e8, 0.3


def cantilever_reference() -> float:
    """Euler-Bernoulli + Timoshenko shear, plane strain (benchmarks.md)."""
    q = RHO_S * G * BEAM_T
    e_ps = E_S / (1 - NU_S ** 2)
    inertia = BEAM_T ** 3 / 12
    shear = E_S / (2 * (1 + NU_S))
    return q * BEAM_L ** 4 / (8 * e_ps * inertia) + q * BEAM_L ** 2 / (2 * 5 / 6 * shear * BEAM_T)


def cantilever_params(level: int) -> Params:
    r = 2 ** (level - 1)
    nx, ny = 40 * r, 4 * r
    iters = 20000 * r * r
    return {
        "level": level, "nx": nx, "ny": ny, "cells": nx * ny, "dz": 0.01,
        "endTime": iters, "writeInterval": iters, "sampleInterval": 10,
        "halfLoad": -RHO_S * G * BEAM_T / 2, "residualLimit": 1e-9,
    }


def cantilever_extract(case: Path, p: Params, log: Path) -> Extracted:
    s = {"tip_dx": m.patch_average(case, "tipDisplacement", 0),
         "tip_dy": m.patch_average(case, "tipDisplacement", 1)}
    t, cols = m.merge(s)
    sc: dict[str, object] = {}
    if len(t):
        # Steady iterations: converged when tip_dy changed by less than 1e-4
        # (relative) over the last 10 % of the iterations.
        dy_all = cols["tip_dy"]
        k = int(0.9 * (len(t) - 1))
        change = abs(dy_all[-1] - dy_all[k]) / max(abs(dy_all[-1]), 1e-30)
        sc["tip_dy_change_last_10pct"] = float(change)
        if change > 1e-4:
            raise ValueError(f"not converged: tip_dy changed by {change:.2e} (relative) "
                             f"over the last 10 % of {int(t[-1])} iterations")
        ref = cantilever_reference()
        dy = float(cols["tip_dy"][-1])
        sc.update({"static_tip_dy": dy, "static_tip_dx": float(cols["tip_dx"][-1]),
                   "static_tip_dy_reference": -ref,
                   "static_tip_dy_rel_error": (abs(dy) - ref) / ref,
                   "iterations": int(t[-1])})
    return Extracted(t, cols, sc)


register(CaseSpec(
    name="cantilever", folder="cantilever", solver="solidDisplacementFoam",
    end_time=20000, levels=(1, 2, 3), params=cantilever_params,
    setup=(("blockMesh",),), extract=cantilever_extract,
    vtk_fields=("D", "sigmaEq", "sigmaxx", "sigmaxy", "sigmayy"),
    summary="clamped beam under its weight (traction-equivalent), plane strain"))
