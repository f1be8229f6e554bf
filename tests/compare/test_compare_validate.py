"""``compare validate`` end to end with a fake solver and a fake OpenFOAM driver."""

import json
import os
import stat
from pathlib import Path

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
    assert "not in the quick suite (run them with --benchmark NAME): floating_block_3d" in out
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
