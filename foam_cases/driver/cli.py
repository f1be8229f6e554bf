"""foam_cases/run: build, run and post-process one OpenFOAM reference case.

    foam_cases/run CASE --level N [--np P] [--out DIR] [--end-time T]
                        [--work DIR] [--set FILE:ENTRY=VALUE ...] [--no-vtk]

Exit status: 0 when the run finished and every metric is finite; 1 when the
run failed or diverged (summary.json then says why, metrics.csv is not
written); 2 for a usage error (unknown case or level, bad option).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from .cases import CASE_PARAM_CHOICES, CASES, CaseSpec, Extracted, Params
from .openfoam import (FoamError, log_reached_end, log_tail, max_courant,
                       openfoam_available, openfoam_version, run_tool, set_entry,
                       solver_steps)

# A run whose Courant number went past this has left its time-step control;
# MULES keeps alpha bounded, so such a run can end "normally" with nonsense.
COURANT_LIMIT = 20.0

FOAM_CASES = Path(__file__).resolve().parents[1]
REPO = FOAM_CASES.parent


class UsageError(Exception):
    pass


def parse_args(argv: list[str]) -> argparse.Namespace:
    ap = argparse.ArgumentParser(
        prog="foam_cases/run",
        description="Run an OpenFOAM reference case and extract metrics.csv / summary.json.",
        epilog="cases: " + ", ".join(
            f"{n} (levels {','.join(map(str, s.levels))})" for n, s in CASES.items()))
    ap.add_argument("case", help="one of: " + ", ".join(CASES))
    ap.add_argument("--level", type=int, required=True, help="mesh level (1 = coarsest)")
    ap.add_argument("--np", type=int, default=1, dest="nprocs",
                    help="MPI ranks (decomposePar + mpirun when > 1)")
    ap.add_argument("--out", type=Path, help="output folder (default: the work folder)")
    ap.add_argument("--work", type=Path,
                    help="case work folder (default: foam_runs/CASE/levelN, or OUT/case with --out)")
    ap.add_argument("--end-time", type=float, help="override the end time (s)")
    ap.add_argument("--set", action="append", default=[], metavar="FILE:ENTRY=VALUE",
                    help="change a dictionary entry in the work copy with foamDictionary, "
                         "e.g. constant/dynamicMeshDict:sixDoFRigidBodyMotionCoeffs/"
                         "accelerationRelaxation=0.4 (repeatable)")
    ap.add_argument("--no-vtk", action="store_true", help="skip foamToVTK")
    return ap.parse_args(argv)


def validate(args: argparse.Namespace) -> CaseSpec:
    spec = CASES.get(args.case)
    if spec is None:
        raise UsageError(f"unknown case '{args.case}'; accepted cases: {', '.join(CASES)}")
    if args.level not in spec.levels:
        raise UsageError(f"unknown level {args.level} for case '{spec.name}'; accepted levels: "
                         f"{', '.join(map(str, spec.levels))}")
    if args.nprocs < 1:
        raise UsageError("--np must be >= 1")
    if args.end_time is not None and not (args.end_time > 0 and math.isfinite(args.end_time)):
        raise UsageError("--end-time must be a positive number")
    for s in args.set:
        if ":" not in s or "=" not in s.split(":", 1)[1]:
            raise UsageError(f"--set '{s}': expected FILE:ENTRY=VALUE")
        file, rest = s.split(":", 1)
        entry, value = rest.split("=", 1)
        choices = CASE_PARAM_CHOICES.get(entry)
        if file == "system/caseParams" and choices and value not in choices:
            raise UsageError(f"--set '{s}': caseParams entry '{entry}' accepts {', '.join(choices)}")
    for option, path in (("--out", args.out), ("--work", args.work)):
        if path is not None and path.exists() and not path.is_dir():
            raise UsageError(f"{option} '{path}': exists and is not a folder; accepted: a folder or a new path")
    return spec


def write_case_params(case: Path, p: Params) -> None:
    def fmt(v: object) -> str:
        if isinstance(v, (tuple, list)):
            return "(" + " ".join(fmt(x) for x in v) + ")"
        if isinstance(v, float):
            return repr(v)
        return str(v)
    lines = ["FoamFile { version 2.0; format ascii; class dictionary; object caseParams; }",
             "// Written by foam_cases/run for this level; do not edit.", ""]
    lines += [f"{k:<20} {fmt(v)};" for k, v in p.items()]
    (case / "system" / "caseParams").write_text("\n".join(lines) + "\n")


def decompose_dict(case: Path, nprocs: int) -> None:
    (case / "system" / "decomposeParDict").write_text(
        "FoamFile { version 2.0; format ascii; class dictionary; object decomposeParDict; }\n"
        f"numberOfSubdomains {nprocs};\n"
        # Strips along x: 'simple' is built in (Debian's scotch plug-in can
        # resolve to the dummy stub).
        f"method simple;\nsimpleCoeffs {{ n ({nprocs} 1 1); delta 0.001; }}\n")


def atomic_write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    with os.fdopen(fd, "w") as fh:
        fh.write(text)
    os.replace(tmp, path)


def metrics_csv(ex: Extracted) -> str:
    names = list(ex.columns)
    lines = [",".join(["t"] + names)]
    for i, t in enumerate(ex.times):
        lines.append(",".join([f"{t:.9g}"] + [f"{ex.columns[n][i]:.9g}" for n in names]))
    return "\n".join(lines) + "\n"


def run_case(args: argparse.Namespace, spec: CaseSpec) -> int:
    level = args.level
    work = args.work or ((args.out / "case") if args.out else
                         REPO / "foam_runs" / spec.name / f"level{level}")
    work = work.resolve()
    out = (args.out or work).resolve()
    out.mkdir(parents=True, exist_ok=True)
    # Stale results of an earlier run must not survive a failed one.
    for stale in ("metrics.csv", "summary.json"):
        (out / stale).unlink(missing_ok=True)
    if (out / "VTK").exists():
        shutil.rmtree(out / "VTK")

    p = spec.params(level)
    if args.end_time is not None:
        def same_type(old: object, new: float) -> object:
            # Iteration counts (steady solver) stay integers for OpenFOAM.
            return int(round(new)) if isinstance(old, int) else new
        p["endTime"] = same_type(p["endTime"], args.end_time)
        for key in ("writeInterval", "sampleInterval"):
            p[key] = same_type(p[key], min(float(p[key]), args.end_time))  # type: ignore[arg-type]
    end_time = float(p["endTime"])  # type: ignore[arg-type]

    summary: dict[str, object] = {
        "status": "running", "case": spec.name, "level": level, "solver": spec.solver,
        "openfoam_version": openfoam_version(), "end_time": end_time,
        "cells": int(p["cells"]), "np": args.nprocs,  # type: ignore[arg-type]
        "work_dir": str(work), "params": p, "set": args.set,
    }
    t_start = time.perf_counter()
    solver_log = work / f"log.{spec.solver}"
    try:
        if work.exists():
            shutil.rmtree(work)
        shutil.copytree(FOAM_CASES / spec.folder, work,
                        ignore=shutil.ignore_patterns("README*", "*.md"))
        write_case_params(work, p)
        # caseParams first: foamDictionary expands the $macros of a file it
        # edits, so a file edited later must see the final caseParams.
        for s in sorted(args.set, key=lambda s: not s.startswith("system/caseParams:")):
            file, rest = s.split(":", 1)
            entry, value = rest.split("=", 1)
            set_entry(work, file, entry, value)

        setup_wall = 0.0
        used: dict[str, int] = {}
        for cmd in spec.setup:
            # A tool run twice (floating_block: body and background mesh)
            # logs to log.<tool>, then log.<tool>.2, ...
            used[cmd[0]] = used.get(cmd[0], 0) + 1
            log_name = cmd[0] if used[cmd[0]] == 1 else f"{cmd[0]}.{used[cmd[0]]}"
            setup_wall += run_tool(work, list(cmd), log_name)
        summary["setup_wall_time_s"] = round(setup_wall, 3)

        if args.nprocs > 1:
            decompose_dict(work, args.nprocs)
            run_tool(work, ["decomposePar", "-force"], "decomposePar")
        wall = None
        try:
            wall = run_tool(work, [spec.solver], spec.solver, np_=args.nprocs)
        finally:
            steps = solver_steps(solver_log) if solver_log.exists() else []
            summary["steps"] = len(steps)
            summary["last_time"] = steps[-1] if steps else 0.0
        summary["wall_time_s"] = round(wall, 3)
        if not log_reached_end(solver_log) or not steps:
            raise FoamError(f"{spec.solver} did not finish (no 'End' in its log)", solver_log)
        if steps[-1] < end_time * (1 - 1e-6):
            raise FoamError(f"{spec.solver} stopped at t = {summary['last_time']} "
                            f"before the end time {end_time}", solver_log)
        co = max_courant(solver_log)
        summary["max_courant"] = co
        if co > COURANT_LIMIT:
            raise FoamError(f"unstable run: max Courant number {co:g} > {COURANT_LIMIT:g}",
                            solver_log)
        if args.nprocs > 1:
            run_tool(work, ["reconstructPar"], "reconstructPar")

        ex = spec.extract(work, p, solver_log)
        if len(ex.times) == 0:
            raise FoamError("no metric rows could be extracted", solver_log)
        bad = [n for n, c in ex.columns.items() if not np.all(np.isfinite(c))]
        if bad:
            raise FoamError(f"non-finite values in metrics {', '.join(bad)} (diverged?)",
                            solver_log)
        sample = float(p.get("sampleInterval", 0.0))  # type: ignore[arg-type]
        if ex.times[-1] < end_time - sample - 1e-9:
            raise FoamError(f"metrics end at t = {ex.times[-1]}, before {end_time}", solver_log)

        if not args.no_vtk:
            run_tool(work, ["foamToVTK", "-no-boundary", "-name", "VTK_foam", "-fields",
                            "(" + " ".join(spec.vtk_fields) + ")"], "foamToVTK")
            summary["vtk_dir"] = str(out / "VTK")
            summary["vtk_files"] = flatten_vtk(work / "VTK_foam", out / "VTK", spec.name)

        summary.update(ex.scalars)
        summary["status"] = "ok"
        summary["metrics"] = list(ex.columns)
        summary["rows"] = len(ex.times)
        summary["total_wall_time_s"] = round(time.perf_counter() - t_start, 3)
        atomic_write(out / "metrics.csv", metrics_csv(ex))
        atomic_write(out / "summary.json", json.dumps(summary, indent=2, default=_json) + "\n")
        print(f"{spec.name} level {level}: ok, {summary['cells']} cells, "
              f"{summary['steps']} steps, {summary['wall_time_s']} s -> {out}")
        return 0
    except (FoamError, FileNotFoundError, ValueError, IndexError, KeyError) as exc:
        tail = exc.tail if isinstance(exc, FoamError) else log_tail(
            solver_log if solver_log.exists() else None)
        summary["status"] = f"failed: {exc}"
        summary["log_tail"] = tail
        summary["total_wall_time_s"] = round(time.perf_counter() - t_start, 3)
        summary.setdefault("wall_time_s", None)
        atomic_write(out / "summary.json", json.dumps(summary, indent=2, default=_json) + "\n")
        print(f"{spec.name} level {level}: FAILED: {exc}", file=sys.stderr)
        if tail:
            print("---- last lines of the log ----", file=sys.stderr)
            print(tail, file=sys.stderr)
        return 1


def flatten_vtk(src: Path, dst: Path, name: str) -> dict[str, float]:
    """Copy foamToVTK's internal meshes to dst/<name>_<time>.vtu.

    foamToVTK writes <dir>_<timeIndex>/internal.vtu plus a .vtm.series
    file that maps each index to its time."""
    if dst.exists():
        shutil.rmtree(dst)
    dst.mkdir(parents=True)
    files: dict[str, float] = {}
    for series in sorted(src.glob("*.vtm.series")):
        for item in json.loads(series.read_text())["files"]:
            stem = item["name"][: -len(".vtm")]
            t = float(item["time"])
            internal = src / stem / "internal.vtu"
            if internal.exists():
                target = f"{name}_{t:g}.vtu"
                shutil.copyfile(internal, dst / target)
                files[target] = t
    if not files:
        raise FoamError(f"foamToVTK wrote no internal mesh under {src}")
    return files


def _is_number(s: str) -> bool:
    try:
        float(s)
        return True
    except ValueError:
        return False


def _json(o: object) -> object:
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(type(o))


def main(argv: list[str] | None = None) -> int:
    args = parse_args(sys.argv[1:] if argv is None else argv)
    try:
        spec = validate(args)
    except UsageError as exc:
        print(f"foam_cases/run: error: {exc}", file=sys.stderr)
        return 2
    ok, why = openfoam_available()
    if not ok:
        print(f"foam_cases/run: error: {why}", file=sys.stderr)
        return 3
    return run_case(args, spec)
