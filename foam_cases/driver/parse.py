"""Readers for OpenFOAM postProcessing output and solver logs."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np


def _time_dirs(fo_dir: Path) -> list[Path]:
    dirs = []
    for d in fo_dir.iterdir():
        try:
            float(d.name)
        except ValueError:
            continue
        if d.is_dir():
            dirs.append(d)
    return sorted(dirs, key=lambda d: float(d.name))


def read_dat(path: Path) -> tuple[list[str], np.ndarray]:
    """A function-object .dat (or probe) file: header words and numeric rows.

    Parentheses of vector entries are dropped, so a vector becomes three columns.
    Rows of several restarts (time folders) are concatenated by the caller.
    """
    header: list[str] = []
    rows: list[list[float]] = []
    for line in path.read_text(errors="replace").splitlines():
        if line.startswith("#"):
            header = line[1:].split()
            continue
        words = line.replace("(", " ").replace(")", " ").split()
        if not words:
            continue
        vals = []
        for w in words:  # skip words such as a field name "mag(U)"
            try:
                vals.append(float(w))
            except ValueError:
                pass
        if vals:
            rows.append(vals)
    width = max((len(r) for r in rows), default=0)
    rows = [r for r in rows if len(r) == width]
    return header, np.array(rows, dtype=float).reshape(len(rows), width)


def fo_file(case: Path, fo_name: str, file_name: str) -> Path:
    """postProcessing/<fo_name>/<start time>/<file_name> (the earliest start)."""
    fo_dir = case / "postProcessing" / fo_name
    if not fo_dir.is_dir():
        raise FileNotFoundError(f"no function-object output {fo_dir}")
    for d in _time_dirs(fo_dir):
        if (d / file_name).exists():
            return d / file_name
    raise FileNotFoundError(f"no {file_name} under {fo_dir}")


def read_fo_series(case: Path, fo_name: str, file_name: str) -> np.ndarray:
    """Numeric rows (time first) of one function-object file."""
    return read_dat(fo_file(case, fo_name, file_name))[1]


def read_sets(case: Path, fo_name: str, file_name: str) -> tuple[np.ndarray, list[np.ndarray]]:
    """Sampled-set snapshots: times and, per time, an array (coord, value...)."""
    fo_dir = case / "postProcessing" / fo_name
    times, data = [], []
    for d in _time_dirs(fo_dir):
        f = d / file_name
        if not f.exists():
            continue
        arr = np.loadtxt(f, ndmin=2) if f.stat().st_size else np.zeros((0, 2))
        times.append(float(d.name))
        data.append(arr)
    return np.array(times), data


_SIXDOF_RE = re.compile(
    r"Centre of mass: \(([^)]*)\).*?Orientation: \(([^)]*)\)", re.S)


def read_sixdof_log(log: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per solver step: time, centre of mass (n,3), orientation (n,3,3).

    With several outer correctors the motion is reported once per corrector;
    the last report before the next "Time =" line is the converged state.
    """
    text = log.read_text(errors="replace")
    blocks = re.split(r"^Time = ", text, flags=re.M)[1:]
    times, coms, qs = [], [], []
    for b in blocks:
        t_str = b.split(None, 1)[0]
        try:
            t = float(t_str)
        except ValueError:
            continue
        found = _SIXDOF_RE.findall(b)
        if not found:
            continue
        com_s, q_s = found[-1]
        com = [float(w) for w in com_s.split()]
        q = [float(w) for w in q_s.split()]
        if len(com) != 3 or len(q) != 9:
            continue
        times.append(t)
        coms.append(com)
        qs.append(np.array(q).reshape(3, 3))
    return np.array(times), np.array(coms).reshape(-1, 3), np.array(qs).reshape(-1, 3, 3)


def read_internal_field(path: Path) -> np.ndarray:
    """internalField of an ascii volField file (scalar or vector, uniform or not)."""
    text = path.read_text(errors="replace")
    m = re.search(r"internalField\s+uniform\s+([^;]+);", text)
    if m:
        words = m.group(1).replace("(", " ").replace(")", " ").split()
        return np.array([float(w) for w in words])[None, :]
    m = re.search(r"internalField\s+nonuniform\s+List<(\w+)>\s*(\d+)\s*\(", text)
    if not m:
        raise ValueError(f"cannot read internalField of {path}")
    n = int(m.group(2))
    body = text[m.end():]
    words = body.replace("(", " ").replace(")", " ").split()
    ncomp = {"scalar": 1, "vector": 3, "symmTensor": 6, "tensor": 9}[m.group(1)]
    vals = np.array([float(w) for w in words[: n * ncomp]])
    return vals.reshape(n, ncomp)
