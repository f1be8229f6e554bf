"""Synthetic run folders with known answers (IQ-MPM and OpenFOAM output contracts)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

RHO, G, H = 1000.0, 9.81, 0.5
WALL_FORCE = RHO * G * H**2 / 2  # 1226.25 N/m


def write_metrics(run_dir: Path, t: np.ndarray, columns: dict[str, np.ndarray]) -> Path:
    run_dir.mkdir(parents=True, exist_ok=True)
    names = ["t"] + list(columns)
    lines = [",".join(names)]
    for i, ti in enumerate(t):
        lines.append(",".join([repr(float(ti))] + [repr(float(columns[n][i])) for n in columns]))
    path = run_dir / "metrics.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


def write_summary(run_dir: Path, **values: Any) -> Path:
    run_dir.mkdir(parents=True, exist_ok=True)
    data = {"status": "ok", "wall_time_s": 1.0, "steps": 100, "particles": 1000,
            "active_cells": 500, "stage_seconds": {"p2g": 0.2, "pressure": 0.5},
            "linear_iterations": {"min": 3, "mean": 7.5, "max": 12}, "volume_drift": 1e-4}
    data.update(values)
    path = run_dir / "summary.json"
    path.write_text(json.dumps(data, indent=1))
    return path


def hydrostatic_particles(spacing: float = 0.02, depth: float = H, width: float = 1.0,
                          p_scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """A particle lattice filling [0, width] x [0, depth] with p = p_scale rho g (H - y)."""
    xs = np.arange(spacing / 2, width, spacing)
    ys = np.arange(spacing / 2, depth, spacing)
    X, Y = np.meshgrid(xs, ys)
    pts = np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size)])
    return pts, p_scale * RHO * G * (depth - pts[:, 1])


def write_frames(run_dir: Path, frames: list[tuple[float, np.ndarray, np.ndarray]]) -> None:
    """Particle frames via meshio (XDMF + HDF5) and frames/times.csv."""
    import meshio

    fdir = run_dir / "frames"
    fdir.mkdir(parents=True, exist_ok=True)
    rows = ["frame,t"]
    for k, (t, pts, p) in enumerate(frames):
        n = len(pts)
        mesh = meshio.Mesh(pts, [("vertex", np.arange(n).reshape(-1, 1))],
                           point_data={"pressure": p, "velocity": np.zeros((n, 3)),
                                       "material": np.zeros(n, dtype=np.int32)})
        meshio.write(str(fdir / f"frame_{k:05d}.xdmf"), mesh)
        rows.append(f"{k},{t!r}")
    (fdir / "times.csv").write_text("\n".join(rows) + "\n")


def write_hand_xdmf(path: Path, pts: np.ndarray, p: np.ndarray, material: np.ndarray,
                    topology_data: bool = True) -> None:
    """An XDMF frame written the way a C++ writer would (h5py + hand-made XML, 2-D XY).

    meshio 5 needs the Polyvertex Topology to carry a DataItem (the point indices);
    ``topology_data=False`` writes the XDMF-legal form without it, which meshio rejects.
    """
    import h5py

    h5 = path.with_suffix(".h5")
    n = len(pts)
    with h5py.File(h5, "w") as f:
        f["points"] = pts[:, :2]
        f["pressure"] = p
        f["velocity"] = np.ones((n, 2))
        f["material"] = material.astype(np.int32)
        f["vertices"] = np.arange(n, dtype=np.int64).reshape(n, 1)
    topo_item = (f'<DataItem Format="HDF" Dimensions="{n} 1" NumberType="Int" Precision="8">'
                 f'{h5.name}:/vertices</DataItem>') if topology_data else ""
    xml = f"""<?xml version="1.0"?>
<Xdmf Version="3.0"><Domain><Grid Name="particles" GridType="Uniform">
<Topology TopologyType="Polyvertex" NumberOfElements="{n}" NodesPerElement="1">{topo_item}</Topology>
<Geometry GeometryType="XY"><DataItem Format="HDF" Dimensions="{n} 2" NumberType="Float" Precision="8">{h5.name}:/points</DataItem></Geometry>
<Attribute Name="pressure" AttributeType="Scalar" Center="Node"><DataItem Format="HDF" Dimensions="{n}" NumberType="Float" Precision="8">{h5.name}:/pressure</DataItem></Attribute>
<Attribute Name="velocity" AttributeType="Vector" Center="Node"><DataItem Format="HDF" Dimensions="{n} 2" NumberType="Float" Precision="8">{h5.name}:/velocity</DataItem></Attribute>
<Attribute Name="material" AttributeType="Scalar" Center="Node"><DataItem Format="HDF" Dimensions="{n}" NumberType="Int" Precision="4">{h5.name}:/material</DataItem></Attribute>
</Grid></Domain></Xdmf>
"""
    path.write_text(xml)


def foam_grid(nx: int, ny: int, lx: float = 1.0, ly: float = 1.0
              ) -> tuple[np.ndarray, np.ndarray]:
    """Points and hexahedra of a one-cell-thick 2-D mesh (as interFoam uses)."""
    xs, ys, zs = np.linspace(0, lx, nx + 1), np.linspace(0, ly, ny + 1), np.array([0.0, 0.01])
    idx = lambda i, j, k: (k * (ny + 1) + j) * (nx + 1) + i  # noqa: E731
    pts = np.array([[x, y, z] for z in zs for y in ys for x in xs])
    hexes = [[idx(i, j, 0), idx(i + 1, j, 0), idx(i + 1, j + 1, 0), idx(i, j + 1, 0),
              idx(i, j, 1), idx(i + 1, j, 1), idx(i + 1, j + 1, 1), idx(i, j + 1, 1)]
             for j in range(ny) for i in range(nx)]
    return pts, np.array(hexes)


def write_foam_vtk(run_dir: Path, times: list[float], surface: float | Any = H,
                   nx: int = 25, ny: int = 25, case: str = "case", flat: bool = False) -> None:
    """foamToVTK-like output: VTK/<case>_<i>/internal.vtu and VTK/<case>.vtm.series.

    ``flat``: the foam_cases/run layout instead: ``VTK/<case>_<t>.vtu`` with the times in
    ``summary.json`` ``vtk_files``.
    ``surface``: water level (a number, or a function of x); alpha.water is the cell's
    fraction below it and p = rho g (level - y) in water, 0 above.
    """
    import meshio

    pts, hexes = foam_grid(nx, ny)
    centres = pts[hexes].mean(axis=1)
    lo, hi = pts[hexes].min(axis=1), pts[hexes].max(axis=1)
    level = surface(centres[:, 0]) if callable(surface) else np.full(len(centres), surface)
    alpha = np.clip((level - lo[:, 1]) / (hi[:, 1] - lo[:, 1]), 0.0, 1.0)
    p = RHO * G * np.maximum(level - centres[:, 1], 0.0)
    vtk = run_dir / "VTK"
    vtk.mkdir(parents=True, exist_ok=True)
    files = []
    if flat:
        listed = {}
        for t in times:
            mesh = meshio.Mesh(pts, [("hexahedron", hexes)],
                               cell_data={"alpha.water": [alpha], "p": [p], "p_rgh": [p]})
            meshio.write(str(vtk / f"{case}_{t:g}.vtu"), mesh)
            listed[f"{case}_{t:g}.vtu"] = t
        summary = run_dir / "summary.json"
        data = json.loads(summary.read_text()) if summary.is_file() else {"status": "ok"}
        data["vtk_files"] = listed
        summary.write_text(json.dumps(data))
        return
    for k, t in enumerate(times):
        d = vtk / f"{case}_{k * 10}"
        d.mkdir(exist_ok=True)
        mesh = meshio.Mesh(pts, [("hexahedron", hexes)],
                           cell_data={"alpha.water": [alpha], "p": [p], "p_rgh": [p]})
        meshio.write(str(d / "internal.vtu"), mesh)
        files.append({"name": f"{case}_{k * 10}.vtm", "time": t})
    (vtk / f"{case}.vtm.series").write_text(json.dumps({"file-series-version": "1.0",
                                                        "files": files}))


def hydrostatic_run(run_dir: Path, force_factor: float = 1.0, wall_time: float = 1.0,
                    dx: float = 0.02, level: int | None = None, frames: bool = True,
                    foam: bool = False) -> Path:
    """A hydrostatic run whose wall force is force_factor * rho g H^2 / 2 throughout."""
    t = np.linspace(0.0, 2.0, 201)
    write_metrics(run_dir, t, {"wall_force_x": np.full_like(t, WALL_FORCE * force_factor),
                               "max_speed": 1e-3 * np.exp(-t), "volume": np.full_like(t, 0.5)})
    extra: dict[str, Any] = {"level": level} if level is not None else {}
    if foam:
        write_summary(run_dir, wall_time_s=wall_time, cells=625, **extra)
        write_foam_vtk(run_dir, [0.0, 1.0, 2.0])
    else:
        write_summary(run_dir, wall_time_s=wall_time, dx=dx, pressure_l2_error=0.01,
                      scene={"dx": dx, "name": "hydrostatic_2d"}, **extra)
        if frames:
            pts, p = hydrostatic_particles(dx)
            write_frames(run_dir, [(0.0, pts, p), (2.0, pts, p)])
    return run_dir
