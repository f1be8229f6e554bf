"""``compare validate`` end to end with a fake solver and a fake OpenFOAM driver."""

import json
import os
import stat
from pathlib import Path

import pytest

from compare.cli import main

HERE = Path(__file__).resolve().parent

FAKE_SOLVER = f"""#!/usr/bin/python3
import json, sys, time
sys.path.insert(0, {str(HERE)!r})
from pathlib import Path
from compare_synth import hydrostatic_run, write_summary
args = sys.argv[1:]
assert args[0] == "run", args
scene = json.loads(Path(args[1]).read_text())
out = Path(args[args.index("--out") + 1])
sets = dict(args[i + 1].split("=", 1) for i, a in enumerate(args) if a == "--set")
dx = float(sets.get("dx", scene["dx"]))
print("step 1 of 2", flush=True)
time.sleep(scene.get("sleep", 0.0))
if scene.get("fail"):
    write_summary(out, status="diverged at step 3")
    sys.exit(1)
hydrostatic_run(out, force_factor=1 + 0.1 * (dx / 0.04) ** 2, wall_time=0.04 / dx, dx=dx)
print("step 2 of 2", flush=True)
"""

FAKE_DRIVER = f"""#!/usr/bin/python3
import os, sys
sys.path.insert(0, {str(HERE)!r})
from pathlib import Path
from compare_synth import hydrostatic_run
args = sys.argv[1:]
level = int(args[args.index("--level") + 1])
out = Path(args[args.index("--out") + 1])
with open(os.environ["FAKE_FOAM_CALLS"], "a") as fh:
    fh.write(" ".join(args) + "\\n")
hydrostatic_run(out, force_factor=1 + 0.2 * 2.0 ** -(level - 1), wall_time=2.0 * 4 ** level,
                foam=True, level=level)
"""


def _script(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    path.chmod(path.stat().st_mode | stat.S_IEXEC)
    return path


def _repo(tmp_path: Path) -> Path:
    repo = tmp_path / "repo"
    (repo / "benchmarks" / "hydrostatic").mkdir(parents=True)
    (repo / "benchmarks" / "hydrostatic" / "hydrostatic_2d.json").write_text(
        json.dumps({"dx": 0.04, "sleep": 0.6}))
    (repo / "benchmarks" / "broken").mkdir()
    (repo / "benchmarks" / "broken" / "broken.json").write_text(
        json.dumps({"dx": 0.04, "fail": True}))
    (repo / "foam_cases" / "hydrostatic" / "system").mkdir(parents=True)
    (repo / "foam_cases" / "hydrostatic" / "system" / "controlDict").write_text("endTime 2;\n")
    _script(repo / "foam_cases" / "run", FAKE_DRIVER)
    _script(repo / "build" / "iqmpm", FAKE_SOLVER)
    return repo


def _validate(repo: Path, tmp_path: Path, *extra: str) -> int:
    return main(["validate", "--repo", str(repo), "--out", str(tmp_path / "report"),
                 "--runs-dir", str(tmp_path / "runs"), "--foam-runs-dir",
                 str(tmp_path / "foam_runs"), "--solver", str(repo / "build" / "iqmpm"),
                 "--progress-interval", "0.2", *extra])


def test_validate_runs_compares_reports_and_caches(tmp_path, capsys, monkeypatch):
    calls = tmp_path / "calls.txt"
    monkeypatch.setenv("FAKE_FOAM_CALLS", str(calls))
    repo = _repo(tmp_path)
    rc = _validate(repo, tmp_path, "--levels", "1,2", "--jobs", "2")
    out = capsys.readouterr().out
    assert rc == 1  # the broken benchmark's solver run failed
    assert "hydrostatic_2d | IQ-MPM level 2 | done in" in out
    assert "hydrostatic_2d | IQ-MPM level 1 | running" in out  # heartbeat while a child runs
    assert "broken | IQ-MPM level 1 | FAILED" in out and "diverged at step 3" in out
    assert "broken | OpenFOAM | no OpenFOAM case" in out
    assert len(calls.read_text().splitlines()) == 2  # levels 1 and 2
    # level 2 ran at dx / 2
    record = json.loads((tmp_path / "runs" / "hydrostatic_2d" / "iqmpm" / "level2" /
                         "compare_run.json").read_text())
    assert "dx=0.02" in record["command"]
    index = (tmp_path / "report" / "index.md").read_text()
    assert "| broken |" in index and "FAILED: diverged at step 3" in index
    assert "no OpenFOAM case" in index
    assert "[report](hydrostatic_2d/report.md)" in index
    text = (tmp_path / "report" / "hydrostatic_2d" / "report.md").read_text()
    assert "| 10.00 |" in text  # level-1 force error vs rho g H^2/2
    assert "## Convergence" in text and "| IQ-MPM | `wall_force_x` | rho g H^2/2 | 1,2 |" in text

    # second run: OpenFOAM results come from the cache
    rc = _validate(repo, tmp_path, "--levels", "1,2", "--benchmark", "hydrostatic_2d")
    out = capsys.readouterr().out
    assert "reused cache" in out
    assert len(calls.read_text().splitlines()) == 2
    # a changed case template invalidates the cache of that case
    (repo / "foam_cases" / "hydrostatic" / "system" / "controlDict").write_text("endTime 3;\n")
    assert _validate(repo, tmp_path, "--benchmark", "hydrostatic_2d") == 0
    assert len(calls.read_text().splitlines()) == 3


def test_level_zero_is_iqmpm_at_twice_the_cell_size_and_extends_the_cost_curve(tmp_path, capsys,
                                                                              monkeypatch):
    # Level 0 gives the run time against error curve a coarser point (issue 21 item 6): IQ-MPM
    # at twice level 1's dx; OpenFOAM's meshes start at level 1, so it is not asked for one.
    calls = tmp_path / "calls.txt"
    monkeypatch.setenv("FAKE_FOAM_CALLS", str(calls))
    repo = _repo(tmp_path)
    assert _validate(repo, tmp_path, "--levels", "0,1,2", "--benchmark", "hydrostatic_2d") == 0
    out = capsys.readouterr().out
    assert "hydrostatic_2d | IQ-MPM level 0 | done in" in out
    record = json.loads((tmp_path / "runs" / "hydrostatic_2d" / "iqmpm" / "level0" /
                         "compare_run.json").read_text())
    assert record["dx"] == 0.08 and "dx=0.08" in record["command"]
    foam_levels = [line.split("--level ")[1].split()[0] for line in calls.read_text().splitlines()]
    assert sorted(foam_levels) == ["1", "2"]
    text = (tmp_path / "report" / "hydrostatic_2d" / "report.md").read_text()
    assert "| IQ-MPM | `wall_force_x` | rho g H^2/2 | 0,1,2 |" in text
    assert "L0 is IQ-MPM's only" in (tmp_path / "report" / "index.md").read_text() + text


def test_levels_below_zero_are_a_clear_error(tmp_path, capsys):
    repo = _repo(tmp_path)
    with pytest.raises(SystemExit) as exit_info:
        _validate(repo, tmp_path, "--levels=-1,1")
    assert exit_info.value.code == 2
    assert "levels start at 0" in capsys.readouterr().err


def test_validate_without_solver_reports_failure(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("FAKE_FOAM_CALLS", str(tmp_path / "calls.txt"))
    repo = _repo(tmp_path)
    os.remove(repo / "build" / "iqmpm")
    assert _validate(repo, tmp_path, "--benchmark", "hydrostatic") == 1
    out = capsys.readouterr().out
    assert "not found" in out
    assert "solver binary" in (tmp_path / "report" / "index.md").read_text()


def test_validate_unknown_benchmark_is_a_clear_error(tmp_path, capsys):
    repo = _repo(tmp_path)
    assert _validate(repo, tmp_path, "--benchmark", "nosuch") == 2
    assert "unknown benchmark(s): nosuch" in capsys.readouterr().err


def test_quick_suite_leaves_long_benchmarks_to_named_runs(tmp_path, capsys, monkeypatch):
    # floating_block_3d is registered with quick=False: a plain `validate` (the README's
    # main job) lists it as skipped and does not run it; naming it runs it.
    monkeypatch.setenv("FAKE_FOAM_CALLS", str(tmp_path / "calls.txt"))
    repo = _repo(tmp_path)
    (repo / "benchmarks" / "broken" / "broken.json").unlink()
    (repo / "benchmarks" / "floating_block_3d").mkdir()
    (repo / "benchmarks" / "floating_block_3d" / "floating_block_3d.json").write_text(
        json.dumps({"dx": 0.04}))
    _validate(repo, tmp_path)
    out = capsys.readouterr().out
    assert "not in the quick suite (run them with --benchmark NAME or --full): floating_block_3d" in out
    assert "floating_block_3d | IQ-MPM level 1" not in out
    _validate(repo, tmp_path, "--benchmark", "floating_block_3d")
    assert "floating_block_3d | IQ-MPM level 1 | started" in capsys.readouterr().out


def test_long_benchmarks_keep_their_own_minimum_timeout(tmp_path, capsys, monkeypatch):
    # --timeout kills a run that takes longer (hydrostatic_2d sleeps 0.6 s), but a benchmark
    # registered with a longer min_timeout (floating_block_3d_fine: 4 h) keeps it.
    monkeypatch.setenv("FAKE_FOAM_CALLS", str(tmp_path / "calls.txt"))
    repo = _repo(tmp_path)
    (repo / "benchmarks" / "floating_block_3d").mkdir()
    (repo / "benchmarks" / "floating_block_3d" / "floating_block_3d_fine.json").write_text(
        json.dumps({"dx": 0.04, "sleep": 0.6}))
    assert _validate(repo, tmp_path, "--benchmark", "hydrostatic_2d", "--timeout", "0.3") == 1
    assert "timed out after 0.3 s" in capsys.readouterr().out
    _validate(repo, tmp_path, "--benchmark", "floating_block_3d_fine", "--timeout", "0.3")
    out = capsys.readouterr().out
    assert "floating_block_3d_fine | IQ-MPM level 1 | done" in out
    assert "timed out" not in out


def _expect(repo: Path, margin: float) -> None:
    (repo / "benchmarks" / "hydrostatic" / "expected.json").write_text(json.dumps({
        "hydrostatic_2d": [
            {"metric": "wall_force_final", "value": 1226.25, "margin": {"relative": margin},
             "source": "analytic rho g H^2/2"},
            {"metric": "status", "value": "ok", "source": "runs to its end"}]}))


def test_validate_checks_expected_results_and_fails_on_a_failed_check(tmp_path, capsys,
                                                                       monkeypatch):
    # The fake solver's level-1 wall force is 10 % high: a 2 % margin fails, 15 % passes.
    monkeypatch.setenv("FAKE_FOAM_CALLS", str(tmp_path / "calls.txt"))
    repo = _repo(tmp_path)
    _expect(repo, 0.02)
    page = tmp_path / "docs" / "validation.md"
    rc = _validate(repo, tmp_path, "--benchmark", "hydrostatic_2d", "--page", str(page))
    out = capsys.readouterr().out
    assert rc == 1
    assert "validate | summary | 1 benchmark(s) in" in out and "1 pass, 1 fail" in out
    assert "FAILED check: hydrostatic_2d wall_force_final: 1349 N/m (+10.00 %)" in out
    assert f"report: {tmp_path / 'report' / 'index.md'}" in out
    assert out.rstrip().splitlines()[-1].endswith("FAILED: hydrostatic_2d wall_force_final")
    text = (tmp_path / "report" / "hydrostatic_2d" / "report.md").read_text()
    assert "## Checks (expected.json)" in text and "**FAIL**" in text
    index = (tmp_path / "report" / "index.md").read_text()
    assert "### Failed checks" in index and "1 pass, 1 **FAIL**" in index
    for p in (tmp_path / "report" / "validation.md", page):
        body = p.read_text()
        assert "| `wall_force_final` | value | 1349 N/m | 1226.25 N/m ± 2 % |" in body
        assert "**FAIL**" in body and str(repo) not in body
    _expect(repo, 0.15)
    assert _validate(repo, tmp_path, "--benchmark", "hydrostatic_2d") == 0
    out = capsys.readouterr().out
    assert "checks (expected.json): 2 pass" in out and "no check failed" in out


def test_malformed_expected_json_stops_before_any_run(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("FAKE_FOAM_CALLS", str(tmp_path / "calls.txt"))
    repo = _repo(tmp_path)
    (repo / "benchmarks" / "hydrostatic" / "expected.json").write_text(json.dumps({
        "hydrostatic_2d": [{"metric": "wall_force_final", "value": 1.0, "source": "x"}]}))
    assert _validate(repo, tmp_path, "--benchmark", "hydrostatic_2d") == 2
    assert "missing 'margin'" in capsys.readouterr().err
    assert not (tmp_path / "calls.txt").exists() and not (tmp_path / "runs").exists()


def test_quick_suite_leaves_slow_openfoam_references_to_the_full_suite(tmp_path, capsys,
                                                                       monkeypatch):
    # floating_block's interFoam (7 min at level 1) is registered foam_quick=False.
    calls = tmp_path / "calls.txt"
    monkeypatch.setenv("FAKE_FOAM_CALLS", str(calls))
    repo = _repo(tmp_path)
    (repo / "benchmarks" / "broken" / "broken.json").unlink()
    (repo / "benchmarks" / "floating_block").mkdir()
    (repo / "benchmarks" / "floating_block" / "floating_block.json").write_text(
        json.dumps({"dx": 0.04}))
    (repo / "foam_cases" / "floating_block").mkdir()
    (repo / "foam_cases" / "floating_block" / "controlDict").write_text("endTime 5;\n")
    _validate(repo, tmp_path)
    out = capsys.readouterr().out
    assert "floating_block | OpenFOAM level 1 | L1 not run in the quick suite" in out
    assert "floating_block | IQ-MPM level 1 | done" in out
    assert "floating_block" not in calls.read_text()  # hydrostatic's interFoam did run
    assert "not run in the quick suite" in (tmp_path / "report" / "index.md").read_text()
    _validate(repo, tmp_path, "--full")
    assert "floating_block | OpenFOAM level 1 | done" in capsys.readouterr().out
    assert "floating_block --level 1" in calls.read_text()
    _validate(repo, tmp_path)  # a cached run with unchanged inputs is used
    assert "floating_block | OpenFOAM level 1 | reused cache" in capsys.readouterr().out


def test_jobs_start_longest_first_and_a_later_level_after_its_first():
    from compare.validate import Job, submit_longest_first

    started: list[str] = []

    def job(name, estimate, after=None):
        return Job(estimate, len(started), lambda: started.append(name) or name,
                   lambda f: None, after)

    a1 = job("a L1", 5.0)
    jobs = [a1, job("a L2", 40.0, after=a1), job("b L1", 20.0), job("c L1", 1.0)]
    for i, j in enumerate(jobs):
        j.order = i
    submit_longest_first(jobs)
    assert started == ["b L1", "a L1", "a L2", "c L1"]


def test_progress_counts_finished_jobs(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("FAKE_FOAM_CALLS", str(tmp_path / "calls.txt"))
    repo = _repo(tmp_path)
    _validate(repo, tmp_path, "--levels", "1,2")
    out = capsys.readouterr().out
    # hydrostatic_2d: IQ-MPM and OpenFOAM at 2 levels; broken: IQ-MPM at 2 levels
    assert "(6/6 jobs)" in out and "(1/6 jobs)" in out
    # a job's CPU time beside its wall time (the children are Python scripts: > 10 ms)
    import re

    cpu = [float(c) for c in re.findall(r"done in [0-9.]+ s, cpu ([0-9.]+) s", out)]
    assert len(cpu) == 4 and all(c > 0 for c in cpu)
    record = json.loads((tmp_path / "runs" / "hydrostatic_2d" / "iqmpm" / "level1" /
                         "compare_run.json").read_text())
    assert 0 < record["cpu_s"] < record["elapsed_s"] + 5
