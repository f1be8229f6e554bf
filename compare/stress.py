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

The physics checks, their thresholds and why: ``compare/stress_checks.py``.

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

from compare.io import REPO_ROOT, RUN_RECORD, CompareError, read_summary
from compare.stress_checks import Check, physics_checks

STABLE, STOPPED, ADAPTED, WRONG, NO_RESULT = "stable", "stopped", "adapted", "wrong", "no result"
CLASSES = (STABLE, ADAPTED, STOPPED, WRONG, NO_RESULT)
CLASS_LABELS = {STABLE: "stable and plausible", ADAPTED: "adapted (dt retried)",
                STOPPED: "stopped with a diagnosis", WRONG: "wrong (a physics check failed)",
                NO_RESULT: "no result (crash, interrupt, timeout)"}
CLASS_MARKS = {STABLE: "S", ADAPTED: "A", STOPPED: "D", WRONG: "W", NO_RESULT: "N"}  # heat map
CLASS_COLOURS = {STABLE: "#4daf4a", ADAPTED: "#377eb8", STOPPED: "#ffbf00", WRONG: "#e41a1c",
                 NO_RESULT: "#6a3d9a"}



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


# --------------------------------------------------------------------------- classification


@dataclass
class Verdict:
    cls: str
    reason: str
    checks: list[Check] = field(default_factory=list)


def _log_reason(run_dir: Path) -> str:
    """The solver's last log line, without its "[hh:mm:ss] " stamp."""
    from compare.children import last_log_line

    line = last_log_line(run_dir / "iqmpm.log")
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
    from compare.children import run_child

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
    from compare.children import Progress

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
    lines += ["", "Classes and checks: compare/README.md (stress), compare/stress.py and "
              "compare/stress_checks.py.", "",
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
