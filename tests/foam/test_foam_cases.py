"""CI checks of foam_cases/run (the OpenFOAM reference-case driver).

Run from the repository root:  /usr/bin/python3 -m pytest -q tests/foam
The OpenFOAM runs are skipped, with the reason shown, only where OpenFOAM is
not installed (no /usr/share/openfoam/etc/bashrc).
"""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
RUN = REPO / "foam_cases" / "run"
BASHRC = Path("/usr/share/openfoam/etc/bashrc")

needs_openfoam = pytest.mark.skipif(
    not BASHRC.exists(), reason=f"OpenFOAM not installed ({BASHRC} missing)")


def run(*args: str, timeout: float = 150) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(RUN), *args], cwd=REPO,
                          capture_output=True, text=True, timeout=timeout)


def test_unknown_case_is_a_clear_error(tmp_path: Path) -> None:
    r = run("no_such_case", "--level", "1", "--out", str(tmp_path))
    assert r.returncode == 2
    assert "unknown case 'no_such_case'" in r.stderr
    for name in ("dam_break", "dam_break_obstacle", "hydrostatic", "floating_block",
                 "floating_block_roll", "floating_block_light", "cantilever"):
        assert name in r.stderr
    assert not (tmp_path / "summary.json").exists()


def test_unknown_level_is_a_clear_error(tmp_path: Path) -> None:
    r = run("dam_break", "--level", "9", "--out", str(tmp_path))
    assert r.returncode == 2
    assert "unknown level 9" in r.stderr and "accepted levels: 1, 2, 3, 4" in r.stderr


def test_malformed_set_is_a_clear_error(tmp_path: Path) -> None:
    r = run("dam_break", "--level", "1", "--set", "controlDict", "--out", str(tmp_path))
    assert r.returncode == 2
    assert "FILE:ENTRY=VALUE" in r.stderr


def test_case_parameter_outside_its_values_is_a_clear_error(tmp_path: Path) -> None:
    r = run("dam_break", "--level", "1", "--set", "system/caseParams:wallVelocity=sticky",
            "--out", str(tmp_path))
    assert r.returncode == 2
    assert "'wallVelocity' accepts slip, noSlip" in r.stderr
    assert not (tmp_path / "summary.json").exists()


def wall_velocity_types(u_file: Path) -> dict[str, str]:
    """Patch name -> type of the wall patches in a written U field."""
    text = u_file.read_text()
    return {patch: text.split(patch, 1)[1].split("type", 1)[1].split(";", 1)[0].strip()
            for patch in ("leftWall", "rightWall", "lowerWall")}


def test_out_that_is_a_file_is_a_clear_error(tmp_path: Path) -> None:
    target = tmp_path / "a_file"
    target.write_text("not a folder\n")
    r = run("dam_break", "--level", "1", "--out", str(target))
    assert r.returncode == 2
    assert "exists and is not a folder" in r.stderr
    assert "Traceback" not in r.stderr
    assert target.read_text() == "not a folder\n"


@needs_openfoam
def test_dam_break_short_run_extracts_metrics(tmp_path: Path) -> None:
    out = tmp_path / "out"
    r = run("dam_break", "--level", "1", "--end-time", "0.05", "--out", str(out))
    assert r.returncode == 0, r.stdout + r.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "ok"
    for key in ("wall_time_s", "steps", "cells", "level", "case", "end_time", "solver",
                "openfoam_version"):
        assert key in summary, key
    assert summary["case"] == "dam_break" and summary["level"] == 1
    assert summary["cells"] == 1600 and summary["steps"] > 10
    assert summary["end_time"] == pytest.approx(0.05)
    with open(out / "metrics.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert rows, "metrics.csv has no rows"
    assert list(rows[0])[:1] == ["t"]
    for col in ("front_x", "height_left", "pressure_right", "pressure_right_3cm",
                "pressure_right_6cm", "pressure_right_10cm", "volume"):
        assert col in rows[0], col
        assert all(math.isfinite(float(r[col])) for r in rows), col
    # The water reaches the right wall after about 0.2 s: until then its probes read the
    # air, a few Pa (its column's weight), not the water's kPa.
    for col in ("pressure_right", "pressure_right_3cm", "pressure_right_6cm", "pressure_right_10cm"):
        assert abs(float(rows[-1][col])) < 50, col
    assert float(rows[-1]["t"]) == pytest.approx(0.05)
    # Physical sanity at t = 0.05 s: the front has left x = a, the column
    # has dropped, the water volume is a x 2a per unit depth.
    assert 0.146 < float(rows[-1]["front_x"]) < 0.3
    assert 0.2 < float(rows[-1]["height_left"]) < 0.292
    assert float(rows[-1]["volume"]) == pytest.approx(0.146 * 0.292, rel=1e-3)
    vtk = sorted(p.name for p in (out / "VTK").glob("*.vtu"))
    assert vtk == ["dam_break_0.05.vtu", "dam_break_0.vtu"]
    # The walls slip, as the model's do (method.md section 1), unless a run asks otherwise.
    assert set(wall_velocity_types(out / "case" / "0.05" / "U").values()) == {"slip"}


@needs_openfoam
def test_dam_break_walls_can_be_no_slip(tmp_path: Path) -> None:
    out = tmp_path / "out"
    r = run("dam_break", "--level", "1", "--end-time", "0.01", "--no-vtk", "--out", str(out),
            "--set", "system/caseParams:wallVelocity=noSlip")
    assert r.returncode == 0, r.stdout + r.stderr
    assert set(wall_velocity_types(out / "case" / "0.01" / "U").values()) == {"noSlip"}


@needs_openfoam
def test_failed_openfoam_run_is_reported_not_extracted(tmp_path: Path) -> None:
    # A real solver failure: an unknown linear solver for p_rgh makes interFoam
    # stop with a FOAM FATAL ERROR at its first pressure solve.
    out = tmp_path / "out"
    r = run("dam_break", "--level", "1", "--end-time", "0.01", "--out", str(out),
            "--set", "system/fvSolution:solvers/p_rgh/solver=noSuchSolver")
    assert r.returncode == 1
    assert "FAILED" in r.stderr and "last lines of the log" in r.stderr
    assert "noSuchSolver" in r.stderr          # the log tail is printed
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] != "ok" and summary["status"].startswith("failed")
    assert "noSuchSolver" in summary["log_tail"]
    assert not (out / "metrics.csv").exists()


@needs_openfoam
def test_failed_floating_block_run_is_reported_failed(tmp_path: Path) -> None:
    # The floating_block cases now run (overset, foam_cases/floating_block/
    # README.md), so the failure path of the overset solver is checked with an
    # impossible setting: an unknown linear solver for p_rgh makes
    # overInterDyMFoam stop with a FOAM FATAL ERROR.
    out = tmp_path / "out"
    r = run("floating_block", "--level", "1", "--end-time", "0.1", "--out", str(out),
            "--no-vtk",
            "--set", "system/fvSolution:solvers/p_rgh/solver=noSuchSolver")
    assert r.returncode == 1, r.stdout + r.stderr
    assert "last lines of the log" in r.stderr
    assert "noSuchSolver" in r.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"].startswith("failed")
    assert summary["log_tail"]
    assert not (out / "metrics.csv").exists()


@needs_openfoam
def test_floating_block_short_run_extracts_metrics(tmp_path: Path) -> None:
    # Overset formulation (foam_cases/floating_block/README.md): a short run
    # must give every metric; the water area is 0.5 - 0.2 x 0.03 = 0.494 m^2.
    out = tmp_path / "out"
    r = run("floating_block", "--level", "1", "--end-time", "0.05", "--out", str(out),
            "--no-vtk")
    assert r.returncode == 0, r.stdout + r.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "ok"
    assert summary["solver"] == "overInterDyMFoam"
    with open(out / "metrics.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 5
    for col in ("com_x", "com_y", "angle", "block_force_x", "block_force_y", "volume",
                "max_speed", "water_level"):
        assert all(math.isfinite(float(row[col])) for row in rows), col
    assert abs(float(rows[0]["volume"]) - 0.494) < 1e-3
    assert abs(float(rows[0]["com_y"]) - 0.52) < 0.005
    assert abs(float(rows[-1]["com_x"]) - 0.5) < 1e-3


@needs_openfoam
def test_run_past_its_stability_limit_is_reported_failed(tmp_path: Path) -> None:
    # A fixed time step of 0.05 s (Courant number > 100) does not crash
    # interFoam (MULES keeps alpha bounded) but the result is meaningless;
    # the driver must not extract it as fine.
    out = tmp_path / "out"
    r = run("dam_break", "--level", "1", "--end-time", "0.3", "--out", str(out),
            "--no-vtk",
            "--set", "system/controlDict:adjustTimeStep=no",
            "--set", "system/controlDict:deltaT=0.05")
    assert r.returncode == 1, r.stdout + r.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"].startswith("failed: unstable run: max Courant number")
    assert not (out / "metrics.csv").exists()


def test_driver_reads_reference_data_from_the_repository(monkeypatch) -> None:
    # A clone needs nothing beside it: the Koshizuka & Oka front behind the summary's
    # front_l2_vs_koshizuka_oka is read from <repo>/data.
    import numpy as np

    monkeypatch.syspath_prepend(str(REPO / "foam_cases"))
    monkeypatch.delenv("IQMPM_DATA_DIR", raising=False)
    from driver import cases

    path = cases._data_file(cases.KO_DATA)
    assert path == REPO / "data" / "koshizuka_oka_1996_surge_front_pysph.csv"
    data = np.loadtxt(path, delimiter=",", comments="#", skiprows=4)
    T, Z = data[1:, 0], data[1:, 1]  # T > 0: the driver prepends the initial (0, 1)
    t = T / math.sqrt(2 * 9.81 / 0.146)
    exact = cases.koshizuka_oka_error(t, Z * 0.146)
    assert exact["front_l2_vs_koshizuka_oka"] < 1e-12 and exact["front_l2_points"] >= 6
    ahead = cases.koshizuka_oka_error(t, 1.1 * Z * 0.146)["front_l2_vs_koshizuka_oka"]
    assert 0.08 < ahead < 0.1  # 10 % ahead at every point but the initial one
    monkeypatch.setenv("IQMPM_DATA_DIR", str(REPO / "nowhere"))
    assert cases._data_file(cases.KO_DATA) == path  # falls back to the repository's copy
