"""Reading run folders (IQ-MPM and OpenFOAM), reference CSVs and field files.

Every reader raises :class:`CompareError` with a message naming the file (and the column
or field) on bad input; the CLI prints that message without a traceback.
"""

from __future__ import annotations

import csv
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable

import numpy as np

REPO_ROOT = Path(__file__).resolve().parent.parent


class CompareError(Exception):
    """An input problem the user can fix (missing file or column, bad value)."""


DATA_DIR = REPO_ROOT / "data"  # the experimental reference data, shipped with the repository


def default_data_dir(repo_root: Path = REPO_ROOT) -> Path:
    """Reference-data folder: ``$IQMPM_DATA_DIR`` or ``<repo>/data`` (found from this
    package's own path, so a clone needs nothing beside it)."""
    env = os.environ.get("IQMPM_DATA_DIR")
    if env:
        return Path(env)
    return repo_root / "data"


# --------------------------------------------------------------------------- CSV tables


@dataclass
class Table:
    """Columns of a CSV file as strings; ``#`` lines kept as ``comments``."""

    path: Path
    header: list[str]
    rows: list[list[str]]
    comments: list[str] = field(default_factory=list)

    def has(self, name: str) -> bool:
        return name in self.header

    def _index(self, name: str) -> int:
        if name not in self.header:
            raise CompareError(
                f"{self.path}: missing column '{name}' (columns: {', '.join(self.header)})"
            )
        return self.header.index(name)

    def strings(self, name: str) -> list[str]:
        i = self._index(name)
        return [row[i] if i < len(row) else "" for row in self.rows]

    def numbers(self, name: str) -> np.ndarray:
        """Column ``name`` as floats; empty cells become NaN."""
        i = self._index(name)
        out = np.empty(len(self.rows))
        for k, row in enumerate(self.rows):
            text = row[i].strip() if i < len(row) else ""
            if text == "":
                out[k] = math.nan
                continue
            try:
                out[k] = float(text)
            except ValueError:
                raise CompareError(
                    f"{self.path}: column '{name}', data row {k + 1}: '{text}' is not a number"
                ) from None
        return out

    def filtered(self, where: Iterable[tuple[str, str]]) -> "Table":
        """Rows whose columns equal the given values (numerically when both are numbers)."""
        rows = self.rows
        for name, value in where:
            i = self._index(name)
            rows = [r for r in rows if i < len(r) and _cell_equal(r[i], value)]
        return Table(self.path, self.header, rows, self.comments)


def _cell_equal(cell: str, value: str) -> bool:
    cell = cell.strip()
    if cell == value:
        return True
    try:
        return math.isclose(float(cell), float(value), rel_tol=1e-12)
    except ValueError:
        return False


def read_table(path: Path) -> Table:
    """Read a CSV with optional leading ``#`` comment lines and one header row."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise CompareError(f"cannot read {path}: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise CompareError(f"cannot read {path}: not a text file") from None
    comments: list[str] = []
    data_lines: list[str] = []
    for line in text.splitlines():
        stripped = line.strip()
        if not stripped:
            continue
        if stripped.startswith("#"):
            comments.append(stripped.lstrip("#").strip())
        else:
            data_lines.append(line)
    if not data_lines:
        raise CompareError(f"{path}: no header row (empty CSV)")
    reader = csv.reader(data_lines)
    header = [h.strip() for h in next(reader)]
    rows = [row for row in reader]
    return Table(path, header, rows, comments)


# --------------------------------------------------------------------------- metrics.csv


@dataclass
class Metrics:
    """``metrics.csv``: time column ``t`` (s) and one column per metric (SI units)."""

    path: Path
    t: np.ndarray
    columns: dict[str, np.ndarray]

    def names(self) -> list[str]:
        return list(self.columns)

    def column(self, name: str) -> np.ndarray:
        if name not in self.columns:
            raise CompareError(
                f"{self.path}: missing column '{name}' (columns: t, {', '.join(self.columns)})"
            )
        return self.columns[name]


def read_metrics(path: Path) -> Metrics:
    """Read ``metrics.csv`` (or the one inside a run folder)."""
    path = Path(path)
    if path.is_dir():
        path = path / "metrics.csv"
    table = read_table(path)
    if not table.has("t"):
        raise CompareError(
            f"{path}: missing column 't' (columns: {', '.join(table.header) or 'none'})"
        )
    t = table.numbers("t")
    columns = {name: table.numbers(name) for name in table.header if name != "t" and name}
    order = np.argsort(t, kind="stable")
    if np.any(np.diff(t) < 0):
        t = t[order]
        columns = {k: v[order] for k, v in columns.items()}
    return Metrics(path, t, columns)


# --------------------------------------------------------------------------- summary.json


def read_json_object(path: Path, what: str = "a JSON object at top level") -> dict[str, Any]:
    """A JSON file whose top level is an object; CompareError names the file otherwise."""
    try:
        data = json.loads(Path(path).read_text())
    except OSError as exc:
        raise CompareError(f"cannot read {path}: {exc.strerror or exc}") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise CompareError(f"{path}: not valid JSON ({exc})") from None
    if not isinstance(data, dict):
        raise CompareError(f"{path}: expected {what}")
    return data


def read_summary(path: Path) -> dict[str, Any]:
    """Read ``summary.json`` (or the one inside a run folder)."""
    path = Path(path)
    if path.is_dir():
        path = path / "summary.json"
    return read_json_object(path)


def summary_ok(summary: dict[str, Any]) -> bool:
    return str(summary.get("status", "")).strip().lower() == "ok"


# --------------------------------------------------------------------------- run folders


@dataclass
class Run:
    """One solver run folder: summary, metrics and (optional) run record."""

    path: Path
    solver: str  # "iqmpm" or "interFoam"
    summary: dict[str, Any]
    metrics: Metrics | None
    record: dict[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return summary_ok(self.summary)

    @property
    def status(self) -> str:
        return str(self.summary.get("status", "missing status"))

    @property
    def wall_time(self) -> float:
        value = self.summary.get("wall_time_s", self.record.get("elapsed_s"))
        return float(value) if value is not None else math.nan

    @property
    def level(self) -> int | None:
        for source in (self.record, self.summary):
            if "level" in source:
                try:
                    return int(source["level"])
                except (TypeError, ValueError):
                    pass
        return None

    @property
    def dx(self) -> float | None:
        for source in (self.summary, self.record):
            if source.get("dx") is not None:
                try:
                    return float(source["dx"])
                except (TypeError, ValueError):
                    pass
        return None

    @property
    def label(self) -> str:
        name = "IQ-MPM" if self.solver == "iqmpm" else "interFoam"
        if self.level is not None:
            return f"{name} L{self.level}"
        return name


RUN_RECORD = "compare_run.json"


def read_run(path: Path, solver: str, need_metrics: bool = True) -> Run:
    """Read a run folder. A failed run (status not "ok") is returned without metrics."""
    path = Path(path)
    if not path.is_dir():
        raise CompareError(f"run folder {path} does not exist")
    summary = read_summary(path / "summary.json")
    record: dict[str, Any] = {}
    if (path / RUN_RECORD).is_file():
        try:
            record = json.loads((path / RUN_RECORD).read_text())
        except (OSError, json.JSONDecodeError):
            record = {}
    metrics = None
    if summary_ok(summary) and (need_metrics or (path / "metrics.csv").exists()):
        metrics = read_metrics(path / "metrics.csv")
    return Run(path, solver, summary, metrics, record)


# --------------------------------------------------------------------------- particle frames


@dataclass
class ParticleFrame:
    path: Path
    time: float
    points: np.ndarray  # (N, 3)
    pressure: np.ndarray  # (N,)
    velocity: np.ndarray  # (N, 3)
    material: np.ndarray  # (N,)


def read_frame_times(run_dir: Path) -> list[tuple[int, float]]:
    """``frames/times.csv`` as (frame, t) pairs."""
    table = read_table(Path(run_dir) / "frames" / "times.csv")
    frames = table.numbers("frame")
    times = table.numbers("t")
    return [(int(f), float(t)) for f, t in zip(frames, times)]


def _as3(points: np.ndarray) -> np.ndarray:
    points = np.asarray(points, dtype=float)
    if points.ndim == 1:
        points = points[:, None]
    if points.shape[1] < 3:
        points = np.hstack([points, np.zeros((points.shape[0], 3 - points.shape[1]))])
    return points


def _meshio_read(path: Path, what: str) -> Any:
    """meshio.read with its failures (exceptions, and sys.exit on unknown formats) as
    CompareError; meshio's own printing is silenced."""
    import contextlib
    import io as _io

    import meshio

    sink = _io.StringIO()
    try:
        with contextlib.redirect_stdout(sink), contextlib.redirect_stderr(sink):
            return meshio.read(str(path))
    except (Exception, SystemExit) as exc:  # meshio raises many types, or exits
        detail = str(exc) if not isinstance(exc, SystemExit) else ""
        detail = detail or sink.getvalue().strip().replace("\n", " ") or type(exc).__name__
        hint = ""
        if str(path).endswith(".xdmf"):
            hint = (" (meshio's XDMF reader needs one Uniform Grid per file, a Topology with a "
                    "DataItem of point indices, Geometry XY or XYZ)")
        raise CompareError(f"cannot read {what} {path}: {detail}{hint}") from None


def read_particle_frame(path: Path, time: float = math.nan) -> ParticleFrame:
    """Read one particle frame (XDMF + HDF5) with meshio."""

    path = Path(path)
    if not path.is_file():
        raise CompareError(f"particle frame {path} does not exist")
    mesh = _meshio_read(path, "particle frame")
    data = mesh.point_data
    for name in ("pressure", "velocity", "material"):
        if name not in data:
            raise CompareError(
                f"{path}: missing point data '{name}' (has: {', '.join(data) or 'none'})"
            )
    n = len(mesh.points)
    velocity = np.asarray(data["velocity"], dtype=float).reshape(n, -1)
    return ParticleFrame(
        path=path,
        time=time,
        points=_as3(mesh.points),
        pressure=np.asarray(data["pressure"], dtype=float).reshape(n),
        velocity=_as3(velocity),
        material=np.asarray(data["material"]).reshape(n).astype(int),
    )


def particle_frame_at(run_dir: Path, t: float) -> ParticleFrame:
    """The frame of ``run_dir`` nearest to time ``t``."""
    run_dir = Path(run_dir)
    times = read_frame_times(run_dir)
    if not times:
        raise CompareError(f"{run_dir / 'frames' / 'times.csv'}: no frames listed")
    frame, time = min(times, key=lambda ft: abs(ft[1] - t))
    return read_particle_frame(run_dir / "frames" / f"frame_{frame:05d}.xdmf", time)


# --------------------------------------------------------------------------- OpenFOAM VTK


@dataclass
class CellField:
    """interFoam cell data at one time: cell centres, extents and fields."""

    path: Path
    time: float
    centres: np.ndarray  # (M, 3)
    lower: np.ndarray  # (M, 3) bounding-box minimum per cell
    upper: np.ndarray  # (M, 3) bounding-box maximum per cell
    fields: dict[str, np.ndarray]

    def field(self, name: str) -> np.ndarray:
        if name not in self.fields:
            raise CompareError(
                f"{self.path}: missing cell field '{name}' (has: {', '.join(self.fields)})"
            )
        return self.fields[name]


def _vtk_times_from_series(vtk_dir: Path) -> dict[str, float]:
    """Map file-name stem -> time from ``*.series`` files (foamToVTK, ParaView format)."""
    out: dict[str, float] = {}
    for series in sorted(vtk_dir.glob("*.series")):
        try:
            data = json.loads(series.read_text())
        except (OSError, json.JSONDecodeError):
            continue
        for entry in data.get("files", []):
            name = str(entry.get("name", ""))
            stem = name.split("/")[0]
            for suffix in (".vtm", ".vtu", ".vtk"):
                if stem.endswith(suffix):
                    stem = stem[: -len(suffix)]
            out[stem] = float(entry.get("time", math.nan))
    return out


def list_vtk_times(vtk_dir: Path) -> list[tuple[float, Path]]:
    """(time, internal-mesh file) pairs of a foamToVTK folder.

    Layouts understood: ``VTK/<name>.vtu`` (flat, as foam_cases/run writes),
    ``VTK/<case>_<i>/internal.vtu`` (or ``.vtk``) and ``VTK/<case>_<i>.vtk``. Times come from
    ``vtk_files`` ({file name: time}) in the run's ``summary.json``, else ``VTK/*.series``,
    else ``VTK/times.csv`` (columns ``name``, ``t``), else the files' ``TimeValue`` field data.
    """
    vtk_dir = Path(vtk_dir)
    if not vtk_dir.is_dir():
        raise CompareError(f"OpenFOAM VTK folder {vtk_dir} does not exist")
    files: dict[str, Path] = {}
    for sub in sorted(p for p in vtk_dir.iterdir() if p.is_dir()):
        for name in ("internal.vtu", "internal.vtk"):
            if (sub / name).is_file():
                files[sub.name] = sub / name
                break
    for flat in sorted(list(vtk_dir.glob("*.vtu")) + list(vtk_dir.glob("*.vtk"))):
        files.setdefault(flat.stem, flat)
    times: dict[str, float] = {}
    summary_path = vtk_dir.parent / "summary.json"
    if summary_path.is_file():
        try:
            listed = json.loads(summary_path.read_text()).get("vtk_files", {})
        except (OSError, json.JSONDecodeError, AttributeError):
            listed = {}
        if isinstance(listed, dict):
            for name, t in listed.items():
                times[Path(str(name)).stem] = float(t)
    for stem, t in _vtk_times_from_series(vtk_dir).items():
        times.setdefault(stem, t)
    if (vtk_dir / "times.csv").is_file():
        table = read_table(vtk_dir / "times.csv")
        for name, t in zip(table.strings("name"), table.numbers("t")):
            times.setdefault(Path(name).stem if "." in name else name, float(t))
    out: list[tuple[float, Path]] = []
    for stem, path in files.items():
        t = times.get(stem)
        if t is None:
            t = _time_value_field(path)
        if t is None:
            raise CompareError(
                f"{path}: cannot tell its time (not in summary.json vtk_files, no VTK/*.series, "
                f"no VTK/times.csv, no TimeValue field data)"
            )
        out.append((t, path))
    if not out:
        raise CompareError(f"{vtk_dir}: no foamToVTK internal-mesh files found")
    return sorted(out)


def _time_value_field(path: Path) -> float | None:
    try:
        mesh = _meshio_read(path, "VTK file")
    except CompareError:
        return None
    for key in ("TimeValue", "TIME", "time"):
        if key in mesh.field_data:
            return float(np.ravel(mesh.field_data[key])[0])
    return None


def read_cell_field(path: Path, time: float = math.nan) -> CellField:
    """Read an unstructured VTK file with cell data via meshio."""
    path = Path(path)
    mesh = _meshio_read(path, "OpenFOAM VTK file")
    points = _as3(mesh.points)
    centres, lower, upper = [], [], []
    for block in mesh.cells:
        conn = np.asarray(block.data)
        if conn.ndim != 2 or block.type in ("vertex", "line"):
            continue
        cell_points = points[conn]  # (n, k, 3)
        centres.append(cell_points.mean(axis=1))
        lower.append(cell_points.min(axis=1))
        upper.append(cell_points.max(axis=1))
    if not centres:
        raise CompareError(f"{path}: no volume or face cells")
    fields: dict[str, np.ndarray] = {}
    for name, blocks in mesh.cell_data.items():
        kept = [
            np.asarray(b)
            for b, block in zip(blocks, mesh.cells)
            if np.asarray(block.data).ndim == 2 and block.type not in ("vertex", "line")
        ]
        if not kept:
            continue
        if all(k.ndim == 1 for k in kept):
            fields[name] = np.concatenate(kept).astype(float)
        else:
            fields[name] = np.concatenate([k.reshape(len(k), -1) for k in kept]).astype(float)
    return CellField(
        path=path,
        time=time,
        centres=np.concatenate(centres),
        lower=np.concatenate(lower),
        upper=np.concatenate(upper),
        fields=fields,
    )


def cell_field_at(foam_run: Path, t: float) -> CellField:
    """The foamToVTK output of ``foam_run`` nearest to time ``t``."""
    entries = list_vtk_times(Path(foam_run) / "VTK")
    time, path = min(entries, key=lambda e: abs(e[0] - t))
    return read_cell_field(path, time)
