"""Command line: ``compare/compare <subcommand> ...`` (see compare/README.md)."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import Sequence

from compare import __version__
from compare.io import REPO_ROOT, CompareError, Run, default_data_dir, read_run


def _levels(text: str) -> list[int]:
    try:
        levels = sorted({int(x) for x in text.split(",") if x.strip()})
    except ValueError:
        raise argparse.ArgumentTypeError(f"--levels wants integers like 1,2,3, not '{text}'")
    if not levels or levels[0] < 0:
        raise argparse.ArgumentTypeError("--levels: levels start at 0 (IQ-MPM only) or 1")
    return levels


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--data-dir", type=Path, default=None,
                   help="reference data folder (default $IQMPM_DATA_DIR or <repo>/data)")
    p.add_argument("--fluid-material", type=int, default=0,
                   help="material id of fluid particles in frames (default 0)")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="compare", description="IQ-MPM validation: errors against references and "
                                    "interFoam, convergence, cost, reports.")
    parser.add_argument("--version", action="version", version=f"compare {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    v = sub.add_parser("validate", help="run all benchmarks (IQ-MPM + OpenFOAM), compare, report")
    v.add_argument("--benchmark", action="append", default=[], metavar="NAME",
                   help="scene stem or folder name (repeatable; default: all)")
    v.add_argument("--levels", type=_levels, default=[1],
                   help="e.g. 1,2,3 (default 1); level 0 (IQ-MPM only): twice level 1's dx")
    v.add_argument("--out", type=Path, default=REPO_ROOT / "report", help="report folder")
    v.add_argument("--jobs", type=int, default=None,
                   help="child runs at a time (default: the number of cores)")
    v.add_argument("--threads", type=int, default=None,
                   help="IQ-MPM --threads per run (default: cores / jobs)")
    v.add_argument("--foam-np", type=int, default=1, help="OpenFOAM processes per run")
    v.add_argument("--foam-end-time", type=float, default=None, help="OpenFOAM --end-time")
    v.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="extra --set for every IQ-MPM run")
    v.add_argument("--solver", type=Path, default=None,
                   help="IQ-MPM binary (default $IQMPM_BIN or <repo>/build/iqmpm)")
    v.add_argument("--repo", type=Path, default=REPO_ROOT, help="repository root")
    v.add_argument("--runs-dir", type=Path, default=None,
                   help="IQ-MPM run folders (default <repo>/out/validate)")
    v.add_argument("--foam-runs-dir", type=Path, default=None,
                   help="OpenFOAM run cache (default <repo>/foam_runs)")
    v.add_argument("--timeout", type=float, default=900.0, help="seconds per child run (a long benchmark's registered minimum still applies: floating_block_3d_fine 4 h)")
    v.add_argument("--reuse", action="store_true",
                   help="reuse IQ-MPM runs whose binary, scene and options are unchanged")
    v.add_argument("--no-foam-cache", action="store_true", help="always rerun OpenFOAM")
    v.add_argument("--progress-interval", type=float, default=10.0,
                   help="seconds between progress lines while a child runs")
    v.add_argument("--full", action="store_true",
                   help="the full suite: every benchmark and every OpenFOAM reference (default "
                        "without --benchmark: the quick suite)")
    v.add_argument("--page", type=Path, default=None, metavar="PATH",
                   help="also write the validation page here (e.g. docs/validation.md); "
                        "OUT/validation.md is always written")
    _common(v)

    d = sub.add_parser("docs", help="write the validation page (docs/validation.md) from the "
                                    "latest reports and every expected.json")
    d.add_argument("--out", type=Path, default=REPO_ROOT / "report",
                   help="report folder to read (OUT/*/entry.json)")
    d.add_argument("--page", type=Path, default=REPO_ROOT / "docs" / "validation.md",
                   help="the page to write (default <repo>/docs/validation.md)")
    d.add_argument("--repo", type=Path, default=REPO_ROOT, help="repository root")

    e = sub.add_parser("expected", help="check every benchmarks/*/expected.json and print its checks")
    e.add_argument("--repo", type=Path, default=REPO_ROOT, help="repository root")

    fr = sub.add_parser("foam-reference",
                        help="run (or reuse) an OpenFOAM case and ship a few of its metric "
                             "columns as a reference run folder in the repository")
    fr.add_argument("case", help="OpenFOAM case (foam_cases/<case>)")
    fr.add_argument("--level", type=int, required=True)
    fr.add_argument("--column", action="append", required=True, metavar="NAME",
                    help="metric column to keep (repeatable)")
    fr.add_argument("--out", type=Path, required=True,
                    help="reference run folder to write (metrics.csv + summary.json)")
    fr.add_argument("--foam-runs-dir", type=Path, default=None,
                    help="OpenFOAM run cache (default <repo>/foam_runs)")
    fr.add_argument("--repo", type=Path, default=REPO_ROOT, help="repository root")
    fr.add_argument("--timeout", type=float, default=3600.0, help="seconds for the OpenFOAM run")

    s = sub.add_parser("series", help="errors of metric series of one run against another")
    s.add_argument("ours", type=Path, help="run folder or metrics.csv")
    s.add_argument("reference", type=Path, help="run folder or metrics.csv")
    s.add_argument("--metric", action="append", default=[],
                   help="column (repeatable; default: all common columns)")

    f = sub.add_parser("fields", help="pressure line / free surface: particles vs interFoam cells")
    f.add_argument("ours", type=Path, help="IQ-MPM run folder (frames/)")
    f.add_argument("foam", type=Path, nargs="?", help="OpenFOAM run folder (VTK/)")
    f.add_argument("--time", type=float, action="append", required=True, help="s (repeatable)")
    f.add_argument("--kind", choices=("pressure_line", "free_surface"), default="pressure_line")
    f.add_argument("--x", type=float, default=None, help="x of the vertical line (m)")
    f.add_argument("--hydrostatic-depth", type=float, default=None,
                   help="also compare with rho g (H - y) for this H (m)")
    f.add_argument("--dim", type=int, default=2)
    f.add_argument("--cell", type=float, default=None,
                   help="free surface: occupancy grid cell (m); default: the run's dx from "
                        "summary.json, else two particle spacings")
    f.add_argument("--plot-dir", type=Path, default=None, help="write PNG plots here")
    _common(f)

    for name, help_text in (("convergence", "observed orders over levels"),
                            ("cost", "error against wall time, ratio at matched error"),
                            ("report", "report of one benchmark from existing run folders")):
        c = sub.add_parser(name, help=help_text)
        c.add_argument("--benchmark", required=True, help="registry name (scene stem)")
        c.add_argument("--ours", type=Path, action="append", default=[], metavar="RUN",
                       help="IQ-MPM run folder (repeatable, one per level)")
        c.add_argument("--foam", type=Path, action="append", default=[], metavar="RUN",
                       help="OpenFOAM run folder (repeatable, one per level)")
        c.add_argument("--out", type=Path, default=REPO_ROOT / "report",
                       help="report folder (plots and report.md go to OUT/<benchmark>/)")
        _common(c)

    r = sub.add_parser("registry", help="print the benchmark -> metrics -> references table")
    r.add_argument("--markdown", action="store_true", help="(default) Markdown table")
    i = sub.add_parser("index", help="rebuild OUT/index.md from OUT/*/entry.json")
    i.add_argument("--out", type=Path, default=REPO_ROOT / "report")

    from compare import stress
    stress.add_parser(sub)  # compare stress: the stability map (compare/stress.py)
    return parser


# --------------------------------------------------------------------------- commands


def _data_dir(args: argparse.Namespace) -> Path:
    return args.data_dir if args.data_dir is not None else default_data_dir()


def _cmd_validate(args: argparse.Namespace) -> int:
    from compare.validate import Settings, cpu_count, validate

    repo = args.repo.resolve()
    solver = args.solver or Path(os.environ.get("IQMPM_BIN", repo / "build" / "iqmpm"))
    jobs = max(1, args.jobs if args.jobs is not None else cpu_count())
    settings = Settings(
        repo=repo, out=args.out.resolve(),
        runs_dir=(args.runs_dir or repo / "out" / "validate").resolve(),
        foam_runs_dir=(args.foam_runs_dir or repo / "foam_runs").resolve(),
        data_dir=_data_dir(args), solver_bin=Path(solver).resolve(), levels=args.levels,
        jobs=jobs, threads=args.threads or max(1, cpu_count() // jobs), foam_np=args.foam_np,
        foam_end_time=args.foam_end_time, sets=args.set, timeout=args.timeout,
        reuse_solver=args.reuse, foam_cache=not args.no_foam_cache,
        progress_interval=args.progress_interval, fluid_material=args.fluid_material,
        benchmarks=args.benchmark, full=args.full,
        page=args.page.resolve() if args.page is not None else None)
    return validate(settings)


def _cmd_docs(args: argparse.Namespace) -> int:
    from compare.page import write_validation_page

    if not args.out.is_dir():
        raise CompareError(f"{args.out}: no report folder (run compare validate first)")
    print(write_validation_page(args.out, args.page, args.repo.resolve()))
    return 0


def _cmd_expected(args: argparse.Namespace) -> int:
    from compare import expected as exp

    checks = exp.load_all(args.repo.resolve())
    if not checks:
        raise CompareError(f"no {args.repo}/benchmarks/*/{exp.EXPECTED_FILE}")
    print("| benchmark | metric | value | margin | source |")
    print("|---|---|---|---|---|")
    for name, items in checks.items():
        for c in items:
            margin = "-" if c.kind == "status" else (
                "none (information)" if c.margin is None else f"{c.margin.kind} {c.margin.text()}")
            print(f"| {name} | {c.metric} | {c.value} | {margin} | {c.source} |")
    return 0


def _cmd_foam_reference(args: argparse.Namespace) -> int:
    from compare.validate import ship_foam_reference

    repo = args.repo.resolve()
    print(ship_foam_reference(repo, args.case, args.level, args.column, args.out.resolve(),
                              (args.foam_runs_dir or repo / "foam_runs").resolve(),
                              args.timeout))
    return 0


def _metrics_of(path: Path):
    from compare.io import read_metrics

    return read_metrics(path)


def _cmd_series(args: argparse.Namespace) -> int:
    from compare.errors import Series, series_error
    from compare.report import fmt, pct

    ours, ref = _metrics_of(args.ours), _metrics_of(args.reference)
    names = args.metric or [c for c in ours.names() if c in ref.columns]
    if not names:
        raise CompareError(f"{ours.path} and {ref.path} have no metric column in common")
    print("| metric | window (s) | points | rel. L2 (%) | RMS | peak | peak (ref) | "
          "peak error (%) | peak time error (s) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name in names:
        e = series_error(Series.of(ours.t, ours.column(name), str(ours.path)),
                         Series.of(ref.t, ref.column(name), str(ref.path)))
        print(f"| {name} | [{fmt(e.window[0])}, {fmt(e.window[1])}] | {e.n_points} | "
              f"{pct(e.rel_l2)} | {fmt(e.rms)} | {fmt(e.peak_ours)} | {fmt(e.peak_ref)} | "
              f"{pct(e.peak_rel_error)} | {fmt(e.peak_time_error)} |")
    return 0


def _cmd_fields(args: argparse.Namespace) -> int:
    from compare import fields as fld
    from compare import plots
    from compare.io import cell_field_at, particle_frame_at
    from compare.report import fmt, pct

    if args.kind == "pressure_line" and args.x is None:
        raise CompareError("fields --kind pressure_line needs --x")
    if args.foam is None and args.hydrostatic_depth is None:
        raise CompareError("fields: give an OpenFOAM run folder or --hydrostatic-depth")
    print("| field | t (s) | against | rel. L2 (%) | max abs. difference |")
    print("|---|---|---|---|---|")
    for t in args.time:
        frame = particle_frame_at(args.ours, t)
        if args.kind == "pressure_line":
            mine = fld.particle_pressure_line(frame, args.x, args.fluid_material, args.dim)
            unit = "Pa"
        else:
            mine = fld.particle_free_surface(frame, args.fluid_material, args.dim,
                                             cell=args.cell if args.cell else _run_dx(args.ours))
            unit = "m"
        refs = []
        if args.hydrostatic_depth is not None:
            refs.append(fld.hydrostatic_profile(mine.s, args.hydrostatic_depth))
        if args.foam is not None:
            cells = cell_field_at(args.foam, t)
            refs.append(fld.cell_pressure_line(cells, args.x) if args.kind == "pressure_line"
                        else fld.cell_free_surface(cells))
        curves = [plots.Curve(mine.s, mine.v, f"IQ-MPM t = {frame.time:g} s", "o-")]
        for ref in refs:
            e = fld.compare_profiles(mine, ref)
            print(f"| {args.kind} | {fmt(frame.time)} | {ref.label} | {pct(e.rel_l2)} | "
                  f"{fmt(e.max_abs)} {unit} |")
            curves.append(plots.Curve(ref.s, ref.v, ref.label))
        if args.plot_dir is not None:
            xl, yl = (("y (m)", "p (Pa)") if args.kind == "pressure_line"
                      else ("x (m)", "surface elevation (m)"))
            path = plots.line_plot(args.plot_dir / f"{args.kind}_t{t:g}.png", curves,
                                   f"{args.kind}, t = {frame.time:g} s", xl, yl)
            print(f"plot: {path}")
    return 0


def _run_dx(path: Path) -> float | None:
    """The run's dx from its summary.json, when it has one."""
    try:
        return read_run(path, "iqmpm", need_metrics=False).dx
    except CompareError:
        return None


def _load_runs(paths: Sequence[Path], solver: str) -> list[Run]:
    return [read_run(p, solver) for p in paths]


def _analyse(args: argparse.Namespace):
    from compare.analysis import Options, analyse
    from compare.registry import lookup

    if not args.ours:
        raise CompareError(f"{args.command}: give at least one --ours RUN")
    bench = lookup(args.benchmark)
    ours = _load_runs(args.ours, "iqmpm")
    foam = _load_runs(args.foam, "interFoam")
    if bench.generic:
        # A scene of the user's own gets a generic report under its scene's name; any
        # other unregistered name is a typo, not a benchmark.
        scenes = sorted({str(r.summary.get("scene_name", "")) for r in ours} - {""})
        if args.benchmark not in scenes:
            from compare.registry import REGISTRY
            raise CompareError(
                f"--benchmark {args.benchmark!r}: not a registered benchmark and not the scene of the runs given "
                f"({', '.join(scenes) or 'none named'}); registered: {', '.join(sorted(REGISTRY))}")
    out_dir = args.out / bench.name
    _require_reference_data(bench, _data_dir(args))
    result = analyse(bench, ours, foam, out_dir, Options(_data_dir(args), args.fluid_material))
    return result, out_dir


def _require_reference_data(bench, data_dir: Path) -> None:
    """A report without the data its benchmark compares against would drop those comparisons
    silently: a missing reference file is bad input (exit 2) naming the file and the folder."""
    from compare.registry import CsvReference

    missing = sorted({ref.file for spec in bench.metrics for ref in spec.references
                      if isinstance(ref, CsvReference) and not (Path(data_dir) / ref.file).is_file()})
    if missing:
        raise CompareError(f"reference data missing in {data_dir} (--data-dir, $IQMPM_DATA_DIR, else <repo>/data): "
                           f"{', '.join(missing)}; the repository's data/ folder has them (data/README.md)")


def _cmd_convergence(args: argparse.Namespace) -> int:
    from compare.report import fmt

    result, _ = _analyse(args)
    if not result.convergence:
        raise CompareError("convergence: need successful runs at two or more levels")
    print("| solver | quantity | against | levels | h/h_coarsest | errors | order | note |")
    print("|---|---|---|---|---|---|---|---|")
    for c in result.convergence:
        print(f"| {c.solver} | {c.quantity} | {c.against} | {','.join(map(str, c.levels))} | "
              f"{', '.join(fmt(h, 3) for h in c.h)} | {', '.join(fmt(e, 3) for e in c.errors)} | "
              f"{fmt(c.order, 3)} | {c.note or '-'} |")
    return 0


def _cmd_cost(args: argparse.Namespace) -> int:
    from compare.report import fmt, pct

    result, out_dir = _analyse(args)
    if result.cost is None:
        raise CompareError("cost: no error measure available: " + "; ".join(result.notes))
    c = result.cost
    print(f"error measure: {c.measure}")
    for p in c.points:
        print(f"  {p.solver:9s} level {p.level}: wall time {fmt(p.wall_time)} s, "
              f"error {pct(p.error)} %")
    for err, t_ours, t_foam in c.ratios:
        print(f"  matched error {pct(err)} %: IQ-MPM {fmt(t_ours)} s, interFoam {fmt(t_foam)} s,"
              f" ratio interFoam/IQ-MPM {fmt(t_foam / t_ours, 3)}")
    for b in c.bounds:
        ratio = b.ratio if b.fast.solver == "IQ-MPM" else 1 / b.ratio
        print(f"  no matched error: {b.fast.solver} L{b.fast.level} ({pct(b.fast.error)} %) has no larger error "
              f"than {b.slow.solver} L{b.slow.level} ({pct(b.slow.error)} %): ratio interFoam/IQ-MPM "
              f"{'>=' if b.fast.solver == 'IQ-MPM' else '<='} {fmt(ratio, 3)}")
    if c.note:
        print(f"  {c.note}")
    print(f"plot: {out_dir / 'cost.png'}")
    return 0


def _cmd_report(args: argparse.Namespace) -> int:
    from compare import report

    from compare import expected as exp

    result, out_dir = _analyse(args)
    checks = exp.load_all(REPO_ROOT).get(result.benchmark.name, [])
    result.checks = exp.evaluate(result.benchmark, checks, result.ours, result.foam,
                                 _data_dir(args))
    path = report.write_report(result, out_dir)
    failed = any(not r.ok for r in result.ours + result.foam)
    status = lambda runs: "; ".join(f"{r.label} {r.status}" for r in runs) or "none"  # noqa: E731
    report.write_entry(report.IndexEntry(result.benchmark.name, status(result.ours),
                                         status(result.foam) if result.foam else "not given",
                                         report.headline(result), path, failed,
                                         checks=result.checks, title=result.benchmark.title),
                       out_dir)
    index = report.write_index(report.read_entries(args.out), args.out, {"command": "report"})
    print(f"report: {path}\nindex: {index}")
    if result.checks:
        print(f"checks (expected.json): {exp.Tally().add(result.checks).text()}")
    return 1 if failed or any(c.result == exp.FAIL for c in result.checks) else 0


def _cmd_registry(args: argparse.Namespace) -> int:
    from compare.registry import registry_markdown

    print(registry_markdown())
    return 0


def _cmd_index(args: argparse.Namespace) -> int:
    from compare import report

    entries = report.read_entries(args.out)
    if not entries:
        raise CompareError(f"{args.out}: no */entry.json (run validate or report first)")
    print(report.write_index(entries, args.out, {"command": "index"}))
    return 1 if any(e.failed for e in entries) else 0


def _cmd_stress(args: argparse.Namespace) -> int:
    from compare.stress import command

    return command(args)


COMMANDS = {"validate": _cmd_validate, "series": _cmd_series, "fields": _cmd_fields,
            "convergence": _cmd_convergence, "cost": _cmd_cost, "report": _cmd_report,
            "registry": _cmd_registry, "index": _cmd_index, "docs": _cmd_docs,
            "expected": _cmd_expected, "foam-reference": _cmd_foam_reference,
            "stress": _cmd_stress}


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return COMMANDS[args.command](args)
    except CompareError as exc:
        print(f"compare: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("compare: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
