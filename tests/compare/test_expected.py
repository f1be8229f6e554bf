"""Expected results (benchmarks/<folder>/expected.json): parsing, pass / fail, the shipped files."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from compare import expected as exp
from compare.io import CompareError, read_run
from compare.registry import REGISTRY, lookup
from compare_synth import WALL_FORCE, hydrostatic_run, write_metrics, write_summary

REPO = Path(__file__).resolve().parents[2]


def _write(tmp_path: Path, folder: str, data, scenes=("hydrostatic_2d",)) -> Path:
    d = tmp_path / "benchmarks" / folder
    d.mkdir(parents=True, exist_ok=True)
    for s in scenes:
        (d / f"{s}.json").write_text("{}")
    path = d / exp.EXPECTED_FILE
    path.write_text(json.dumps(data))
    return path


def _checks(tmp_path: Path, *checks, name="hydrostatic_2d", folder="hydrostatic"):
    path = _write(tmp_path, folder, {name: list(checks)}, scenes=(name,))
    return exp.read_expected(path, exp.scene_stems(path.parent))[name]


def _run(tmp_path: Path, factor: float, **kw):
    return read_run(hydrostatic_run(tmp_path / f"run{factor}", force_factor=factor,
                                    frames=False, **kw), "iqmpm")


FORCE = {"metric": "wall_force_final", "value": WALL_FORCE, "margin": {"relative": 0.02},
         "source": "analytic; issue 2"}


# --------------------------------------------------------------------------- the shipped files


def test_every_benchmark_compare_knows_has_expected_results():
    checks = exp.load_all(REPO)  # parses and validates every benchmarks/*/expected.json
    missing = [name for name in REGISTRY if name not in checks]
    assert not missing, f"no expected.json entry for {missing}"
    for name, items in checks.items():
        assert items, name
        for c in items:
            assert c.source.strip() and c.file is not None
            assert c.file.parent.parent == REPO / "benchmarks"
            assert (c.file.parent / f"{name}.json").is_file()  # beside its scene


def test_the_settled_criteria_of_issue_20():
    checks = exp.load_all(REPO)
    front = [c for c in checks["dam_break"] if c.metric == "front_x"]
    judged = [c for c in front if c.margin is not None]
    assert len(judged) == 1 and judged[0].value == "interFoam level 3"
    assert judged[0].reference_level == 3 and judged[0].margin == exp.Margin("relative", 0.03)
    ko = [c for c in front if c.value == "ko1996"]
    assert len(ko) == 1 and ko[0].margin is None  # Koshizuka & Oka: information only
    gate = {c.metric: c for c in checks["elastic_gate"]}
    assert gate["gate_tip_dx_peak"].margin == exp.Margin("relative", 0.15)
    assert gate["gate_tip_dx"].value == "experiment_x"
    assert gate["gate_tip_dx"].margin == exp.Margin("relative", 0.25)
    assert gate["gate_tip_dy"].margin is None and "26.8 %" in gate["gate_tip_dy"].note
    assert "7.8 MPa" in gate["gate_tip_dy"].note


def test_expected_json_is_not_taken_for_a_scene():
    from compare.validate import discover

    names = [s.name for s in discover(REPO)]
    assert "expected" not in names and "dam_break" in names


# --------------------------------------------------------------------------- parsing


@pytest.mark.parametrize("check, message", [
    ({"metric": "nosuch", "value": 1.0, "margin": {"relative": 0.1}, "source": "x"},
     "'nosuch' is not a scalar of hydrostatic_2d"),
    ({"metric": "wall_force_final", "value": 1.0, "source": "x"}, "missing 'margin'"),
    ({"metric": "wall_force_final", "value": 1.0, "margin": {"relative": 0.1}}, "missing 'source'"),
    ({"metric": "wall_force_final", "value": 1.0, "margin": {"relative": 0.1}, "source": " "},
     "'source' must say"),
    ({"metric": "volume_drift", "value": 0, "margin": {"relative": 0.1}, "source": "x"},
     "a relative margin about 0 means nothing"),
    ({"metric": "wall_force_final", "value": 1.0, "margin": {"percent": 2}, "source": "x"},
     "unknown margin kind 'percent'"),
    ({"metric": "wall_force_final", "value": 1.0, "margin": {"relative": -1}, "source": "x"},
     "must be a number > 0"),
    ({"metric": "wall_force_final", "value": 1.0, "margin": 0.02, "source": "x"},
     "'margin' must be null or one of"),
    ({"metric": "wall_force_final", "value": 1.0, "margin": None, "source": "x", "tol": 1},
     "unknown key(s) tol"),
    ({"metric": "wall_force_x", "value": "nosuch", "margin": {"relative": 0.1}, "source": "x"},
     "'nosuch' is not a reference of wall_force_x (known: analytic, interFoam"),
    ({"metric": "wall_force_final", "value": "analytic", "margin": None, "source": "x"},
     "'wall_force_final' is not a metric series"),
    ({"metric": "status", "value": "ok", "margin": {"relative": 0.1}, "source": "x"},
     "a status check has value \"ok\" and no margin"),
    ({"metric": "wall_force_final", "value": 1.0, "margin": None, "source": "x",
      "reference_run": "r"}, "'reference_run' only goes with a series check"),
])
def test_malformed_checks_are_clear_errors(tmp_path, check, message):
    with pytest.raises(CompareError) as info:
        _checks(tmp_path, check)
    assert message in str(info.value) and "hydrostatic_2d[0]" in str(info.value)


def test_a_key_that_names_no_scene_of_the_folder_is_an_error(tmp_path):
    _write(tmp_path, "hydrostatic", {"hydrostatic_4d": []})
    with pytest.raises(CompareError, match="'hydrostatic_4d' is no scene of"):
        exp.load_all(tmp_path)


def test_a_benchmark_without_registry_entry_takes_only_status_checks(tmp_path):
    _write(tmp_path, "stability", {"wobble": [FORCE]}, scenes=("wobble",))
    with pytest.raises(CompareError, match="only status checks"):
        exp.load_all(tmp_path)


# --------------------------------------------------------------------------- pass / fail


def _one(tmp_path, check, ours, foam=(), **kw):
    bench = lookup("hydrostatic_2d")
    (c,) = _checks(tmp_path, check)
    (r,) = exp.evaluate(bench, [c], ours, list(foam), REPO / "data", **kw)
    return r


def test_scalar_inside_the_margin_passes_and_outside_fails(tmp_path):
    inside = _one(tmp_path, FORCE, [_run(tmp_path, 1.019)])
    assert inside.result == exp.PASS and inside.detail == "+1.90 %"
    assert inside.value == pytest.approx(1.019 * WALL_FORCE)
    outside = _one(tmp_path, FORCE, [_run(tmp_path, 0.979)])
    assert outside.result == exp.FAIL and outside.detail == "-2.10 %"
    assert outside.expected == "1226.25 N/m ± 2 %"


def test_absolute_margin_and_information(tmp_path):
    drift = {"metric": "volume_drift", "value": 0, "margin": {"absolute": 1e-3}, "source": "s"}
    ours = [_run(tmp_path, 1.0)]  # compare_synth: volume_drift 1e-4
    assert _one(tmp_path, drift, ours).result == exp.PASS
    assert _one(tmp_path, {**drift, "margin": {"absolute": 1e-5}}, ours).result == exp.FAIL
    info = _one(tmp_path, {**FORCE, "margin": None}, [_run(tmp_path, 1.5)])
    assert info.result == exp.INFO and info.detail == "+50.00 %"


def test_series_relative_l2_and_rms_margins(tmp_path):
    check = {"metric": "wall_force_x", "value": "analytic", "margin": {"relative": 0.05},
             "source": "s"}
    assert _one(tmp_path, check, [_run(tmp_path, 1.04)]).result == exp.PASS
    r = _one(tmp_path, check, [_run(tmp_path, 1.06)])
    assert r.result == exp.FAIL and exp.shown_value(r) == "6.00 %" and r.value == pytest.approx(0.06)
    rms = {**check, "margin": {"absolute": 10.0}}  # N/m
    assert _one(tmp_path, rms, [_run(tmp_path, 1.005)]).result == exp.PASS  # 6.1 N/m
    assert _one(tmp_path, rms, [_run(tmp_path, 1.01)]).result == exp.FAIL  # 12.3 N/m


def test_against_an_interfoam_level_not_computed_is_not_checked(tmp_path):
    check = {"metric": "wall_force_x", "value": "interFoam level 3",
             "margin": {"relative": 0.05}, "source": "s"}
    ours = [_run(tmp_path, 1.0)]
    l1 = read_run(hydrostatic_run(tmp_path / "foam1", foam=True, level=1, frames=False),
                  "interFoam")
    r = _one(tmp_path, check, ours, [l1])
    assert r.result == exp.NOT_CHECKED and "level 3 not computed" in r.detail
    l3 = read_run(hydrostatic_run(tmp_path / "foam3", foam=True, level=3, frames=False,
                                  force_factor=1.1), "interFoam")
    r = _one(tmp_path, check, ours, [l1, l3])
    assert r.result == exp.FAIL and r.measure == "rel. L2 vs interFoam L3"
    # from the cache of an earlier run (validate passes a finder)
    r = _one(tmp_path, check, ours, [l1], foam_level=lambda level: (l3, "cached run"))
    assert r.result == exp.FAIL and r.detail == "reference: cached run"


def test_a_shipped_reference_run_stands_in_for_the_level(tmp_path):
    ship = tmp_path / "benchmarks" / "hydrostatic" / "references" / "l3"
    t = np.linspace(0.01, 2.0, 50)
    write_metrics(ship, t, {"wall_force_x": np.full_like(t, WALL_FORCE * 1.01)})
    write_summary(ship, level=3, case="hydrostatic")
    check = {"metric": "wall_force_x", "value": "interFoam level 3",
             "margin": {"relative": 0.05}, "source": "s", "reference_run": "references/l3"}
    r = _one(tmp_path, check, [_run(tmp_path, 1.0)])
    assert r.result == exp.PASS and r.value == pytest.approx(0.01 / 1.01, rel=1e-6)
    assert "shipped reference benchmarks/hydrostatic/references/l3" in r.detail
    r = _one(tmp_path, {**check, "margin": {"relative": 0.005}}, [_run(tmp_path, 1.0)])
    assert r.result == exp.FAIL


def test_checks_apply_to_the_default_resolution_only(tmp_path):
    level2 = _run(tmp_path, 1.0, level=2)
    r = _one(tmp_path, FORCE, [level2])
    assert r.result == exp.NOT_CHECKED and "level 1" in r.detail
    r = _one(tmp_path, FORCE, [_run(tmp_path, 1.5, level=1), level2])
    assert r.result == exp.FAIL and r.run == "IQ-MPM L1"


def test_failed_runs_fail_status_and_leave_the_rest_not_checked(tmp_path):
    status = {"metric": "status", "value": "ok", "source": "runs to the end"}
    bad = tmp_path / "bad"
    write_summary(bad, status="particle left the domain at step 12")
    bad_run = read_run(bad, "iqmpm")
    r = _one(tmp_path, status, [bad_run])
    assert r.result == exp.FAIL and "left the domain" in r.detail
    assert _one(tmp_path, FORCE, [bad_run]).result == exp.NOT_CHECKED
    # a run that left no folder to read: validate passes its failure
    r = _one(tmp_path, status, [], failed={1: "timed out after 900 s"})
    assert r.result == exp.FAIL and "timed out" in r.detail
    r = _one(tmp_path, FORCE, [], failed={1: "timed out after 900 s"})
    assert r.result == exp.NOT_CHECKED and "timed out" in r.detail
    assert _one(tmp_path, status, [_run(tmp_path, 1.0)]).result == exp.PASS


def test_a_metric_missing_from_a_successful_run_fails(tmp_path):
    run = tmp_path / "nocol"
    t = np.linspace(0, 2, 11)
    write_metrics(run, t, {"max_speed": np.zeros_like(t)})
    write_summary(run)
    r = _one(tmp_path, FORCE, [read_run(run, "iqmpm")])
    assert r.result == exp.FAIL and "does not provide wall_force_final" in r.detail
    nan = tmp_path / "nan"
    write_metrics(nan, t, {"wall_force_x": np.full_like(t, math.nan)})
    write_summary(nan)
    assert _one(tmp_path, FORCE, [read_run(nan, "iqmpm")]).result == exp.FAIL


def test_tally_counts_each_result():
    results = [exp.CheckResult("b", "m", "value", 1.0, "", "", res, "", "")
               for res in (exp.PASS, exp.PASS, exp.FAIL, exp.INFO, exp.NOT_CHECKED)]
    assert exp.Tally().add(results).text() == "2 pass, 1 fail, 1 not checked, 1 info"


@pytest.mark.parametrize("factor, result", [(1.02, exp.PASS), (1.04, exp.FAIL)])
def test_dam_break_front_against_the_shipped_interfoam_level_3(tmp_path, factor, result):
    """The issue-20 criterion in the quick suite: no level-3 run, the shipped front stands in."""
    from compare.io import read_metrics

    shipped = REPO / "benchmarks" / "dam_break" / "references" / "interfoam_level3"
    ref = read_metrics(shipped)
    assert read_run(shipped, "interFoam").level == 3 and len(ref.t) > 100
    ours = tmp_path / "ours"
    write_metrics(ours, ref.t, {"front_x": factor * ref.column("front_x")})
    write_summary(ours, dx=0.0045625)
    bench = lookup("dam_break")
    (check,) = [c for c in exp.load_all(REPO)["dam_break"] if c.value == "interFoam level 3"]
    (r,) = exp.evaluate(bench, [check], [read_run(ours, "iqmpm")], [], REPO / "data")
    assert r.result == result and r.value == pytest.approx(factor - 1, rel=1e-6)
    assert "shipped reference benchmarks/dam_break/references/interfoam_level3" in r.detail
    assert "STALE" not in r.detail  # foam_cases/dam_break and the driver as when it was made
