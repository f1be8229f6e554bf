"""benchmarks/solvers/force_sources.py on a real dump: the force it rebuilds from the dumped
pressure system (A, r, D and the solid's velocity entries) is the force the run measured on the
obstacle in those steps, and its rows' contributions add up to it. Needs IQMPM_BIN (ctest sets
it)."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent.parent
SCENE = REPO / "benchmarks" / "dam_break_obstacle" / "dam_break_obstacle.json"
BIN = os.environ.get("IQMPM_BIN")
sys.path.insert(0, str(REPO / "benchmarks" / "solvers"))
import force_sources  # noqa: E402

pytestmark = pytest.mark.skipif(not BIN, reason="IQMPM_BIN is not set (ctest sets it)")

# The water reaches the obstacle at about 0.14 s; at twice the scene's dx these steps lie in
# the first impact (checked below: the force must not be small).
STEPS = (60, 61, 62)


@pytest.fixture(scope="module")
def dumped_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("obstacle")
    result = subprocess.run([BIN, "run", str(SCENE), "-o", str(out), "--quiet", "--threads", "1",
                             "--set", "write_frames=false", "--set", "dx=0.009125", "--set", "end_time=0.2",
                             "--dump-system", ",".join(map(str, STEPS))], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr[-2000:]
    return out


def test_rebuilt_force_is_the_measured_force(dumped_run):
    report = dumped_run / "sources.json"
    force_sources.main([str(dumped_run), "--metrics", str(dumped_run / "metrics.csv"),
                        "--probe", "obstacle_force_x", "--json", str(report), "--top", "5"])
    steps = json.loads(report.read_text())
    assert [s["step"] for s in steps] == [str(n) for n in STEPS]
    for s in steps:
        assert abs(s["probe"]) > 20, f"step {s['step']}: {s['probe']} N/m: not in the impact any more, move STEPS"
        assert s["force"] == pytest.approx(s["probe"], rel=1e-6)
        assert sum(s["by_block"].values()) == pytest.approx(s["force"], rel=1e-6)
        assert set(s["by_block"]) >= {"p_f", "h"}
        assert len(s["rows"]) == 5
        # `new` needs the previous step's dump: unknown for the first step, known for the others.
        first = s["step"] == str(STEPS[0])
        assert all((r["new"] is None) == first for r in s["rows"])


@pytest.mark.parametrize("args, message", [(["--axis", "2"], "--axis 2: accepted 0 to 1"),
                                           (["--metrics", "m.csv"], "--metrics needs --probe")])
def test_bad_input_names_the_option_and_exits_2(dumped_run, capsys, args, message):
    with pytest.raises(SystemExit) as stop:
        force_sources.main([str(dumped_run), *args])
    assert stop.value.code == 2
    assert message in capsys.readouterr().err
