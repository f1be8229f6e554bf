"""Comparison of one benchmark: our runs (by level) against references and interFoam.

Produces a :class:`BenchmarkResult` (tables, convergence, cost, plots) that
``compare.report`` renders. Plots are written into the benchmark's report folder.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from compare import fields as fld
from compare import plots
from compare.convergence import observed_order, richardson
from compare.errors import (Series, SeriesError, constant_series, interval_means, peak,
                            relative_error, series_error)
from compare.io import CompareError, Run, cell_field_at, particle_frame_at
from compare.reducers import scalar_value_u
from compare.registry import (Benchmark, ConstantReference, CsvReference, MetricSpec,
                              Reference, ScalarSpec, generic_metrics)


# --------------------------------------------------------------------------- results


@dataclass
class SeriesRow:
    metric: str
    run: str
    against: str
    unit: str  # unit of the compared values
    t_unit: str
    error: SeriesError
    absolute: bool = False  # a zero quantity (MetricSpec.absolute): no relative errors shown


@dataclass
class ScalarRow:
    name: str
    description: str
    run: str
    value: float
    reference: float
    against: str
    unit: str
    # expanded uncertainties (k = 2) of value and reference, NaN when the reducer has none
    uncertainty: float = math.nan
    reference_uncertainty: float = math.nan
    # |reference| at or below this counts as zero (ScalarSpec.zero_floor); `absolute`: always
    zero_floor: float = 0.0
    absolute: bool = False

    @property
    def is_absolute(self) -> bool:
        """The error is reported as an absolute one (the reference is zero or noise)."""
        return self.absolute or abs(self.reference) <= self.zero_floor

    @property
    def rel_error(self) -> float:
        if self.is_absolute:
            return math.nan
        return relative_error(self.value, self.reference)

    @property
    def abs_error(self) -> float:
        return self.value - self.reference

    @property
    def combined_uncertainty(self) -> float:
        """sqrt(U_value^2 + U_reference^2), a missing one counted as 0; NaN when both miss."""
        parts = [u for u in (self.uncertainty, self.reference_uncertainty) if math.isfinite(u)]
        return math.sqrt(sum(u * u for u in parts)) if parts else math.nan

    @property
    def beyond_uncertainty(self) -> bool | None:
        """|value - reference| > the combined uncertainty; None when there is none."""
        u = self.combined_uncertainty
        if not math.isfinite(u) or not math.isfinite(self.abs_error):
            return None
        return abs(self.abs_error) > u


@dataclass
class FieldRow:
    kind: str
    time_ours: float
    time_ref: float
    against: str
    unit: str
    rel_l2: float
    max_abs: float


@dataclass
class ConvergenceRow:
    solver: str
    quantity: str
    against: str  # reference label, "successive levels" or "Richardson"
    levels: tuple[int, ...]
    h: tuple[float, ...]  # relative cell size h / h_L1
    errors: tuple[float, ...]
    order: float
    pairwise: tuple[float, ...] = ()
    extrapolated: float | None = None
    note: str = ""


@dataclass
class CostPoint:
    solver: str
    level: int
    wall_time: float
    error: float


@dataclass
class CostBound:
    """One solver's run at least as accurate as the other's most accurate run, and cheaper:
    the ratio at matched error is at least ``t_slow / t_fast`` when the slower solver's
    error falls with its cost (no interpolation possible: the error ranges do not overlap)."""

    fast: CostPoint
    slow: CostPoint

    @property
    def ratio(self) -> float:
        return self.slow.wall_time / self.fast.wall_time


@dataclass
class CostResult:
    measure: str  # what "error" is
    points: list[CostPoint]
    ratios: list[tuple[float, float, float]]  # (error, t_iqmpm, t_interFoam)
    note: str = ""
    bounds: list[CostBound] = field(default_factory=list)


@dataclass
class BenchmarkResult:
    benchmark: Benchmark
    ours: list[Run]
    foam: list[Run]
    series_rows: list[SeriesRow] = field(default_factory=list)
    scalar_rows: list[ScalarRow] = field(default_factory=list)
    field_rows: list[FieldRow] = field(default_factory=list)
    convergence: list[ConvergenceRow] = field(default_factory=list)
    cost: CostResult | None = None
    plots: list[tuple[str, Path]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    checks: list = field(default_factory=list)  # compare.expected.CheckResult, from expected.json


@dataclass
class Options:
    data_dir: Path
    fluid_material: int = 0


# --------------------------------------------------------------------------- references


def load_reference(ref: Reference, data_dir: Path, t_like: np.ndarray | None = None) -> Series:
    """A reference as a Series (CSV: in its own, possibly normalised, space)."""
    if isinstance(ref, ConstantReference):
        if t_like is None:
            raise CompareError(f"constant reference '{ref.key}' needs sample times")
        return constant_series(ref.value, t_like, ref.label)
    from compare.io import read_table

    table = read_table(Path(data_dir) / ref.file).filtered(ref.where)
    if not table.rows:
        raise CompareError(f"{data_dir / ref.file}: no rows match {dict(ref.where)}")
    s = Series.of(table.numbers(ref.t_column), table.numbers(ref.y_column), ref.label)
    y = s.y - s.y[0] if ref.subtract_first else s.y
    t = s.t
    if ref.max_y is not None:
        keep = y <= ref.max_y
        t, y = t[keep], y[keep]
    if ref.max_t is not None:
        keep = t <= ref.max_t + 1e-9
        t, y = t[keep], y[keep]
    return Series(t, y, ref.label)


def _ours_series(run: Run, spec: MetricSpec) -> Series:
    assert run.metrics is not None
    t = run.metrics.t
    y = run.metrics.column(spec.column)
    if spec.use_abs:
        y = np.abs(y)
    if spec.skip_initial:
        t, y = t[t > 0], y[t > 0]
    return Series.of(t, y, run.label)


# --------------------------------------------------------------------------- helpers


def ok_runs(runs: Sequence[Run]) -> list[Run]:
    return sorted((r for r in runs if r.ok and r.metrics is not None),
                  key=lambda r: (r.level if r.level is not None else 0, -(r.dx or 0)))


def relative_h(runs: Sequence[Run]) -> list[float]:
    """Cell size relative to the coarsest run: from dx when known, else 2^-(level-1)."""
    dxs = [r.dx for r in runs]
    if all(d is not None and d > 0 for d in dxs):
        return [float(d) / float(max(dxs)) for d in dxs]  # type: ignore[arg-type]
    levels = [r.level if r.level is not None else i + 1 for i, r in enumerate(runs)]
    base = min(levels)
    return [2.0 ** -(lv - base) for lv in levels]


def _slug(text: str) -> str:
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in text)


def _metric_specs(bench: Benchmark, ours: Sequence[Run], foam: Sequence[Run]) -> list[MetricSpec]:
    if not bench.generic:
        return list(bench.metrics)
    cols: list[str] = []
    for run in list(ours[:1]):
        assert run.metrics is not None
        cols = [c for c in run.metrics.names()
                if all(f.metrics is not None and c in f.metrics.columns for f in foam[:1])]
    return list(generic_metrics(cols))


# --------------------------------------------------------------------------- analysis


def analyse(bench: Benchmark, ours_runs: Sequence[Run], foam_runs: Sequence[Run],
            out_dir: Path, options: Options) -> BenchmarkResult:
    """All comparisons of ``bench``; plots go into ``out_dir``."""
    out_dir.mkdir(parents=True, exist_ok=True)
    result = BenchmarkResult(bench, list(ours_runs), list(foam_runs))
    ours = ok_runs(ours_runs)
    foam = ok_runs(foam_runs)
    if not ours:
        result.notes.append("no successful IQ-MPM run: nothing to compare")
        return result
    base, foam_base = ours[0], (foam[0] if foam else None)
    specs = _metric_specs(bench, ours, foam)
    for spec in specs:
        _series_section(result, spec, base, foam_base, ours, options, out_dir)
    for sspec in bench.scalars:  # every level: the scalars' own convergence shows in the table
        for i, run in enumerate(ours):
            _scalar_section(result, sspec, run, foam[i] if i < len(foam) else foam_base)
    for fspec in bench.fields:
        for t in fspec.times:
            _field_section(result, bench, fspec, t, base, foam_base, options, out_dir)
    _convergence_section(result, specs, ours, foam, options, out_dir)
    _cost_section(result, bench, specs, ours, foam, options, out_dir)
    return result


def _series_section(result: BenchmarkResult, spec: MetricSpec, base: Run, foam: Run | None,
                    ours: Sequence[Run], options: Options, out_dir: Path) -> None:
    assert base.metrics is not None
    if spec.column not in base.metrics.columns:
        result.notes.append(f"{base.path}/metrics.csv has no column '{spec.column}': "
                            f"not compared")
        return
    mine = _ours_series(base, spec)
    norm = spec.normalisation
    # against independent references
    if any(isinstance(r, CsvReference) and r.normalised for r in spec.references) and norm:
        curves = [plots.Curve(r_.t * norm.t_scale, r_.y * norm.y_scale, r_.label)
                  for r_ in (_ours_series(r, spec) for r in ours)]
        if foam is not None and foam.metrics is not None and spec.column in foam.metrics.columns:
            fs = _ours_series(foam, spec)
            curves.append(plots.Curve(fs.t * norm.t_scale, fs.y * norm.y_scale, foam.label, "--"))
        t_label, y_label = norm.t_label, norm.y_label
    else:
        curves = [plots.Curve(s.t, s.y, s.label) for s in (_ours_series(r, spec) for r in ours)]
        if foam is not None and foam.metrics is not None and spec.column in foam.metrics.columns:
            fs = _ours_series(foam, spec)
            curves.append(plots.Curve(fs.t, fs.y, foam.label, "--"))
        t_label, y_label = "t (s)", f"{spec.column} ({spec.unit})"
    for ref in spec.references:
        try:
            if isinstance(ref, CsvReference) and ref.normalised and norm:
                r = load_reference(ref, options.data_dir)
                err = series_error(mine.scaled(norm.t_scale, norm.y_scale), r)
                result.series_rows.append(SeriesRow(spec.column, base.label, ref.label, "-", "-", err))
                curves.append(plots.Curve(r.t, r.y, ref.label, "o"))
            else:
                r = load_reference(ref, options.data_dir, mine.t)
                err = series_error(mine, r)
                result.series_rows.append(SeriesRow(spec.column, base.label, ref.label,
                                                    spec.unit, "s", err, spec.absolute))
                if norm is not None:
                    curves.append(plots.Curve(r.t * norm.t_scale, r.y * norm.y_scale, ref.label, "o"))
                else:
                    curves.append(plots.Curve(r.t, r.y, ref.label,
                                              "-" if isinstance(ref, ConstantReference) else "o"))
        except CompareError as exc:
            result.notes.append(f"{spec.column} vs {ref.label}: {exc}")
    # against interFoam (SI units)
    if spec.against_foam and foam is not None and foam.metrics is not None:
        if spec.column in foam.metrics.columns:
            try:
                theirs = _ours_series(foam, spec)
                err = series_error(mine, theirs)
                result.series_rows.append(SeriesRow(spec.column, base.label, foam.label,
                                                    spec.unit, "s", err, spec.absolute))
                if spec.per_step:
                    err = series_error(interval_means(mine, theirs.t), theirs)
                    result.series_rows.append(SeriesRow(spec.column, f"{base.label}, interval means",
                                                        foam.label, spec.unit, "s", err, spec.absolute))
            except CompareError as exc:
                result.notes.append(f"{spec.column} vs {foam.label}: {exc}")
        else:
            result.notes.append(f"{foam.path}/metrics.csv has no column '{spec.column}'")
    path = out_dir / f"series_{_slug(spec.column)}.png"
    plots.line_plot(path, curves, f"{result.benchmark.name}: {spec.description}",
                    t_label, y_label)
    result.plots.append((f"{spec.column}: {spec.description}", path))


def _scalar_section(result: BenchmarkResult, spec: ScalarSpec, base: Run,
                    foam: Run | None) -> None:
    found = scalar_value_u(base, spec)
    if found is None:
        result.notes.append(f"scalar {spec.name}: not provided by {base.path}")
        return
    value, u = found
    rule = dict(zero_floor=spec.zero_floor, absolute=spec.absolute)
    if spec.reference is not None:
        result.scalar_rows.append(ScalarRow(spec.name, spec.description, base.label, value,
                                            spec.reference, spec.reference_label, spec.unit,
                                            u, **rule))
    elif foam is not None:
        theirs = scalar_value_u(foam, spec)
        if theirs is None or not math.isfinite(theirs[0]):
            result.notes.append(f"scalar {spec.name}: not available from {foam.label}")
        else:
            result.scalar_rows.append(ScalarRow(spec.name, spec.description, base.label, value,
                                                theirs[0], foam.label, spec.unit, u, theirs[1],
                                                **rule))
    else:
        result.scalar_rows.append(ScalarRow(spec.name, spec.description, base.label, value,
                                            math.nan, "-", spec.unit, u, **rule))


def _field_section(result: BenchmarkResult, bench: Benchmark, spec, t: float, base: Run,
                   foam: Run | None, options: Options, out_dir: Path) -> None:
    if not (base.path / "frames" / "times.csv").is_file():
        result.notes.append(f"field {spec.kind} at t = {t:g} s: {base.path} has no "
                            f"frames/times.csv")
        return
    try:
        frame = particle_frame_at(base.path, t)
        if spec.kind == "pressure_line":
            mine = fld.particle_pressure_line(frame, spec.x, options.fluid_material, bench.dim,
                                              base.label)
            unit, xlabel, ylabel = "Pa", "y (m)", "p (Pa)"
            title = f"{bench.name}: pressure along x = {spec.x:g} m, t = {frame.time:g} s"
        else:
            mine = fld.particle_free_surface(frame, options.fluid_material, bench.dim, base.label,
                                             cell=base.dx)
            unit, xlabel, ylabel = "m", "x (m)", "surface elevation (m)"
            title = f"{bench.name}: free surface, t = {frame.time:g} s"
    except CompareError as exc:
        result.notes.append(f"field {spec.kind} at t = {t:g} s: {exc}")
        return
    curves = [plots.Curve(mine.s, mine.v, f"{base.label} (t = {frame.time:g} s)", "o-")]
    refs: list[fld.Profile] = []
    if spec.hydrostatic_depth is not None:
        refs.append(fld.hydrostatic_profile(np.linspace(mine.s.min(), mine.s.max(), 50),
                                            spec.hydrostatic_depth))
        result.scalar_rows.append(ScalarRow(
            "pressure_l2_particles", "particle pressure vs rho g (H - y), all fluid particles",
            base.label, fld.hydrostatic_particle_error(frame, spec.hydrostatic_depth,
                                                       options.fluid_material),
            0.0, "0", "-"))
    if foam is not None and bench.foam_case:
        try:
            cells = cell_field_at(foam.path, t)
            if spec.kind == "pressure_line":
                refs.append(fld.cell_pressure_line(cells, spec.x, label=foam.label))
            else:
                refs.append(fld.cell_free_surface(cells, label=foam.label))
        except CompareError as exc:
            result.notes.append(f"field {spec.kind} at t = {t:g} s, {foam.label}: {exc}")
    for ref in refs:
        try:
            e = fld.compare_profiles(mine, ref)
        except CompareError as exc:
            result.notes.append(f"field {spec.kind} at t = {t:g} s: {exc}")
            continue
        result.field_rows.append(FieldRow(spec.kind + (f" x={spec.x:g} m" if spec.x else ""),
                                          frame.time, ref.time, ref.label, unit, e.rel_l2,
                                          e.max_abs))
        label = ref.label + (f" (t = {ref.time:g} s)" if math.isfinite(ref.time) else "")
        curves.append(plots.Curve(ref.s, ref.v, label, "-"))
    path = out_dir / f"field_{spec.kind}_t{t:g}.png"
    plots.line_plot(path, curves, title, xlabel, ylabel)
    result.plots.append((f"{spec.kind} at t = {t:g} s", path))


def _independent_refs(spec: MetricSpec) -> list[Reference]:
    return list(spec.references)


def _error_against(run: Run, spec: MetricSpec, ref: Reference | Run,
                   options: Options) -> float:
    """Relative L2 of ``run`` against ``ref``; the RMS difference (metric's unit) for a
    zero quantity (``spec.absolute``)."""
    mine = _ours_series(run, spec)
    if spec.absolute:
        other = (_ours_series(ref, spec) if isinstance(ref, Run)
                 else load_reference(ref, options.data_dir, mine.t))
        return series_error(mine, other).rms
    if isinstance(ref, Run):
        return series_error(mine, _ours_series(ref, spec)).rel_l2
    if isinstance(ref, CsvReference) and ref.normalised and spec.normalisation:
        n = spec.normalisation
        return series_error(mine.scaled(n.t_scale, n.y_scale),
                            load_reference(ref, options.data_dir)).rel_l2
    return series_error(mine, load_reference(ref, options.data_dir, mine.t)).rel_l2


def _convergence_section(result: BenchmarkResult, specs: Sequence[MetricSpec],
                         ours: Sequence[Run], foam: Sequence[Run], options: Options,
                         out_dir: Path) -> None:
    curves: list[plots.Curve] = []
    for solver, runs in (("IQ-MPM", ours), ("interFoam", foam)):
        if len(runs) < 2:
            continue
        h = relative_h(runs)
        levels = tuple(r.level if r.level is not None else i + 1 for i, r in enumerate(runs))
        for spec in specs:
            if not all(r.metrics is not None and spec.column in r.metrics.columns for r in runs):
                continue
            refs = _independent_refs(spec)
            for ref in refs:
                try:
                    errs = [_error_against(r, spec, ref, options) for r in runs]
                    o = observed_order(np.array(h), np.array(errs))
                    row = ConvergenceRow(solver, spec.column, ref.label, levels, tuple(h),
                                         tuple(errs), o.order, o.pairwise)
                except CompareError as exc:
                    row = ConvergenceRow(solver, spec.column, ref.label, levels, tuple(h),
                                         (), math.nan, note=str(exc))
                result.convergence.append(row)
                if row.errors:
                    curves.append(plots.Curve(np.array(h), np.array(row.errors),
                                              f"{solver} {spec.column} vs {ref.label}"))
            if refs:
                continue
            # no independent reference: successive differences and Richardson on the peak
            try:
                diffs = [_error_against(runs[i], spec, runs[i + 1], options)
                         for i in range(len(runs) - 1)]
                note = ""
                if len(diffs) >= 2:
                    o = observed_order(np.array(h[:-1]), np.array(diffs))
                    order, pairwise = o.order, o.pairwise
                else:
                    order, pairwise = math.nan, ()
                    note = "order needs 3 levels"
                result.convergence.append(ConvergenceRow(
                    solver, spec.column,
                    f"successive levels ({'RMS difference' if spec.absolute else 'rel. L2'} "
                    f"of L_i vs L_i+1)",
                    levels[:-1], tuple(h[:-1]), tuple(diffs), order, pairwise, note=note))
                curves.append(plots.Curve(np.array(h[:-1]), np.array(diffs),
                                          f"{solver} {spec.column}: successive differences"))
            except CompareError as exc:
                result.notes.append(f"convergence {solver} {spec.column}: {exc}")
            if len(runs) >= 3:
                peaks = [peak(_ours_series(r, spec))[0] for r in runs]
                try:
                    rr = richardson(np.array(h), np.array(peaks))
                    result.convergence.append(ConvergenceRow(
                        solver, f"peak {spec.column}", "Richardson", levels, tuple(h),
                        rr.errors, rr.order, extrapolated=rr.extrapolated))
                except CompareError as exc:
                    result.convergence.append(ConvergenceRow(
                        solver, f"peak {spec.column}", "Richardson", levels, tuple(h),
                        tuple(peaks), math.nan, note=str(exc)))
    if curves:
        path = out_dir / "convergence.png"
        plots.loglog_plot(path, curves, f"{result.benchmark.name}: convergence",
                          "relative cell size h / h_coarsest (-)", "relative L2 error (-)",
                          slopes=(1, 2))
        result.plots.append(("convergence", path))


def _cost_section(result: BenchmarkResult, bench: Benchmark, specs: Sequence[MetricSpec],
                  ours: Sequence[Run], foam: Sequence[Run], options: Options,
                  out_dir: Path) -> None:
    if bench.primary is None:
        spec = specs[0] if specs else None
        ref_key = "foam"
    else:
        spec = next((s for s in specs if s.column == bench.primary[0]), None)
        ref_key = bench.primary[1]
    if spec is None:
        return
    points: list[CostPoint] = []
    note = ""
    foam_eval = list(foam)
    own_finest: dict[str, Run] = {}
    if ref_key == "self":
        # Each solver against its own finest run: a stand-in for its grid-converged limit,
        # where the solvers' limits differ by more than their grid errors (dam_break's
        # front: docs/benchmarks.md).
        for solver, runs in (("IQ-MPM", ours), ("interFoam", foam)):
            if len(runs) >= 2:
                own_finest[solver] = runs[-1]
        if not own_finest:
            result.notes.append("run time vs error: needs two or more levels of a solver (--levels 1,2,3)")
            return
        ours = list(ours[:-1]) if "IQ-MPM" in own_finest else []
        foam_eval = list(foam[:-1]) if "interFoam" in own_finest else []
        reference: Reference | Run | None = None
        measure = (f"relative L2 of {spec.column} against each solver's own finest run ("
                   + ", ".join(r.label for r in own_finest.values())
                   + ", excluded from the curves): how far each is from its own limit, not from the other's")
    elif ref_key == "foam":
        if not foam:
            result.notes.append("run time vs error: no interFoam run to measure against")
            return
        reference: Reference | Run = foam[-1]
        foam_eval = list(foam[:-1])
        measure = (f"relative L2 of {spec.column} against the finest interFoam run "
                   f"({foam[-1].label}, excluded from the interFoam curve)")
    else:
        ref_obj = next((r for r in spec.references if r.key == ref_key), None)
        if ref_obj is None:
            return
        reference = ref_obj
        measure = f"relative L2 of {spec.column} against {ref_obj.label}"
    for solver, runs in (("IQ-MPM", ours), ("interFoam", foam_eval)):
        for i, r in enumerate(runs):
            if r.metrics is None or spec.column not in r.metrics.columns:
                continue
            try:
                e = _error_against(r, spec, own_finest.get(solver, reference), options)
            except CompareError as exc:
                result.notes.append(f"run time vs error, {r.label}: {exc}")
                continue
            points.append(CostPoint(solver, r.level if r.level is not None else i + 1,
                                    r.wall_time, e))
    mine = [p for p in points if p.solver == "IQ-MPM"]
    theirs = [p for p in points if p.solver == "interFoam"]
    ratios = matched_ratios(mine, theirs)
    bounds = [] if ratios else dominance_bounds(mine, theirs)
    if not ratios and not bounds:
        note = ("no matched error: the two solvers' error ranges do not overlap, or neither "
                "has two levels to interpolate between (use --levels 1,2,3)")
    result.cost = CostResult(measure, points, ratios, note, bounds)
    curves = [plots.Curve(np.array([p.wall_time for p in pts]),
                          np.array([p.error for p in pts]), name)
              for name, pts in (("IQ-MPM", mine), ("interFoam", theirs)) if pts]
    if curves:
        path = out_dir / "cost.png"
        plots.loglog_plot(path, curves, f"{bench.name}: error against run time",
                          "wall time (s)", f"relative L2 error of {spec.column} (-)")
        result.plots.append(("error against run time", path))


def time_at_error(points: Sequence[CostPoint], error: float) -> float | None:
    """Wall time at ``error`` by log-log interpolation along the curve (cheapest crossing)."""
    pts = sorted((p for p in points if p.error > 0 and p.wall_time > 0),
                 key=lambda p: p.wall_time)
    for a, b in zip(pts, pts[1:]):
        lo, hi = sorted((a.error, b.error))
        if lo <= error <= hi:
            if a.error == b.error:
                return a.wall_time
            w = (math.log(error) - math.log(a.error)) / (math.log(b.error) - math.log(a.error))
            return math.exp(math.log(a.wall_time) + w * (math.log(b.wall_time)
                                                          - math.log(a.wall_time)))
    for p in pts:
        if p.error == error:
            return p.wall_time
    return None


def dominance_bounds(mine: Sequence[CostPoint], theirs: Sequence[CostPoint]) -> list[CostBound]:
    """Where the error ranges do not overlap: the cheapest run of one solver at least as
    accurate as the other's most accurate run, if it is also cheaper than that run. Valid as
    a bound on the ratio at matched error when the slower solver's error falls with its cost
    (its cheaper runs are less accurate still)."""
    out: list[CostBound] = []
    for a, b in ((mine, theirs), (theirs, mine)):
        a = [p for p in a if p.error >= 0 and p.wall_time > 0]
        b = [p for p in b if p.error >= 0 and p.wall_time > 0]
        if not a or not b:
            continue
        best = min(b, key=lambda p: (p.error, p.wall_time))
        better = [p for p in a if p.error <= best.error and p.wall_time < best.wall_time]
        if better:
            out.append(CostBound(min(better, key=lambda p: p.wall_time), best))
    return out


def matched_ratios(mine: Sequence[CostPoint],
                   theirs: Sequence[CostPoint]) -> list[tuple[float, float, float]]:
    """(error, t_iqmpm, t_interFoam) at each point of one solver inside the other's range."""
    out: list[tuple[float, float, float]] = []
    for p in mine:
        t = time_at_error(theirs, p.error)
        if t is not None:
            out.append((p.error, p.wall_time, t))
    for p in theirs:
        t = time_at_error(mine, p.error)
        if t is not None:
            out.append((p.error, t, p.wall_time))
    unique: dict[tuple[float, float, float], tuple[float, float, float]] = {}
    for err, t1, t2 in out:  # the same match found from both sides differs only by round-off
        unique.setdefault((round(math.log(err), 9), round(math.log(t1), 9),
                           round(math.log(t2), 9)), (err, t1, t2))
    return sorted(unique.values())
