"""``compare validate``: run every benchmark with IQ-MPM and OpenFOAM, compare, report.

Stages per benchmark: IQ-MPM at each level (level L: dx = default_dx / 2^(L-1); level 0,
twice level 1's cell size, extends the run time against error curve to larger errors), the
OpenFOAM case at each level from 1 (cached under foam_runs/ by a hash of its inputs), then the
comparison, the checks of the benchmark's expected.json and the report. Child processes
run ``--jobs`` at a time, the longest first; progress is printed as one line per stage with
the elapsed time, plus a heartbeat line while a child runs; the run ends with a summary:
where the report is, the checks' tally and what failed.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from concurrent.futures import FIRST_COMPLETED, Future, ThreadPoolExecutor, wait
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

from compare import analysis, report
from compare import expected as exp
from compare.children import ChildResult, Progress, last_log_line, run_child
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
    full: bool = False  # every benchmark and every reference (else the quick suite)
    page: Path | None = None  # also write the validation page here (e.g. docs/validation.md)


# --------------------------------------------------------------------------- discovery


@dataclass
class Scene:
    name: str  # scene stem
    folder: str  # benchmarks/<folder>/
    path: Path


def discover(repo: Path, names: Sequence[str] = ()) -> list[Scene]:
    """Scenes ``benchmarks/*/*.json``; ``names`` selects by stem or folder name."""
    scenes = [Scene(p.stem, p.parent.name, p)
              for p in sorted((repo / "benchmarks").glob("*/*.json"))
              if p.name != exp.EXPECTED_FILE]
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


def _driver_files(foam_dir: Path) -> list[Path]:
    """The OpenFOAM driver: ``foam_cases/run`` and the package ``foam_cases/driver/``."""
    files = [foam_dir / "run"]
    driver = foam_dir / "driver"
    if driver.is_dir():
        files += [p for p in driver.rglob("*") if p.is_file() and "__pycache__" not in p.parts
                  and p.suffix != ".pyc"]
    return files


def foam_inputs_hash(foam_dir: Path, case: str, level: int, options: dict[str, Any]) -> str:
    """sha256 of the case template folder, the driver, level and options."""
    h = hashlib.sha256()
    case_dir = foam_dir / case
    _hash_files(h, foam_dir, [p for p in case_dir.rglob("*") if p.is_file()])
    _hash_files(h, foam_dir, _driver_files(foam_dir))
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
    if level != 1:
        if default_dx is None:
            return RunOutcome(None, "default dx unknown (no 'dx' in the scene and no level-1 "
                                    "summary)", True)
        dx = default_dx / 2 ** (level - 1)
        args += ["--set", f"dx={dx:.10g}"]
    if not s.solver_bin.is_file():
        progress.line(scene.name, stage, f"FAILED: solver binary {s.solver_bin} not found"
                      f"{progress.finished_job()}")
        return RunOutcome(None, f"solver binary {s.solver_bin} not found", True)
    key = solver_inputs_hash(s.solver_bin, scene.path, args)
    if s.reuse_solver and cached(out_dir, key):
        progress.line(scene.name, stage, f"reused {out_dir}{progress.finished_job()}")
        return RunOutcome(read_run(out_dir, "iqmpm"), "cached", False)
    out_dir.mkdir(parents=True, exist_ok=True)
    for stale in ("summary.json", "metrics.csv", CACHE_STAMP):
        (out_dir / stale).unlink(missing_ok=True)
    cmd = [str(s.solver_bin)] + args
    progress.line(scene.name, stage, "started")
    timeout = max(s.timeout, lookup(scene.name, scene.folder).min_timeout)
    res = run_child(cmd, out_dir / "iqmpm.log", progress, scene.name, stage, timeout, s.repo)
    _record(out_dir, {"solver": "iqmpm", "level": level, "dx": dx, "command": cmd,
                      "threads": s.threads, "elapsed_s": res.elapsed, "cpu_s": res.cpu,
                      "returncode": res.returncode})
    return _finish(out_dir, "iqmpm", res, key, progress, scene.name, stage, timeout)


def _finish(out_dir: Path, solver: str, res: ChildResult, key: str, progress: Progress,
            bench: str, stage: str, timeout: float) -> RunOutcome:
    log = out_dir / ("iqmpm.log" if solver == "iqmpm" else "foam.log")
    if res.timed_out:
        status = f"timed out after {timeout:g} s (log {log})"
    elif not (out_dir / "summary.json").is_file():
        last = last_log_line(log)
        status = (f"exit code {res.returncode}, no summary.json" + (f": {last}" if last else "")
                  + f" (log {log})")
    else:
        try:
            run = read_run(out_dir, solver)
        except CompareError as exc:
            status = f"unreadable output: {exc}"
        else:
            if run.ok and res.returncode == 0:
                (out_dir / CACHE_STAMP).write_text(json.dumps({"key": key}))
                cpu = f", cpu {res.cpu:.1f} s" if res.cpu is not None else ""
                progress.line(bench, stage, f"done in {res.elapsed:.1f} s{cpu}"
                              f"{progress.finished_job()}")
                return RunOutcome(run, "ok", False)
            status = (run.status if not run.ok else f"exit code {res.returncode}")
            progress.line(bench, stage, f"FAILED after {res.elapsed:.1f} s: {status}"
                          f"{progress.finished_job()}")
            return RunOutcome(run, status, True)
    progress.line(bench, stage, f"FAILED after {res.elapsed:.1f} s: {status}"
                  f"{progress.finished_job()}")
    return RunOutcome(None, status, True)


def run_foam(s: Settings, case: str, bench: str, level: int, progress: Progress) -> RunOutcome:
    stage = f"OpenFOAM level {level}"
    foam_dir = s.repo / "foam_cases"
    driver = foam_dir / "run"
    out_dir = s.foam_runs_dir / case / f"level{level}"
    options = {"np": s.foam_np, "end_time": s.foam_end_time}
    key = foam_inputs_hash(foam_dir, case, level, options)
    if s.foam_cache and cached(out_dir, key):
        progress.line(bench, stage, f"reused cache {out_dir}{progress.finished_job()}")
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
                      "elapsed_s": res.elapsed, "cpu_s": res.cpu, "returncode": res.returncode})
    return _finish(out_dir, "interFoam", res, key, progress, bench, stage, s.timeout)


# --------------------------------------------------------------------------- orchestration


@dataclass
class BenchPlan:
    scene: Scene
    bench: Benchmark
    ours: dict[int, Future] = field(default_factory=dict)
    foam: dict[int, Future] = field(default_factory=dict)
    foam_notes: list[str] = field(default_factory=list)  # OpenFOAM levels not run, and why
    checks: list[exp.Check] = field(default_factory=list)

    def futures(self) -> list[Future]:
        return list(self.ours.values()) + list(self.foam.values())


@dataclass
class Job:
    """One child run to submit: its estimated seconds order the queue (longest first)."""

    estimate: float
    order: int
    submit: Any  # () -> Future
    store: Any  # (Future) -> None
    after: "Job | None" = None  # submitted only after this one (a later level needing dx)
    submitted: bool = False


def submit_longest_first(jobs: Sequence[Job]) -> None:
    """Submit the jobs by decreasing estimate (ties: in order), each after its ``after``."""
    queue = sorted(jobs, key=lambda j: (-j.estimate, j.order))
    while queue:
        job = next(j for j in queue if j.after is None or j.after.submitted)
        job.store(job.submit())
        job.submitted = True
        queue.remove(job)


def _previous_wall_time(run_dir: Path) -> float | None:
    try:
        value = read_summary(run_dir / "summary.json").get("wall_time_s")
    except CompareError:
        return None
    return float(value) if isinstance(value, (int, float)) and value > 0 else None


def estimate_seconds(s: Settings, bench: Benchmark, name: str, level: int,
                     foam_case: str | None = None) -> float:
    """A child run's expected wall time: its previous run's, else the registry's estimate
    (one thread), times 8 per level (2-D: 4 times the cells, twice the steps)."""
    if foam_case is None:
        previous = _previous_wall_time(s.runs_dir / name / "iqmpm" / f"level{level}")
        base = bench.cost_s
    else:
        previous = _previous_wall_time(s.foam_runs_dir / foam_case / f"level{level}")
        base = bench.foam_cost_s
    return previous if previous is not None else base * 8.0 ** (level - 1)


def foam_cached_run(s: Settings, case: str, level: int) -> Run | None:
    """The cached OpenFOAM run of ``case`` at ``level`` if its inputs are unchanged."""
    out_dir = s.foam_runs_dir / case / f"level{level}"
    key = foam_inputs_hash(s.repo / "foam_cases", case, level,
                           {"np": s.foam_np, "end_time": s.foam_end_time})
    if not cached(out_dir, key):
        return None
    try:
        return read_run(out_dir, "interFoam")
    except CompareError:
        return None


def validate(s: Settings, progress: Progress | None = None) -> int:
    """Run everything; write reports, the index and the validation page. Returns the exit
    status: 0 all runs ok and no check failed, 1 a run, a comparison or a check failed."""
    progress = progress or Progress(interval=s.progress_interval)
    scenes = discover(s.repo, s.benchmarks)
    if not scenes:
        raise CompareError(f"no benchmarks found in {s.repo / 'benchmarks'}/*/*.json")
    expected = exp.load_all(s.repo)  # a malformed expected.json stops here (exit 2)
    quick = not s.benchmarks and not s.full
    if quick:  # the quick suite: long benchmarks only when named or with --full
        long = [sc.name for sc in scenes if not lookup(sc.name, sc.folder).quick]
        scenes = [sc for sc in scenes if lookup(sc.name, sc.folder).quick]
        if long:
            progress.line("validate", "plan", f"not in the quick suite (run them with --benchmark "
                          f"NAME or --full): {', '.join(long)}")
    progress.line("validate", "plan", f"{len(scenes)} benchmark(s): "
                  f"{', '.join(sc.name for sc in scenes)}; levels {s.levels}; jobs {s.jobs}; "
                  f"threads per run {s.threads}")
    foam_dir = s.repo / "foam_cases"
    plans: list[BenchPlan] = []
    jobs: list[Job] = []
    with ThreadPoolExecutor(max_workers=max(1, s.jobs)) as pool:
        for scene in scenes:
            bench = lookup(scene.name, scene.folder)
            plan = BenchPlan(scene, bench, checks=expected.get(scene.name, []))
            plans.append(plan)
            try:
                scene_dx = find_dx(json.loads(scene.path.read_text()))
            except (OSError, json.JSONDecodeError):
                scene_dx = None
            levels = sorted(set(s.levels))
            # Level 1 first where asked: without a dx in the scene, the other levels take
            # it from its summary.
            first_level = 1 if 1 in levels else levels[0]
            first = Job(estimate_seconds(s, bench, scene.name, first_level), len(jobs),
                        lambda scene=scene, level=first_level, dx=scene_dx: pool.submit(
                            run_iqmpm, s, scene, level, dx, progress),
                        lambda f, plan=plan, lv=first_level: plan.ours.__setitem__(lv, f))
            jobs.append(first)
            for level in levels:
                if level == first_level:
                    continue
                jobs.append(Job(estimate_seconds(s, bench, scene.name, level), len(jobs),
                                lambda scene=scene, level=level, dx=scene_dx, plan=plan,
                                first_level=first_level: pool.submit(
                                    _later_level, s, scene, level, dx, plan.ours[first_level],
                                    first_level, progress),
                                lambda f, plan=plan, lv=level: plan.ours.__setitem__(lv, f),
                                after=first))
            case = bench.foam_case
            if not case or not (foam_dir / case).is_dir():
                plan.foam_notes.append("no OpenFOAM case")
                progress.line(scene.name, "OpenFOAM", f"no OpenFOAM case "
                              f"({'none registered' if not case else foam_dir / case})")
            elif not (foam_dir / "run").is_file():
                plan.foam_notes.append(f"no OpenFOAM driver ({foam_dir / 'run'})")
                progress.line(scene.name, "OpenFOAM", plan.foam_notes[-1])
            else:
                for level in levels:
                    if level == 0:
                        plan.foam_notes.append("L0 is IQ-MPM's only (the OpenFOAM cases' "
                                               "meshes start at level 1)")
                        continue
                    if quick and not bench.foam_quick and foam_cached_run(s, case, level) is None:
                        plan.foam_notes.append(
                            f"L{level} not run in the quick suite (about "
                            f"{bench.foam_cost_s * 8.0 ** (level - 1) / 60:.0f} min; "
                            f"--benchmark {scene.name} or --full runs it)")
                        progress.line(scene.name, f"OpenFOAM level {level}", plan.foam_notes[-1])
                        continue
                    jobs.append(Job(estimate_seconds(s, bench, scene.name, level, case),
                                    len(jobs),
                                    lambda case=case, name=scene.name, level=level: pool.submit(
                                        run_foam, s, case, name, level, progress),
                                    lambda f, plan=plan, lv=level: plan.foam.__setitem__(lv, f)))
        # Longest first: the last jobs to start are the short ones, so both workers end
        # together. A later level of a scene still starts after its first level.
        progress.jobs_total = len(jobs)
        submit_longest_first(jobs)
        entries = []
        pending = list(plans)
        while pending:  # compare each benchmark as soon as its runs are done
            ready = [p for p in pending if all(f.done() for f in p.futures())]
            if not ready:
                wait([f for p in pending for f in p.futures() if not f.done()],
                     return_when=FIRST_COMPLETED)
                continue
            for plan in ready:
                entries.append(_compare_plan(s, plan, progress))
                pending.remove(plan)
    return _finish_suite(s, entries, progress)


def _finish_suite(s: Settings, entries: list[report.IndexEntry], progress: Progress) -> int:
    """Index, validation page and the closing summary: where the report is, what failed."""
    from compare.page import write_validation_page

    index = report.write_index(report.read_entries(s.out), s.out, _settings_table(s))
    page = write_validation_page(s.out, s.out / "validation.md", s.repo)
    if s.page is not None:
        write_validation_page(s.out, s.page, s.repo)
    failed_runs = [e for e in entries if e.failed]
    tally = exp.Tally()
    for e in entries:
        tally.add(e.checks)
    failed_checks = [c for e in entries for c in e.checks if c.result == exp.FAIL]
    minutes = progress.elapsed() / 60
    progress.line("validate", "summary", f"{len(entries)} benchmark(s) in {minutes:.1f} min; "
                  f"checks (expected.json): {tally.text()}")
    for e in failed_runs:  # only the stages that failed
        parts = [f"IQ-MPM {e.iqmpm}" if "FAILED" in e.iqmpm else "",
                 f"OpenFOAM {e.openfoam}" if "FAILED" in e.openfoam else "",
                 e.headline if e.headline.startswith("comparison failed") else ""]
        progress.line("validate", "summary", f"FAILED run: {e.name}: "
                      + "; ".join(p for p in parts if p))
    for c in failed_checks:
        progress.line("validate", "summary", f"FAILED check: {c.benchmark} {c.metric}: "
                      f"{exp.shown_value(c)}" + (f" ({c.detail})" if c.detail else "")
                      + f"; expected {c.expected}")
    for e in entries:  # a failed run's checks are covered by its line above
        for c in (c for c in e.checks if c.result == exp.NOT_CHECKED and not e.failed):
            progress.line("validate", "summary", f"not checked: {c.benchmark} {c.metric}: "
                          f"{c.detail}")
    progress.line("validate", "summary", f"report: {index}; checks page: {page}"
                  + (f" and {s.page}" if s.page is not None else ""))
    if failed_runs or failed_checks:
        progress.line("validate", "summary", "FAILED: " + ", ".join(
            [f"{e.name} (run)" for e in failed_runs]
            + [f"{c.benchmark} {c.metric}" for c in failed_checks]))
        return 1
    progress.line("validate", "summary", "all runs succeeded and no check failed")
    return 0


def _later_level(s: Settings, scene: Scene, level: int, scene_dx: float | None, first: Future,
                 first_level: int, progress: Progress) -> RunOutcome:
    dx = scene_dx
    if dx is None:
        outcome: RunOutcome = first.result()
        if outcome.run is not None and outcome.run.dx:
            dx = outcome.run.dx * 2 ** (first_level - 1)
    return run_iqmpm(s, scene, level, dx, progress)


def _settings_table(s: Settings) -> dict[str, Any]:
    return {"suite": "named" if s.benchmarks else ("full" if s.full else "quick"),
            "levels": ",".join(map(str, s.levels)), "solver": s.solver_bin,
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
    foam_text = "; ".join(
        [f"L{lv} {('ok' if o.status == 'ok' else o.status) if not o.failed else 'FAILED: ' + o.status}"
         for lv, o in sorted(foam.items())] + plan.foam_notes)
    out_dir = s.out / name
    t0 = time.monotonic()
    progress.line(name, "compare", "started")
    ours_runs = [o.run for o in ours.values() if o.run]
    foam_runs = [o.run for o in foam.values() if o.run]
    checks: list[exp.CheckResult] = []
    try:
        result = analysis.analyse(plan.bench, ours_runs, foam_runs, out_dir,
                                  analysis.Options(s.data_dir, s.fluid_material))
        result.checks = checks = _checks(s, plan, ours_runs, foam_runs, ours)
        extra = [f"IQ-MPM level {lv}: FAILED ({o.status})" for lv, o in ours.items() if o.failed
                 and o.run is None]
        extra += [f"OpenFOAM: {note}" for note in plan.foam_notes]
        extra += [f"OpenFOAM level {lv}: FAILED ({o.status})" for lv, o in foam.items()
                  if o.failed and o.run is None]
        path = report.write_report(result, out_dir, extra, s.solver_bin)
        head = report.headline(result)
        tally = f"; checks: {exp.Tally().add(checks).text()}" if checks else ""
        progress.line(name, "compare", f"done in {time.monotonic() - t0:.1f} s{tally}: {path}")
    except Exception as exc:  # noqa: BLE001 - one benchmark's failure must not stop the rest
        text = str(exc) if isinstance(exc, CompareError) else f"{type(exc).__name__}: {exc}"
        progress.line(name, "compare", f"FAILED: {text}")
        entry = report.IndexEntry(name, ours_text, foam_text, f"comparison failed: {text}",
                                  None, True, checks=checks, title=plan.bench.title)
        report.write_entry(entry, out_dir)
        return entry
    entry = report.IndexEntry(name, ours_text, foam_text, head, path, failed, checks=checks,
                              title=plan.bench.title)
    report.write_entry(entry, out_dir)
    return entry


def _checks(s: Settings, plan: BenchPlan, ours_runs: list[Run], foam_runs: list[Run],
            ours: dict[int, RunOutcome]) -> list[exp.CheckResult]:
    """The benchmark's expected.json checks; an interFoam level this run did not compute
    comes from the OpenFOAM cache (inputs unchanged) or a shipped reference run."""
    case = plan.bench.foam_case

    def foam_level(level: int) -> tuple[Run | None, str]:
        if not case:
            return None, ""
        run = foam_cached_run(s, case, level)
        if run is not None:
            try:
                where = run.path.relative_to(s.repo)
            except ValueError:
                where = run.path
            return run, f"cached run {where}"
        return None, ""

    failed = {lv: o.status for lv, o in ours.items() if o.failed and o.run is None}
    return exp.evaluate(plan.bench, plan.checks, ours_runs, foam_runs, s.data_dir,
                        foam_level, failed)


SHIPPED_OPTIONS: dict[str, Any] = {"np": 1, "end_time": None}  # of a shipped reference run


def ship_foam_reference(repo: Path, case: str, level: int, columns: Sequence[str], out: Path,
                        foam_runs_dir: Path, timeout: float,
                        progress: Progress | None = None) -> Path:
    """Run (or reuse from the cache) ``foam_cases/run CASE --level N`` and write a reference
    run folder ``out`` with only ``columns`` of its metrics: small enough to ship in the
    repository, so a criterion against that level is checked without running it."""
    import datetime as _dt

    progress = progress or Progress()
    s = Settings(repo=repo, out=repo / "report", runs_dir=repo / "out" / "validate",
                 foam_runs_dir=foam_runs_dir, data_dir=repo / "data",
                 solver_bin=repo / "build" / "iqmpm", levels=[level], timeout=timeout,
                 foam_np=int(SHIPPED_OPTIONS["np"]), foam_end_time=SHIPPED_OPTIONS["end_time"])
    if not (repo / "foam_cases" / case).is_dir():
        raise CompareError(f"no OpenFOAM case {repo / 'foam_cases' / case}")
    outcome = run_foam(s, case, case, level, progress)
    run = outcome.run
    if outcome.failed or run is None or run.metrics is None:
        raise CompareError(f"OpenFOAM {case} level {level} failed: {outcome.status}")
    for c in columns:
        run.metrics.column(c)  # a clear error for a missing column
    key = foam_inputs_hash(repo / "foam_cases", case, level, SHIPPED_OPTIONS)
    try:
        where = out.relative_to(repo)
    except ValueError:
        where = out
    command = (f"compare/compare foam-reference {case} --level {level} "
               + " ".join(f"--column {c}" for c in columns) + f" --out {where}")
    version = run.summary.get("openfoam_version", "?")
    lines = [f"# interFoam reference: foam_cases/{case} at level {level} "
             f"({run.summary.get('cells', '?')} cells), OpenFOAM {version}; columns of its "
             f"metrics.csv (SI units)",
             f"# generated {_dt.date.today().isoformat()} by: {command}",
             f"# inputs sha256 (case template, driver, level, np 1): {key}",
             ",".join(["t", *columns])]
    for i, t in enumerate(run.metrics.t):
        lines.append(",".join([repr(float(t))] + [repr(float(run.metrics.columns[c][i]))
                                                   for c in columns]))
    summary = {"status": "ok", "solver": run.summary.get("solver", "interFoam"), "case": case,
               "level": level, "cells": run.summary.get("cells"),
               "steps": run.summary.get("steps"), "wall_time_s": run.summary.get("wall_time_s"),
               "end_time": run.summary.get("end_time"), "openfoam_version": version,
               "inputs_sha256": key, "columns": list(columns), "regenerate": command,
               "generated": _dt.date.today().isoformat(),
               "note": "a shipped copy of the compared columns of an OpenFOAM run "
                       "(compare/README.md, Expected results)"}
    out.mkdir(parents=True, exist_ok=True)
    (out / "metrics.csv").write_text("\n".join(lines) + "\n")
    (out / "summary.json").write_text(json.dumps(summary, indent=1) + "\n")
    return out


def shipped_reference_stale(run: Run, repo: Path) -> str:
    """Why a shipped reference run no longer matches its OpenFOAM case ("" when it does)."""
    case, level = run.summary.get("case"), run.summary.get("level")
    recorded = run.summary.get("inputs_sha256")
    if not isinstance(case, str) or not isinstance(level, int) or not recorded:
        return ""
    foam_dir = repo / "foam_cases"
    if not (foam_dir / case).is_dir():
        return ""
    if foam_inputs_hash(foam_dir, case, level, SHIPPED_OPTIONS) == recorded:
        return ""
    return (f"foam_cases/{case} or its driver changed since this reference was made; "
            f"regenerate: {run.summary.get('regenerate', 'compare/compare foam-reference')}")


def cpu_count() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1

