"""Expected results beside each benchmark: ``benchmarks/<folder>/expected.json``.

One file per benchmark folder; its top-level keys are the scene stems of that folder (the
registry's benchmark names), each a list of checks::

    {"hydrostatic_2d": [
        {"metric": "wall_force_final", "value": 1226.25, "margin": {"relative": 0.02},
         "source": "analytic rho g H^2/2; margin: issue 2"},
        {"metric": "front_x", "value": "interFoam level 3", "margin": {"relative": 0.03},
         "source": "...", "reference_run": "references/interfoam_level3"},
        {"metric": "gate_tip_dy", "value": "experiment_y", "margin": null,
         "source": "...", "note": "reported without a criterion"},
        {"metric": "status", "value": "ok", "source": "runs to its end time"}]}

A check's kind follows from ``metric`` and ``value`` (see compare/README.md, "Expected
results"):

* scalar: ``metric`` is one of the benchmark's registry scalars, ``value`` a number; pass
  when ``|x - value| <= margin`` (absolute) or ``<= margin * |value|`` (relative);
* series: ``metric`` is one of the benchmark's registry metric columns, ``value`` names
  the reference series: a registry reference key of that metric (``experiment_x``,
  ``ko1996``, ``analytic``), ``interFoam`` (the comparison's first interFoam run) or
  ``interFoam level N``; pass when the relative L2 error is at most the relative margin
  (or the RMS difference at most the absolute margin, in the metric's unit);
* status: ``metric`` "status", ``value`` "ok": pass when the run's status is ok.

``margin: null`` makes a check informational: computed and reported, never pass or fail.
Checks are evaluated on the IQ-MPM run at the default resolution (level 1), where the
project's criteria are stated. A result is ``pass``, ``fail``, ``not checked`` (with the
reason: the run failed, a reference level was not computed) or ``info``; only ``fail``
fails ``compare validate``, and ``not checked`` never counts as a pass.
"""

from __future__ import annotations

import math
import re
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

from compare.io import CompareError, Run, read_json_object, read_run
from compare.registry import Benchmark, CsvReference, MetricSpec, ScalarSpec, lookup

EXPECTED_FILE = "expected.json"
CHECK_KEYS = {"metric", "value", "margin", "source", "note", "reference_run"}
LEVEL_RE = re.compile(r"^interFoam level (\d+)$")

PASS, FAIL, NOT_CHECKED, INFO = "pass", "fail", "not checked", "info"


@dataclass(frozen=True)
class Margin:
    kind: str  # "relative" or "absolute"
    size: float

    def text(self, unit: str = "") -> str:
        if self.kind == "relative":
            return f"{100.0 * self.size:g} %"
        return f"{self.size:g}" + (f" {unit}" if unit and unit != "-" else "")


@dataclass(frozen=True)
class Check:
    benchmark: str
    metric: str
    kind: str  # "scalar", "series" or "status"
    value: float | str
    margin: Margin | None  # None: informational
    source: str
    note: str = ""
    reference_run: Path | None = None  # a shipped reference run folder (series checks)
    file: Path | None = None

    @property
    def reference_level(self) -> int | None:
        m = LEVEL_RE.match(str(self.value)) if self.kind == "series" else None
        return int(m.group(1)) if m else None


@dataclass
class CheckResult:
    benchmark: str
    metric: str
    measure: str  # what was measured, e.g. "value", "rel. L2 vs interFoam L3"
    value: float | None  # our value or error
    expected: str  # the reference and the margin as text
    margin: str
    result: str  # PASS, FAIL, NOT_CHECKED, INFO
    detail: str  # why (the error, or why not checked)
    source: str
    note: str = ""
    unit: str = ""
    run: str = ""  # the run judged

    def to_json(self) -> dict[str, Any]:
        return asdict(self)

    @staticmethod
    def from_json(d: dict[str, Any]) -> "CheckResult":
        return CheckResult(**{k: d.get(k, "") for k in CheckResult.__dataclass_fields__})


# --------------------------------------------------------------------------- reading


def _fail(path: Path, where: str, message: str) -> CompareError:
    return CompareError(f"{path}: {where}: {message}")


def _parse_margin(path: Path, where: str, raw: Any) -> Margin | None:
    if raw is None:
        return None
    if not isinstance(raw, dict) or len(raw) != 1:
        raise _fail(path, where, "'margin' must be null or one of {\"relative\": r} and "
                                 "{\"absolute\": a}")
    (kind, size), = raw.items()
    if kind not in ("relative", "absolute"):
        raise _fail(path, where, f"unknown margin kind '{kind}' (relative or absolute)")
    if isinstance(size, bool) or not isinstance(size, (int, float)) or not size > 0 \
            or not math.isfinite(size):
        raise _fail(path, where, f"margin {kind} must be a number > 0, not {size!r}")
    return Margin(kind, float(size))


def _series_reference_ok(spec: MetricSpec, bench: Benchmark, value: str) -> bool:
    if value == "interFoam" or LEVEL_RE.match(value):
        return bench.foam_case is not None
    return any(r.key == value for r in spec.references)


def parse_check(path: Path, bench: Benchmark, index: int, raw: Any) -> Check:
    where = f"{bench.name}[{index}]"
    if not isinstance(raw, dict):
        raise _fail(path, where, "a check must be a JSON object")
    unknown = set(raw) - CHECK_KEYS
    if unknown:
        raise _fail(path, where, f"unknown key(s) {', '.join(sorted(unknown))} "
                                 f"(accepted: {', '.join(sorted(CHECK_KEYS))})")
    for key in ("metric", "value", "source"):
        if key not in raw:
            raise _fail(path, where, f"missing '{key}'")
    metric, value, source = raw["metric"], raw["value"], raw["source"]
    if not isinstance(source, str) or not source.strip():
        raise _fail(path, where, "'source' must say where the value and the margin come from")
    note = raw.get("note", "")
    if not isinstance(note, str):
        raise _fail(path, where, "'note' must be a string")
    if metric == "status":
        if value != "ok" or raw.get("margin") is not None:
            raise _fail(path, where, "a status check has value \"ok\" and no margin")
        return Check(bench.name, metric, "status", "ok", None, source, note, file=path)
    if "margin" not in raw:
        raise _fail(path, where, "missing 'margin' (null for a check reported without a "
                                 "criterion)")
    margin = _parse_margin(path, where, raw["margin"])
    scalar = next((s for s in bench.scalars if s.name == metric), None)
    series = bench.metric(metric) if isinstance(metric, str) else None
    reference_run = None
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        if scalar is None:
            raise _fail(path, where, f"'{metric}' is not a scalar of {bench.name} (scalars: "
                                     f"{', '.join(s.name for s in bench.scalars) or 'none'})")
        if margin is not None and margin.kind == "relative" and value == 0:
            raise _fail(path, where, "a relative margin about 0 means nothing: use an "
                                     "absolute one")
        kind: str = "scalar"
        value = float(value)
    elif isinstance(value, str):
        if series is None:
            raise _fail(path, where, f"'{metric}' is not a metric series of {bench.name} "
                                     f"(series: {', '.join(m.column for m in bench.metrics) or 'none'})")
        if not _series_reference_ok(series, bench, value):
            keys = [r.key for r in series.references]
            if bench.foam_case:
                keys += ["interFoam", "interFoam level N"]
            raise _fail(path, where, f"'{value}' is not a reference of {metric} (known: "
                                     f"{', '.join(keys) or 'none'})")
        kind = "series"
        if series.absolute and margin is not None and margin.kind == "relative":
            raise _fail(path, where, f"'{metric}' is a zero quantity compared in its unit "
                                     f"(absolute): give an absolute margin (RMS difference)")
        if "reference_run" in raw:
            if not LEVEL_RE.match(value) or not isinstance(raw["reference_run"], str):
                raise _fail(path, where, "'reference_run' (a folder beside expected.json) "
                                         "goes with a value 'interFoam level N'")
            reference_run = path.parent / raw["reference_run"]
    else:
        raise _fail(path, where, "'value' must be a number (a scalar's reference) or the "
                                 "name of a reference series")
    if "reference_run" in raw and kind != "series":
        raise _fail(path, where, "'reference_run' only goes with a series check")
    return Check(bench.name, metric, kind, value, margin, source, note, reference_run, path)


def read_expected(path: Path, scene_names: Sequence[str] | None = None) -> dict[str, list[Check]]:
    """Checks of one ``expected.json``, by benchmark name. ``scene_names``: the scene stems
    of its folder (each key must be one of them when given)."""
    path = Path(path)
    data = read_json_object(path, "an object keyed by benchmark name")
    out: dict[str, list[Check]] = {}
    for name, checks in data.items():
        if scene_names is not None and name not in scene_names:
            raise CompareError(f"{path}: '{name}' is no scene of {path.parent} "
                               f"(scenes: {', '.join(scene_names) or 'none'})")
        bench = lookup(name, path.parent.name)
        if bench.generic and not all(
                isinstance(c, dict) and c.get("metric") == "status" for c in checks or []):
            raise CompareError(f"{path}: '{name}' has no registry entry: only status checks")
        if not isinstance(checks, list):
            raise CompareError(f"{path}: '{name}' must map to a list of checks")
        out[name] = [parse_check(path, bench, i, c) for i, c in enumerate(checks)]
    return out


def scene_stems(folder: Path) -> list[str]:
    return sorted(p.stem for p in folder.glob("*.json") if p.name != EXPECTED_FILE)


def load_all(repo: Path) -> dict[str, list[Check]]:
    """Every ``benchmarks/*/expected.json`` of ``repo``, by benchmark name."""
    out: dict[str, list[Check]] = {}
    for path in sorted((Path(repo) / "benchmarks").glob(f"*/{EXPECTED_FILE}")):
        for name, checks in read_expected(path, scene_stems(path.parent)).items():
            out[name] = checks
    return out


# --------------------------------------------------------------------------- evaluating


def _expected_text(check: Check, unit: str, label: str) -> tuple[str, str]:
    m = check.margin
    if check.kind == "status":
        return "status ok", "-"
    if check.kind == "scalar":
        ref = f"{check.value:g}" + (f" {unit}" if unit and unit != "-" else "")
        if m is None:
            return ref, "none (information)"
        return f"{ref} ± {m.text(unit)}", m.text(unit)
    if m is None:
        return f"{label} (no criterion)", "none (information)"
    bound = (f"rel. L2 <= {m.text()}" if m.kind == "relative"
             else f"RMS difference <= {m.text(unit)}")
    return f"{label}: {bound}", m.text(unit)


FoamRunFinder = Callable[[int], "tuple[Run | None, str]"]


def evaluate(bench: Benchmark, checks: Sequence[Check], ours: Sequence[Run],
             foam: Sequence[Run], data_dir: Path,
             foam_level: FoamRunFinder | None = None,
             failed: dict[int, str] | None = None) -> list[CheckResult]:
    """Results of ``checks`` on the level-1 IQ-MPM run of ``ours``.

    ``foam``: the interFoam runs of this comparison; ``foam_level(N)`` finds a run of
    interFoam level N outside them (the cache of earlier runs), returning (run or None,
    where it came from or why not). ``failed``: IQ-MPM levels that failed without a run
    folder to read, with the failure.
    """
    from compare.analysis import ok_runs

    level1 = [r for r in ours if (r.level if r.level is not None else 1) == 1]
    base: Run | str | None = level1[0] if level1 else (failed or {}).get(1)
    foam_ok = ok_runs(foam)
    return [_evaluate_one(bench, check, base, foam_ok, data_dir, foam_level)
            for check in checks]


def _result(check: Check, measure: str, value: float | None, unit: str, label: str,
            status: str, detail: str, run: str) -> CheckResult:
    expected, margin = _expected_text(check, unit, label)
    return CheckResult(check.benchmark, check.metric, measure, value, expected, margin, status,
                       detail, check.source, check.note, unit, run)


def _not_checked(check: Check, measure: str, unit: str, label: str, why: str,
                 run: str = "") -> CheckResult:
    return _result(check, measure, None, unit, label,
                   INFO if check.margin is None and check.kind != "status" else NOT_CHECKED,
                   why, run)


def _reference_label(spec: MetricSpec, value: str) -> str:
    for r in spec.references:
        if r.key == value:
            return r.label
    return value


def _shown_path(path: Path) -> str:
    """``benchmarks/<folder>/...`` for a path inside a repository's benchmarks folder."""
    parts = Path(path).parts
    if "benchmarks" in parts:
        return "/".join(parts[len(parts) - 1 - parts[::-1].index("benchmarks"):])
    return str(path)


def _find_foam(check: Check, foam: Sequence[Run], foam_level: FoamRunFinder | None
               ) -> tuple[Run | None, str]:
    level = check.reference_level
    if level is None:  # "interFoam": the comparison's first run
        return (foam[0], "") if foam else (None, "no interFoam run in this comparison")
    for r in foam:
        if r.level == level:
            return r, ""
    why = f"interFoam level {level} not computed (run with --levels including {level})"
    if foam_level is not None:
        run, where = foam_level(level)
        if run is not None:
            return run, where
        if where:
            why = where
    if check.reference_run is not None:
        if (check.reference_run / "summary.json").is_file():
            try:
                run = read_run(check.reference_run, "interFoam")
            except CompareError as exc:
                return None, f"shipped reference unreadable: {exc}"
            if run.ok:
                from compare.validate import shipped_reference_stale

                where = f"shipped reference {_shown_path(check.reference_run)}"
                stale = (shipped_reference_stale(run, check.file.parents[2])
                         if check.file is not None and len(check.file.parents) > 2 else "")
                return run, where + (f"; STALE: {stale}" if stale else "")
        why += f"; shipped reference {_shown_path(check.reference_run)} missing"
    return None, why


def _evaluate_one(bench: Benchmark, check: Check, base: Run | str | None,
                  foam: Sequence[Run], data_dir: Path,
                  foam_level: FoamRunFinder | None) -> CheckResult:
    """``base``: the level-1 run, the failure text of a level-1 run that left nothing to
    read, or None when level 1 was not run."""
    from compare.analysis import _error_against
    from compare.reducers import scalar_value

    if check.kind == "status":
        if base is None:
            return _result(check, "status", None, "", "", NOT_CHECKED,
                           "no level-1 run (criteria apply at the default resolution)", "")
        if isinstance(base, str):  # failed without a run folder to read
            return _result(check, "status", None, "", "", FAIL, base, "IQ-MPM L1")
        return _result(check, "status", None, "", "", PASS if base.ok else FAIL, base.status,
                       base.label)
    if check.kind == "scalar":
        spec: ScalarSpec = next(s for s in bench.scalars if s.name == check.metric)
        unit, label, measure = spec.unit, "", "value"
    else:
        mspec = bench.metric(check.metric)
        assert mspec is not None
        unit = mspec.unit
        label = _reference_label(mspec, str(check.value))
        relative = not mspec.absolute and (check.margin is None
                                           or check.margin.kind == "relative")
        measure = f"rel. L2 vs {label}" if relative else f"RMS difference vs {label}"
    if base is None:
        return _not_checked(check, measure, unit, label, "no IQ-MPM run at level 1 "
                            "(criteria apply at the default resolution)")
    if isinstance(base, str):
        return _not_checked(check, measure, unit, label, f"IQ-MPM L1 failed: {base}")
    if not base.ok or base.metrics is None:
        return _not_checked(check, measure, unit, label, f"{base.label} failed: {base.status}",
                            base.label)
    if check.kind == "scalar":
        value = scalar_value(base, spec)
        if value is None:
            return _result(check, measure, None, unit, label,
                           INFO if check.margin is None else FAIL,
                           f"{base.label} does not provide {check.metric}", base.label)
        return _judge(check, measure, value, value - float(check.value), unit, label,
                      base.label)
    # series
    mspec = bench.metric(check.metric)
    assert mspec is not None
    if check.metric not in base.metrics.columns:
        return _result(check, measure, None, unit, label,
                       INFO if check.margin is None else FAIL,
                       f"{base.label} has no column {check.metric}", base.label)
    ref: Any
    origin = ""
    if str(check.value).startswith("interFoam"):
        ref, origin = _find_foam(check, foam, foam_level)
        if ref is None:
            return _not_checked(check, measure, unit, label, origin, base.label)
        if ref.metrics is None or check.metric not in ref.metrics.columns:
            return _not_checked(check, measure, unit, label,
                                f"{ref.label} has no column {check.metric}", base.label)
        label = ref.label
        measure = measure.replace(str(check.value), label)
    else:
        ref = next(r for r in mspec.references if r.key == check.value)
    try:
        if check.margin is not None and check.margin.kind == "absolute":
            from compare.analysis import _ours_series, load_reference
            from compare.errors import series_error

            mine = _ours_series(base, mspec)
            other = (_ours_series(ref, mspec) if isinstance(ref, Run)
                     else load_reference(ref, data_dir, mine.t))
            if isinstance(ref, CsvReference) and ref.normalised:
                raise CompareError("an absolute margin against a normalised reference "
                                   "is not supported")
            error = series_error(mine, other).rms
        else:
            from compare.analysis import Options

            error = _error_against(base, mspec, ref, Options(data_dir))
    except CompareError as exc:
        return _result(check, measure, None, unit, label,
                       INFO if check.margin is None else FAIL, str(exc), base.label)
    result = _judge(check, measure, error, None, unit, label, base.label)
    if origin:
        result.detail = "; ".join(x for x in (result.detail, f"reference: {origin}") if x)
    return result


def _judge(check: Check, measure: str, value: float, deviation: float | None, unit: str,
           label: str, run: str) -> CheckResult:
    """Scalars: ``deviation`` = value - expected; series: ``value`` is the error itself."""
    m = check.margin
    if deviation is not None:  # scalar
        rel = deviation / abs(float(check.value)) if float(check.value) != 0 else math.nan
        detail = (f"{100 * rel:+.2f} %" if math.isfinite(rel)
                  else f"{deviation:+.4g}" + (f" {unit}" if unit and unit != "-" else ""))
        if m is None:
            return _result(check, measure, value, unit, label, INFO, detail, run)
        if not math.isfinite(value):
            return _result(check, measure, value, unit, label, FAIL, "not a number", run)
        size = m.size * abs(float(check.value)) if m.kind == "relative" else m.size
        ok = abs(deviation) <= size * (1 + 1e-12)
        return _result(check, measure, value, unit, label, PASS if ok else FAIL, detail, run)
    detail = ""  # the error itself is the value column
    if m is None:
        return _result(check, measure, value, unit, label, INFO, detail, run)
    if not math.isfinite(value):
        return _result(check, measure, value, unit, label, FAIL, "error is not a number", run)
    ok = value <= m.size * (1 + 1e-12)
    return _result(check, measure, value, unit, label, PASS if ok else FAIL, detail, run)


# --------------------------------------------------------------------------- summaries


@dataclass
class Tally:
    counts: dict[str, int] = field(default_factory=lambda: {PASS: 0, FAIL: 0, NOT_CHECKED: 0,
                                                            INFO: 0})

    def add(self, results: Sequence[CheckResult]) -> "Tally":
        for r in results:
            self.counts[r.result] = self.counts.get(r.result, 0) + 1
        return self

    def text(self) -> str:
        return ", ".join(f"{n} {k}" for k, n in self.counts.items() if n) or "no checks"


def shown_value(r: CheckResult) -> str:
    """Our value as text: a scalar with its unit, a series error in % (or its unit)."""
    if r.value is None or (isinstance(r.value, float) and not math.isfinite(r.value)):
        return "n/a"
    if r.measure == "value":
        return f"{r.value:.4g}" + (f" {r.unit}" if r.unit and r.unit != "-" else "")
    if r.measure.startswith("rel. L2"):
        return f"{100 * r.value:.2f} %"
    return f"{r.value:.4g}" + (f" {r.unit}" if r.unit and r.unit != "-" else "")


def result_text(r: CheckResult) -> str:
    return {PASS: "pass", FAIL: "**FAIL**", NOT_CHECKED: "not checked", INFO: "info"}.get(
        r.result, r.result)


def markdown_rows(results: Sequence[CheckResult], with_benchmark: bool = False) -> list[list[str]]:
    rows = []
    for r in results:
        row = [f"`{r.metric}`", r.measure, shown_value(r), r.expected, r.margin,
               result_text(r), r.detail or "-", r.source + (f" ({r.note})" if r.note else "")]
        rows.append(([r.benchmark] if with_benchmark else []) + row)
    return rows


CHECK_HEADER = ["metric", "measure", "value", "expected", "margin", "result", "deviation / why",
                "source"]
