"""``compare validate``: run every benchmark with IQ-MPM and OpenFOAM, compare, report.

Stages per benchmark: IQ-MPM at each level (level L: dx = default_dx / 2^(L-1)), the
OpenFOAM case at each level (cached under foam_runs/ by a hash of its inputs), then the
comparison and report. Child processes run ``--jobs`` at a time; progress is printed as one
line per stage with the elapsed time, plus a heartbeat line while a child runs.
"""

from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
import threading
import time
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence, TextIO

from compare import analysis, report
from compare.io import RUN_RECORD, CompareError, Run, read_run, read_summary, summary_ok
from compare.registry import Benchmark, lookup

CACHE_STAMP = "compare_cache.json"


# --------------------------------------------------------------------------- settings


@dataclass
class Settings:
    repo: Path
    out: Path
    runs_dir: Path
    foam_runs_dir: Path
    data_dir: Path
    solver_bin: Path
    levels: list[int]
    jobs: int = 1
    threads: int = 1
    foam_np: int = 1
    foam_end_time: float | None = None
    sets: list[str] = field(default_factory=list)
    timeout: float = 900.0
    reuse_solver: bool = False
    foam_cache: bool = True
    progress_interval: float = 10.0
    fluid_material: int = 0
    benchmarks: list[str] = field(default_factory=list)


# --------------------------------------------------------------------------- discovery


@dataclass
class Scene:
    name: str  # scene stem
    folder: str  # benchmarks/<folder>/
    path: Path


def discover(repo: Path, names: Sequence[str] = ()) -> list[Scene]:
    """Scenes ``benchmarks/*/*.json``; ``names`` selects by stem or folder name."""
    scenes = [Scene(p.stem, p.parent.name, p)
              for p in sorted((repo / "benchmarks").glob("*/*.json"))]
    if names:
        known = {s.name for s in scenes} | {s.folder for s in scenes}
        unknown = [n for n in names if n not in known]
        if unknown:
            raise CompareError(
                f"unknown benchmark(s): {', '.join(unknown)} (found: "
                f"{', '.join(sorted(s.name for s in scenes)) or 'none in benchmarks/*/*.json'})"
            )
        scenes = [s for s in scenes if s.name in names or s.folder in names]
    return scenes


def find_dx(scene: Any) -> float | None:
    """The cell size of a scene JSON: key "dx" at top level, else the first nested one."""
    if isinstance(scene, dict):
        if isinstance(scene.get("dx"), (int, float)):
            return float(scene["dx"])
        for value in scene.values():
            found = find_dx(value)
            if found is not None:
                return found
    elif isinstance(scene, list):
        for value in scene:
            found = find_dx(value)
            if found is not None:
                return found
    return None


# --------------------------------------------------------------------------- hashing


def _hash_files(h: "hashlib._Hash", root: Path, paths: Sequence[Path]) -> None:
    for p in sorted(paths):
        if p.is_file():
            h.update(str(p.relative_to(root)).encode())
            h.update(b"\0")
            h.update(p.read_bytes())
            h.update(b"\0")


def foam_inputs_hash(foam_dir: Path, case: str, level: int, options: dict[str, Any]) -> str:
    """sha256 of the case template folder, the driver (top-level files), level, options."""
    h = hashlib.sha256()
    case_dir = foam_dir / case
    _hash_files(h, foam_dir, [p for p in case_dir.rglob("*") if p.is_file()])
    _hash_files(h, foam_dir, [p for p in foam_dir.iterdir() if p.is_file()])
    h.update(json.dumps({"level": level, **options}, sort_keys=True).encode())
    return h.hexdigest()


def solver_inputs_hash(solver_bin: Path, scene: Path, args: Sequence[str]) -> str:
    h = hashlib.sha256()
    for p in (solver_bin, scene):
        h.update(p.read_bytes() if p.is_file() else str(p).encode())
    h.update(json.dumps(list(args)).encode())
    return h.hexdigest()


def cached(out_dir: Path, key: str) -> bool:
    stamp = out_dir / CACHE_STAMP
    if not stamp.is_file() or not (out_dir / "metrics.csv").is_file():
        return False
    try:
        if json.loads(stamp.read_text()).get("key") != key:
            return False
        return summary_ok(read_summary(out_dir / "summary.json"))
    except (CompareError, json.JSONDecodeError, OSError):
        return False


# --------------------------------------------------------------------------- progress


class Progress:
    """Thread-safe progress lines ``[elapsed] benchmark | stage | message``."""

    def __init__(self, stream: TextIO | None = None, interval: float = 10.0) -> None:
        self.start = time.monotonic()
        self.stream = stream if stream is not None else sys.stdout
        self.interval = interval
        self.lock = threading.Lock()

    def elapsed(self) -> float:
        return time.monotonic() - self.start

    def line(self, bench: str, stage: str, message: str) -> None:
        with self.lock:
            self.stream.write(f"[{self.elapsed():7.1f} s] {bench} | {stage} | {message}\n")
            self.stream.flush()


def _last_log_line(log: Path) -> str:
    try:
        with open(log, "rb") as fh:
            fh.seek(max(0, log.stat().st_size - 4096))
            tail = fh.read().decode(errors="replace")
    except OSError:
        return ""
    parts = [p.strip() for p in tail.replace("\r", "\n").split("\n")
             if p.strip() and not p.startswith("$ ")]  # skip our own command echo
    return parts[-1][:100] if parts else ""


@dataclass
class ChildResult:
    returncode: int
    elapsed: float
    timed_out: bool


def run_child(cmd: list[str], log: Path, progress: Progress, bench: str, stage: str,
              timeout: float, cwd: Path, env: dict[str, str] | None = None) -> ChildResult:
    """Run ``cmd`` with output to ``log``; heartbeat lines while it runs; kill on timeout."""
    log.parent.mkdir(parents=True, exist_ok=True)
    t0 = time.monotonic()
    with open(log, "wb") as fh:
        fh.write(("$ " + " ".join(cmd) + "\n").encode())
        fh.flush()
        try:
            proc = subprocess.Popen(cmd, stdout=fh, stderr=subprocess.STDOUT, cwd=cwd, env=env,
                                    start_new_session=True)
        except OSError as exc:
            fh.write(f"cannot start: {exc}\n".encode())
            return ChildResult(127, 0.0, False)
        next_beat = t0 + progress.interval
        shown = ""
        quiet_beats = 0
        while True:
            try:
                rc = proc.wait(timeout=0.2)
                break
            except subprocess.TimeoutExpired:
                pass
            now = time.monotonic()
            if now - t0 > timeout:
                os.killpg(proc.pid, signal.SIGKILL)  # our own child's process group
                proc.wait()
                return ChildResult(-9, now - t0, True)
            if now >= next_beat:
                # a line when the child's log moved on, else every 6 intervals
                last = _last_log_line(log)
                if last != shown or quiet_beats >= 5:
                    progress.line(bench, stage, f"running {now - t0:.0f} s"
                                  + (f": {last}" if last else ""))
                    shown, quiet_beats = last, 0
                else:
                    quiet_beats += 1
                next_beat = now + progress.interval
    return ChildResult(rc, time.monotonic() - t0, False)


# --------------------------------------------------------------------------- one run


@dataclass
class RunOutcome:
    run: Run | None
    status: str  # "ok", "cached", or failure text
    failed: bool


def _record(out_dir: Path, data: dict[str, Any]) -> None:
    (out_dir / RUN_RECORD).write_text(json.dumps(data, indent=1))


def run_iqmpm(s: Settings, scene: Scene, level: int, default_dx: float | None,
              progress: Progress) -> RunOutcome:
    stage = f"IQ-MPM level {level}"
    out_dir = s.runs_dir / scene.name / "iqmpm" / f"level{level}"
    args = ["run", str(scene.path), "--out", str(out_dir), "--threads", str(s.threads)]
    for kv in s.sets:
        args += ["--set", kv]
    dx = None
    if level > 1:
        if default_dx is None:
            return RunOutcome(None, "default dx unknown (no 'dx' in the scene and no level-1 "
                                    "summary)", True)
        dx = default_dx / 2 ** (level - 1)
        args += ["--set", f"dx={dx:.10g}"]
    if not s.solver_bin.is_file():
        progress.line(scene.name, stage, f"FAILED: solver binary {s.solver_bin} not found")
        return RunOutcome(None, f"solver binary {s.solver_bin} not found", True)
    key = solver_inputs_hash(s.solver_bin, scene.path, args)
    if s.reuse_solver and cached(out_dir, key):
        progress.line(scene.name, stage, f"reused {out_dir}")
        return RunOutcome(read_run(out_dir, "iqmpm"), "cached", False)
    out_dir.mkdir(parents=True, exist_ok=True)
    for stale in ("summary.json", "metrics.csv", CACHE_STAMP):
        (out_dir / stale).unlink(missing_ok=True)
    cmd = [str(s.solver_bin)] + args
    progress.line(scene.name, stage, "started")
    timeout = max(s.timeout, lookup(scene.name, scene.folder).min_timeout)
    res = run_child(cmd, out_dir / "iqmpm.log", progress, scene.name, stage, timeout, s.repo)
    _record(out_dir, {"solver": "iqmpm", "level": level, "dx": dx, "command": cmd,
                      "threads": s.threads, "elapsed_s": res.elapsed, "returncode": res.returncode})
    return _finish(out_dir, "iqmpm", res, key, progress, scene.name, stage, timeout)


def _finish(out_dir: Path, solver: str, res: ChildResult, key: str, progress: Progress,
            bench: str, stage: str, timeout: float) -> RunOutcome:
    log = out_dir / ("iqmpm.log" if solver == "iqmpm" else "foam.log")
    if res.timed_out:
        status = f"timed out after {timeout:g} s (log {log})"
    elif not (out_dir / "summary.json").is_file():
        status = f"exit code {res.returncode}, no summary.json (log {log})"
    else:
        try:
            run = read_run(out_dir, solver)
        except CompareError as exc:
            status = f"unreadable output: {exc}"
        else:
            if run.ok and res.returncode == 0:
                (out_dir / CACHE_STAMP).write_text(json.dumps({"key": key}))
                progress.line(bench, stage, f"done in {res.elapsed:.1f} s")
                return RunOutcome(run, "ok", False)
            status = (run.status if not run.ok else f"exit code {res.returncode}")
            progress.line(bench, stage, f"FAILED after {res.elapsed:.1f} s: {status}")
            return RunOutcome(run, status, True)
    progress.line(bench, stage, f"FAILED after {res.elapsed:.1f} s: {status}")
    return RunOutcome(None, status, True)


def run_foam(s: Settings, case: str, bench: str, level: int, progress: Progress) -> RunOutcome:
    stage = f"OpenFOAM level {level}"
    foam_dir = s.repo / "foam_cases"
    driver = foam_dir / "run"
    out_dir = s.foam_runs_dir / case / f"level{level}"
    options = {"np": s.foam_np, "end_time": s.foam_end_time}
    key = foam_inputs_hash(foam_dir, case, level, options)
    if s.foam_cache and cached(out_dir, key):
        progress.line(bench, stage, f"reused cache {out_dir}")
        return RunOutcome(read_run(out_dir, "interFoam"), "cached", False)
    cmd = [str(driver), case, "--level", str(level), "--np", str(s.foam_np), "--out", str(out_dir)]
    if s.foam_end_time is not None:
        cmd += ["--end-time", f"{s.foam_end_time:g}"]
    out_dir.mkdir(parents=True, exist_ok=True)
    for stale in ("summary.json", "metrics.csv", CACHE_STAMP):
        (out_dir / stale).unlink(missing_ok=True)
    progress.line(bench, stage, "started")
    res = run_child(cmd, out_dir / "foam.log", progress, bench, stage, s.timeout, s.repo)
    _record(out_dir, {"solver": "interFoam", "level": level, "command": cmd, "np": s.foam_np,
                      "elapsed_s": res.elapsed, "returncode": res.returncode})
    return _finish(out_dir, "interFoam", res, key, progress, bench, stage, s.timeout)


# --------------------------------------------------------------------------- orchestration


@dataclass
class BenchPlan:
    scene: Scene
    bench: Benchmark
    ours: dict[int, Future] = field(default_factory=dict)
    foam: dict[int, Future] = field(default_factory=dict)
    foam_status: str = ""


def validate(s: Settings, progress: Progress | None = None) -> int:
    """Run everything; write reports and the index. Returns the exit status."""
    progress = progress or Progress(interval=s.progress_interval)
    scenes = discover(s.repo, s.benchmarks)
    if not scenes:
        raise CompareError(f"no benchmarks found in {s.repo / 'benchmarks'}/*/*.json")
    if not s.benchmarks:  # the quick suite: long benchmarks only when named
        long = [sc.name for sc in scenes if not lookup(sc.name, sc.folder).quick]
        scenes = [sc for sc in scenes if lookup(sc.name, sc.folder).quick]
        if long:
            progress.line("validate", "plan", f"not in the quick suite (run them with --benchmark NAME): "
                          f"{', '.join(long)}")
    progress.line("validate", "plan", f"{len(scenes)} benchmark(s): "
                  f"{', '.join(sc.name for sc in scenes)}; levels {s.levels}; jobs {s.jobs}")
    foam_dir = s.repo / "foam_cases"
    plans: list[BenchPlan] = []
    with ThreadPoolExecutor(max_workers=max(1, s.jobs)) as pool:
        for scene in scenes:
            bench = lookup(scene.name, scene.folder)
            plan = BenchPlan(scene, bench)
            plans.append(plan)
            try:
                scene_dx = find_dx(json.loads(scene.path.read_text()))
            except (OSError, json.JSONDecodeError):
                scene_dx = None
            levels = sorted(set(s.levels))
            first = plan.ours[levels[0]] = pool.submit(
                run_iqmpm, s, scene, levels[0], scene_dx, progress)
            for level in levels[1:]:
                plan.ours[level] = pool.submit(_later_level, s, scene, level, scene_dx, first,
                                               levels[0], progress)
            case = bench.foam_case
            if not case or not (foam_dir / case).is_dir():
                plan.foam_status = "no OpenFOAM case"
                progress.line(scene.name, "OpenFOAM", f"no OpenFOAM case "
                              f"({'none registered' if not case else foam_dir / case})")
            elif not (foam_dir / "run").is_file():
                plan.foam_status = f"no OpenFOAM driver ({foam_dir / 'run'})"
                progress.line(scene.name, "OpenFOAM", plan.foam_status)
            else:
                for level in levels:
                    plan.foam[level] = pool.submit(run_foam, s, case, scene.name, level, progress)
        entries = [_compare_plan(s, plan, progress) for plan in plans]
    index = report.write_index(report.read_entries(s.out), s.out, _settings_table(s))
    failed = [e.name for e in entries if e.failed]
    progress.line("validate", "index", f"wrote {index}; "
                  + (f"FAILED: {', '.join(failed)}" if failed else "all runs succeeded"))
    return 1 if failed else 0


def _later_level(s: Settings, scene: Scene, level: int, scene_dx: float | None, first: Future,
                 first_level: int, progress: Progress) -> RunOutcome:
    dx = scene_dx
    if dx is None:
        outcome: RunOutcome = first.result()
        if outcome.run is not None and outcome.run.dx:
            dx = outcome.run.dx * 2 ** (first_level - 1)
    return run_iqmpm(s, scene, level, dx, progress)


def _settings_table(s: Settings) -> dict[str, Any]:
    return {"levels": ",".join(map(str, s.levels)), "solver": s.solver_bin,
            "runs": s.runs_dir, "foam runs": s.foam_runs_dir, "data": s.data_dir,
            "jobs": s.jobs, "threads per run": s.threads, "OpenFOAM np": s.foam_np,
            "extra --set": " ".join(s.sets) or "-", "timeout per run (s)": s.timeout}


def _compare_plan(s: Settings, plan: BenchPlan, progress: Progress) -> report.IndexEntry:
    name = plan.scene.name
    ours = {lv: f.result() for lv, f in plan.ours.items()}
    foam = {lv: f.result() for lv, f in plan.foam.items()}
    failed = any(o.failed for o in ours.values()) or any(o.failed for o in foam.values())
    ours_text = "; ".join(f"L{lv} {'ok' if not o.failed else 'FAILED: ' + o.status}"
                          for lv, o in sorted(ours.items()))
    foam_text = plan.foam_status or "; ".join(
        f"L{lv} {('ok' if o.status == 'ok' else o.status) if not o.failed else 'FAILED: ' + o.status}"
        for lv, o in sorted(foam.items()))
    out_dir = s.out / name
    t0 = time.monotonic()
    progress.line(name, "compare", "started")
    try:
        result = analysis.analyse(plan.bench, [o.run for o in ours.values() if o.run],
                                  [o.run for o in foam.values() if o.run], out_dir,
                                  analysis.Options(s.data_dir, s.fluid_material))
        extra = [f"IQ-MPM level {lv}: FAILED ({o.status})" for lv, o in ours.items() if o.failed
                 and o.run is None]
        extra += [f"OpenFOAM: {plan.foam_status}"] if plan.foam_status else []
        extra += [f"OpenFOAM level {lv}: FAILED ({o.status})" for lv, o in foam.items()
                  if o.failed and o.run is None]
        path = report.write_report(result, out_dir, extra, s.solver_bin)
        head = report.headline(result)
        progress.line(name, "compare", f"done in {time.monotonic() - t0:.1f} s: {path}")
    except Exception as exc:  # noqa: BLE001 - one benchmark's failure must not stop the rest
        text = str(exc) if isinstance(exc, CompareError) else f"{type(exc).__name__}: {exc}"
        progress.line(name, "compare", f"FAILED: {text}")
        entry = report.IndexEntry(name, ours_text, foam_text, f"comparison failed: {text}",
                                  None, True)
        report.write_entry(entry, out_dir)
        return entry
    entry = report.IndexEntry(name, ours_text, foam_text, head, path, failed)
    report.write_entry(entry, out_dir)
    return entry


def cpu_count() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1

