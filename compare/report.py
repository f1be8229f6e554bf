"""Markdown reports: ``<out>/<benchmark>/report.md`` and ``<out>/index.md``."""

from __future__ import annotations

import datetime as _dt
import json
import math
import os
import platform
import subprocess
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

from compare import __version__
from compare import expected as exp
from compare.analysis import BenchmarkResult
from compare.io import REPO_ROOT, Run


def fmt(x: float | None, digits: int = 4) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "n/a"
    return f"{x:.{digits}g}"


def with_unit(x: float | None, unit: str) -> str:
    """A value and its unit; dimensionless ("-") values are shown bare."""
    return fmt(x) if unit in ("-", "") else f"{fmt(x)} {unit}"


def with_uncertainty(x: float | None, u: float | None, unit: str) -> str:
    """``x ± u unit`` (u: expanded uncertainty), or ``x unit`` without one."""
    if u is None or not math.isfinite(u) or x is None or not math.isfinite(x):
        return with_unit(x, unit)
    return with_unit(x, "") + f" ± {with_unit(u, unit)}"


def pct(x: float | None) -> str:
    if x is None or not math.isfinite(x):
        return "n/a"
    return f"{100.0 * x:.2f}"


def _table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(str(c).replace("|", "/") for c in row) + " |" for row in rows]
    return out


# --------------------------------------------------------------------------- versions


def software_versions(runs: Sequence[Run] = (), solver_bin: Path | None = None) -> dict[str, str]:
    import matplotlib
    import meshio
    import numpy
    import scipy

    versions = {
        "compare": __version__,
        "python": platform.python_version(),
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "matplotlib": matplotlib.__version__,
        "meshio": meshio.__version__,
        "repository": _git_describe(),
    }
    for run in runs:
        for key in ("version", "solver_version", "openfoam_version", "git_commit"):
            if key in run.summary:
                name = "iqmpm" if run.solver == "iqmpm" else "OpenFOAM"
                versions.setdefault(f"{name} ({key})", str(run.summary[key]))
    if solver_bin is not None and "iqmpm (version)" not in versions:
        v = _run_quiet([str(solver_bin), "--version"])
        if v:
            versions["iqmpm (--version)"] = v
    return versions


def _run_quiet(cmd: list[str]) -> str | None:
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    text = (p.stdout or p.stderr).strip().splitlines()
    return text[0] if p.returncode == 0 and text else None


def _git_describe() -> str:
    commit = _run_quiet(["git", "-C", str(REPO_ROOT), "rev-parse", "--short", "HEAD"])
    if not commit:
        return "unknown (not a git checkout)"
    dirty = _run_quiet(["git", "-C", str(REPO_ROOT), "status", "--porcelain", "--untracked-files=no"])
    return commit + (" (uncommitted changes)" if dirty else "")


# --------------------------------------------------------------------------- one benchmark


def checks_section(checks: Sequence[exp.CheckResult]) -> list[str]:
    """The report's table of expected.json checks (empty without checks)."""
    if not checks:
        return []
    tally = exp.Tally().add(checks)
    lines = ["## Checks (expected.json)", "",
             f"{tally.text()}. Judged on the IQ-MPM run at the default resolution (level 1); "
             "scalars: |value - expected| within the margin; series: relative L2 error (or "
             "RMS difference for an absolute margin) within it; `info`: reported without a "
             "criterion; `not checked` never counts as a pass.", ""]
    lines += _table(exp.CHECK_HEADER, exp.markdown_rows(checks))
    lines.append("")
    return lines



def _run_settings(runs: Sequence[Run]) -> list[str]:
    rows = []
    for r in runs:
        size = r.summary.get("particles", r.summary.get("cells", "n/a"))
        cmd = r.record.get("command")
        rows.append([
            r.label, f"`{r.path}`", str(r.level if r.level is not None else "n/a"),
            fmt(r.dx), str(size), str(r.summary.get("steps", "n/a")), fmt(r.wall_time),
            str(r.record.get("threads", r.summary.get("threads", r.summary.get("np", "n/a")))),
            r.status if r.ok else f"**{r.status}**",
            f"`{' '.join(cmd)}`" if isinstance(cmd, list) else "n/a",
        ])
    lines = _table(["run", "folder", "level", "dx (m)", "particles / cells", "steps",
                    "wall time (s)", "threads / np", "status", "command"], rows)
    for r in runs:
        extra = []
        stages = r.summary.get("stage_seconds")
        if isinstance(stages, dict) and stages:
            extra.append("stage seconds: " + ", ".join(f"{k} {fmt(float(v), 3)}"
                                                       for k, v in stages.items()
                                                       if isinstance(v, (int, float))))
        lin = r.summary.get("linear_iterations")
        if isinstance(lin, dict):
            extra.append("linear iterations (min/mean/max): " + "/".join(
                fmt(lin.get(k)) if isinstance(lin.get(k), (int, float)) else "n/a"
                for k in ("min", "mean", "max")))
        for key in ("active_cells", "volume_drift", "particle_volume_drift"):
            if key in r.summary:
                extra.append(f"{key}: {r.summary[key]}")
        if extra:
            lines.append(f"- {r.label}: " + "; ".join(extra))
    scenes = [(r, r.summary.get("scene")) for r in runs if isinstance(r.summary.get("scene"), dict)]
    if scenes:
        r, scene = scenes[0]
        text = json.dumps(scene, indent=1, sort_keys=True)
        if len(text) > 6000:
            text = text[:6000] + "\n... (truncated)"
        lines += ["", f"<details><summary>Resolved scene of {r.label}</summary>", "",
                  "```json", text, "```", "", "</details>"]
    return lines


def write_report(result: BenchmarkResult, out_dir: Path, extra_status: Sequence[str] = (),
                 solver_bin: Path | None = None) -> Path:
    """Write ``out_dir/report.md`` (plots already in ``out_dir``)."""
    b = result.benchmark
    lines: list[str] = [f"# {b.name}: {b.title}", "",
                        f"Generated {_dt.datetime.now().isoformat(timespec='seconds')} by "
                        f"compare {__version__}. Errors as defined in "
                        f"`docs/benchmarks.md` (see `compare/README.md`).", ""]
    lines += ["## Status", ""]
    for r in result.ours + result.foam:
        lines.append(f"- {r.label}: {r.status}")
    lines += [f"- {s}" for s in extra_status]
    lines.append("")

    lines += checks_section(result.checks)

    lines += ["## Errors", ""]
    if result.series_rows:
        lines += ["### Time series", "",
                  "rel. L2 = sqrt(int (y - r)^2 dt / int r^2 dt) over the common window; "
                  "peak = sample of largest magnitude in the window; peak error = "
                  "(peak - peak_ref) / |peak_ref|; peak time error = t_peak - t_peak_ref. "
                  "A quantity whose true value is zero (marked *absolute*: the rotation of a "
                  "heaving block) has only the absolute errors: its RMS difference and "
                  "peaks in its unit.", ""]
        rows = []
        for s in result.series_rows:
            e = s.error
            absolute = s.absolute
            rows.append([f"`{s.metric}`" + (" (absolute)" if absolute else ""), s.run, s.against,
                         f"[{fmt(e.window[0])}, {fmt(e.window[1])}]" + ("" if s.t_unit == "-" else f" {s.t_unit}"), str(e.n_points),
                         "n/a" if absolute else pct(e.rel_l2), with_unit(e.rms, s.unit),
                         with_unit(e.peak_ours, s.unit), with_unit(e.peak_ref, s.unit),
                         "n/a" if absolute else pct(e.peak_rel_error),
                         with_unit(e.peak_time_error, s.t_unit)])
        lines += _table(["metric", "run", "against", "window", "points", "rel. L2 (%)",
                         "RMS difference", "peak", "peak (ref)", "peak error (%)",
                         "peak time error"], rows)
        lines.append("")
    if result.scalar_rows:
        lines += ["### Scalars", "",
                  "± : expanded uncertainty (k = 2) of a fitted period, frequency or decay ratio. "
                  "*beyond uncertainty*: |value - reference| > sqrt(U_value^2 + U_reference^2) "
                  "(`no`: the difference is within the estimates' own uncertainty); `-` without "
                  "an uncertainty. A zero reference (or one within the quantity's noise floor) "
                  "has only the absolute error.", ""]
        rows = [[f"`{s.name}`", s.description, s.run,
                 with_uncertainty(s.value, s.uncertainty, s.unit),
                 with_uncertainty(s.reference, s.reference_uncertainty, s.unit)
                 + (f" ({s.against})" if s.against != fmt(s.reference) else ""),
                 pct(s.rel_error), with_unit(s.abs_error, s.unit),
                 {True: "yes", False: "no", None: "-"}[s.beyond_uncertainty]]
                for s in result.scalar_rows]
        lines += _table(["quantity", "description", "run", "value", "reference",
                         "rel. error (%)", "abs. error", "beyond uncertainty"], rows)
        lines.append("")
    if result.field_rows:
        lines += ["### Fields", "",
                  "Profiles interpolated onto 101 common points of their common range.", ""]
        rows = [[f.kind, fmt(f.time_ours), fmt(f.time_ref), f.against, pct(f.rel_l2),
                 f"{fmt(f.max_abs)} {f.unit}"] for f in result.field_rows]
        lines += _table(["field", "t IQ-MPM (s)", "t reference (s)", "against", "rel. L2 (%)",
                         "max abs. difference"], rows)
        lines.append("")
    if not (result.series_rows or result.scalar_rows or result.field_rows):
        lines += ["No errors computed (see Notes).", ""]

    lines += ["## Convergence", ""]
    if result.convergence:
        rows = [[c.solver, f"`{c.quantity}`", c.against, ",".join(map(str, c.levels)),
                 ", ".join(fmt(h, 3) for h in c.h), ", ".join(fmt(e, 3) for e in c.errors),
                 fmt(c.order, 3), ", ".join(fmt(p, 3) for p in c.pairwise) or "-",
                 fmt(c.extrapolated) if c.extrapolated is not None else "-", c.note or "-"]
                for c in result.convergence]
        lines += _table(["solver", "quantity", "against", "levels", "h / h_coarsest (-)",
                         "errors (-)", "observed order (-)", "pairwise orders (-)",
                         "extrapolated", "note"], rows)
    else:
        lines.append("Needs runs at two or more levels (`--levels 1,2,3`).")
    lines.append("")

    lines += ["## Run time against error", ""]
    if result.cost is not None:
        c = result.cost
        lines += [f"Error measure: {c.measure}.", ""]
        rows = [[p.solver, str(p.level), fmt(p.wall_time), pct(p.error)] for p in c.points]
        lines += _table(["solver", "level", "wall time (s)", "error (%)"], rows)
        lines.append("")
        for err, t_ours, t_foam in c.ratios:
            lines.append(f"- At matched error {pct(err)} %: IQ-MPM {fmt(t_ours)} s, interFoam "
                         f"{fmt(t_foam)} s; wall-time ratio interFoam / IQ-MPM = "
                         f"**{fmt(t_foam / t_ours, 3)}** (log-log interpolation).")
        for b in c.bounds:
            bound = "≥" if b.fast.solver == "IQ-MPM" else "≤"
            ratio = b.ratio if b.fast.solver == "IQ-MPM" else 1 / b.ratio
            lines.append(f"- No matched error: {b.fast.solver} L{b.fast.level} ({pct(b.fast.error)} %, "
                         f"{fmt(b.fast.wall_time)} s) has no larger error than {b.slow.solver}'s most "
                         f"accurate run, L{b.slow.level} ({pct(b.slow.error)} %, {fmt(b.slow.wall_time)} s): "
                         f"wall-time ratio interFoam / IQ-MPM at matched error **{bound} {fmt(ratio, 3)}** "
                         f"(if {b.slow.solver}'s error falls with its cost).")
        if c.note:
            lines.append(f"- {c.note}")
    else:
        lines.append("Not available (see Notes).")
    lines.append("")

    if result.plots:
        lines += ["## Plots", ""]
        for title, path in result.plots:
            lines += [f"### {title}", "", f"![{title}]({os.path.relpath(path, out_dir)})", ""]
    if result.notes:
        lines += ["## Notes", ""] + [f"- {n}" for n in result.notes] + [""]
    lines += ["## Run settings", ""] + _run_settings(result.ours + result.foam) + [""]
    lines += ["## Software versions", ""]
    versions = software_versions(result.ours + result.foam, solver_bin)
    lines += _table(["software", "version"], [[k, v] for k, v in versions.items()])
    lines.append("")
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "report.md"
    path.write_text("\n".join(lines))
    return path


# --------------------------------------------------------------------------- index


@dataclass
class IndexEntry:
    name: str
    iqmpm: str  # status text
    openfoam: str
    headline: str  # key errors
    report: Path | None
    failed: bool  # a run or the comparison failed
    generated: str = ""
    checks: list[exp.CheckResult] = field(default_factory=list)
    commit: str = ""
    title: str = ""

    @property
    def checks_failed(self) -> bool:
        return any(c.result == exp.FAIL for c in self.checks)


ENTRY_FILE = "entry.json"


def write_entry(entry: IndexEntry, bench_dir: Path) -> None:
    """The benchmark's line of the index, kept beside its report (index.md is rebuilt from these)."""
    bench_dir.mkdir(parents=True, exist_ok=True)
    data = {"name": entry.name, "iqmpm": entry.iqmpm, "openfoam": entry.openfoam,
            "headline": entry.headline, "report": entry.report.name if entry.report else None,
            "failed": entry.failed,
            "generated": entry.generated or _dt.datetime.now().isoformat(timespec="seconds"),
            "commit": entry.commit or _git_describe(), "title": entry.title,
            "checks": [c.to_json() for c in entry.checks]}
    (bench_dir / ENTRY_FILE).write_text(json.dumps(data, indent=1))


def read_entries(out: Path) -> list[IndexEntry]:
    entries = []
    for path in sorted(Path(out).glob(f"*/{ENTRY_FILE}")):
        try:
            d = json.loads(path.read_text())
            entries.append(IndexEntry(
                d["name"], d["iqmpm"], d["openfoam"], d["headline"],
                path.parent / d["report"] if d.get("report") else None, bool(d["failed"]),
                d.get("generated", ""),
                [exp.CheckResult.from_json(c) for c in d.get("checks", [])],
                d.get("commit", ""), d.get("title", "")))
        except (OSError, json.JSONDecodeError, KeyError, TypeError):
            continue
    return entries


def checks_cell(checks: Sequence[exp.CheckResult]) -> str:
    if not checks:
        return "-"
    text = exp.Tally().add(checks).text()
    return text.replace(f"{exp.FAIL}", "**FAIL**") if any(
        c.result == exp.FAIL for c in checks) else text


def headline(result: BenchmarkResult) -> str:
    parts = []
    for s in result.series_rows[:4]:
        if s.absolute:
            parts.append(f"{s.metric} vs {s.against}: RMS {with_unit(s.error.rms, s.unit)}")
        else:
            parts.append(f"{s.metric} vs {s.against}: {pct(s.error.rel_l2)} %")
    for s in result.scalar_rows[:2]:
        if math.isfinite(s.rel_error):
            parts.append(f"{s.name}: {pct(s.rel_error)} %")
    return "; ".join(parts) or "-"


def write_index(entries: Sequence[IndexEntry], out: Path, settings: dict[str, Any]) -> Path:
    out.mkdir(parents=True, exist_ok=True)
    lines = ["# Validation report", "",
             f"Generated {_dt.datetime.now().isoformat(timespec='seconds')} by compare "
             f"{__version__}.", ""]
    failed = [e.name for e in entries if e.failed]
    check_failed = [e.name for e in entries if e.checks_failed]
    tally = exp.Tally()
    for e in entries:
        tally.add(e.checks)
    lines.append(f"**{len(entries)} benchmarks, {len(failed)} with a failed run**"
                 + (f": {', '.join(failed)}" if failed else "") + "; "
                 f"**checks (expected.json): {tally.text()}**"
                 + (f"; failed checks in {', '.join(check_failed)}" if check_failed else "")
                 + ".")
    lines.append("")
    rows = []
    for e in entries:
        link = f"[report]({os.path.relpath(e.report, out)})" if e.report else "-"
        rows.append([e.name, e.iqmpm, e.openfoam, checks_cell(e.checks), e.headline, link,
                     e.generated or "-"])
    lines += _table(["benchmark", "IQ-MPM", "OpenFOAM", "checks", "key errors (rel. L2 / rel.)",
                     "report", "generated"], rows)
    failing = [c for e in entries for c in e.checks if c.result == exp.FAIL]
    if failing:
        lines += ["", "### Failed checks", ""]
        lines += _table(["benchmark"] + exp.CHECK_HEADER, exp.markdown_rows(failing, True))
    lines += ["", "## Settings", ""]
    lines += _table(["setting", "value"], [[k, f"`{v}`"] for k, v in settings.items()])
    lines += ["", "## Software versions", ""]
    lines += _table(["software", "version"], [[k, v] for k, v in software_versions().items()])
    path = out / "index.md"
    path.write_text("\n".join(lines) + "\n")
    return path
