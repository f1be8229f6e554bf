"""Reading the solver's ``pressure_fields.h5`` files into training windows.

A *window* is T consecutive solved steps of one run (the history the solver will hold at
run time) plus the step after them (the target). Windows never cross runs and never cross a
gap in the ``step`` numbers: at run time the history is always the last T steps, so a
window with a gap would teach the network a time step it never sees.

The files are read lazily (one h5py slice per window, the file is chunked one step at a
time), so a family of long 3-D runs does not have to fit in memory; ``preload_runs`` reads
runs into memory up to a budget, which is faster when they are sampled many times per epoch
(a 128x128 window: 7 ms from the gzip file, 0.5 ms from memory).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Dict, Iterator, List, Optional, Sequence, Tuple

import h5py
import numpy as np

from mpmnet import FORMAT_VERSION, MPMNetError

#: The ``format`` attribute of the dataset file (the contract in mpmnet/README.md).
DATASET_FORMAT = "iqmpm-pressure-fields"
#: The file name the solver writes in each run's output folder.
FILE_NAME = "pressure_fields.h5"

_STEP_DATASETS = ("time", "dt", "step", "iterations")


def _text(value) -> str:
    """An HDF5 string attribute as ``str``: C++ writers store bytes, h5py may give either."""
    if isinstance(value, np.ndarray):
        value = value.item() if value.shape == () else value.tolist()
    if isinstance(value, (bytes, np.bytes_)):
        return value.decode("utf-8")
    return str(value)


def _int(value, what: str) -> int:
    arr = np.asarray(value)
    if arr.size != 1 or not np.issubdtype(arr.dtype, np.integer):
        raise MPMNetError(f"attribute {what} should be one integer, not {value!r}")
    return int(arr.reshape(()))


def resolve_run_file(path: Path) -> Path:
    """A run folder (holding ``pressure_fields.h5``) or the file itself -> the file."""
    path = Path(path)
    if path.is_dir():
        path = path / FILE_NAME
    if not path.is_file():
        raise MPMNetError(f"{path}: no such file (a run folder must hold {FILE_NAME})")
    return path


class Run:
    """One run's ``pressure_fields.h5``: its attributes, and its steps read on demand.

    ``name`` is what the model file records in ``trained_on``; by default the run folder's
    name. The file is checked against the contract when opened, so that a wrong file fails
    at start-up with its name and not half-way through training.
    """

    def __init__(self, path: Path, name: Optional[str] = None):
        self.path = resolve_run_file(Path(path))
        self.name = name if name is not None else (
            self.path.parent.name if self.path.name == FILE_NAME else self.path.stem)
        try:
            self._file = h5py.File(self.path, "r")
        except OSError as e:
            raise MPMNetError(f"{self.path}: not a readable HDF5 file ({e})") from None
        try:
            self._read_header()
        except MPMNetError as e:
            self._file.close()
            raise MPMNetError(f"{self.path}: {e}") from None
        except (KeyError, TypeError, ValueError) as e:
            self._file.close()
            raise MPMNetError(f"{self.path}: not a valid {DATASET_FORMAT} file ({e})") from None

    def _read_header(self) -> None:
        attrs = self._file.attrs
        if "format" not in attrs or _text(attrs["format"]) != DATASET_FORMAT:
            raise MPMNetError(f"attribute format should be '{DATASET_FORMAT}', "
                              f"not {_text(attrs['format']) if 'format' in attrs else 'missing'}")
        version = _int(attrs.get("format_version", -1), "format_version")
        if version != FORMAT_VERSION:
            raise MPMNetError(f"format_version {version} is not supported (this reader: "
                              f"{FORMAT_VERSION})")
        self.dim = _int(attrs["dim"], "dim")
        if self.dim not in (2, 3):
            raise MPMNetError(f"dim should be 2 or 3, not {self.dim}")
        self.dx = float(np.asarray(attrs["dx"]).reshape(()))
        if not (math.isfinite(self.dx) and self.dx > 0):
            raise MPMNetError(f"dx should be positive, not {self.dx}")
        self.origin = np.asarray(attrs["origin"], dtype=np.float64).reshape(-1)
        self.cells = tuple(int(n) for n in np.asarray(attrs["cells"]).reshape(-1))
        if len(self.origin) != self.dim or len(self.cells) != self.dim or min(self.cells) < 1:
            raise MPMNetError(f"origin {self.origin.tolist()} and cells {list(self.cells)} "
                              f"should have dim = {self.dim} entries (cells >= 1)")
        self.scene_name = _text(attrs["scene_name"])
        self.fields = [f.strip() for f in _text(attrs["fields"]).split(",")]
        if not all(self.fields) or len(set(self.fields)) != len(self.fields):
            raise MPMNetError(f"attribute fields '{_text(attrs['fields'])}' should be distinct "
                              "comma-separated names")
        units = _text(attrs.get("units", "missing"))
        if units != "Pa":
            raise MPMNetError(f"units should be 'Pa', not '{units}'")
        self._fields = self._file["fields"]
        self._active = self._file["active"]
        shape = self._fields.shape
        expected = (len(self.fields),) + self.cells
        if len(shape) != 2 + self.dim or tuple(shape[1:]) != expected:
            raise MPMNetError(f"dataset fields has shape {shape}, expected [S, "
                              f"{', '.join(map(str, expected))}]")
        if self._active.shape != shape:
            raise MPMNetError(f"dataset active has shape {self._active.shape}, fields {shape}")
        self.n_steps = shape[0]
        for key in _STEP_DATASETS:
            if self._file[key].shape != (self.n_steps,):
                raise MPMNetError(f"dataset {key} has shape {self._file[key].shape}, "
                                  f"expected [{self.n_steps}]")
        self.step = np.asarray(self._file["step"][()], dtype=np.int64)
        self.time = np.asarray(self._file["time"][()], dtype=np.float64)

    @property
    def nbytes(self) -> int:
        """Memory the run takes once preloaded (float32 fields + uint8 masks)."""
        return int(np.prod(self._fields.shape)) * 5

    @property
    def preloaded(self) -> bool:
        return isinstance(self._fields, np.ndarray)

    def preload(self) -> None:
        """Read the whole run into memory (windows are then read without decompression)."""
        if not self.preloaded:
            self._fields = self._fields[()]
            self._active = self._active[()]

    @property
    def key(self) -> Tuple[str, float]:
        """(scene_name, dx): what may not be shared between splits."""
        return (self.scene_name, self.dx)

    def window_starts(self, sequence_length: int) -> np.ndarray:
        """Indices i such that rows i .. i+T hold consecutive step numbers (T = history)."""
        T = int(sequence_length)
        if T < 1:
            raise ValueError("sequence_length must be >= 1")
        n = self.n_steps - T
        if n <= 0:
            return np.zeros(0, dtype=np.int64)
        consecutive = np.diff(self.step) == 1  # row r -> r+1 is one step
        # a window starting at i needs consecutive[i .. i+T-1] all true
        ok = np.ones(n, dtype=bool)
        for k in range(T):
            ok &= consecutive[k:k + n]
        return np.nonzero(ok)[0].astype(np.int64)

    def window(self, start: int, sequence_length: int
               ) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(history, history_active, next_fields, next_active) as float32 arrays.

        history [T, C, *cells] are rows start .. start+T-1 (oldest first), the target is row
        start+T. Values outside the masks are set to 0 whatever the file holds there, as the
        contract promises the model.
        """
        T = int(sequence_length)
        rows = slice(int(start), int(start) + T + 1)
        fields = np.asarray(self._fields[rows], dtype=np.float32)
        active = np.asarray(self._active[rows], dtype=np.float32)
        if fields.shape[0] != T + 1:
            raise IndexError(f"window {start}+{T} outside {self.n_steps} steps of {self.name}")
        fields *= active
        return fields[:T], active[:T], fields[T], active[T]

    def describe(self) -> Dict:
        return {"name": self.name, "path": str(self.path), "scene_name": self.scene_name,
                "dx": self.dx, "dim": self.dim, "cells": list(self.cells),
                "steps": int(self.n_steps)}

    def close(self) -> None:
        self._file.close()


class Windows:
    """All windows of T+1 consecutive steps over a list of runs, as (run, start) pairs."""

    def __init__(self, runs: Sequence[Run], sequence_length: int):
        self.runs = list(runs)
        self.sequence_length = int(sequence_length)
        pairs = [np.stack([np.full(len(s), r, dtype=np.int64), s], axis=1)
                 for r, s in enumerate(run.window_starts(self.sequence_length)
                                       for run in self.runs)]
        self.pairs = np.concatenate(pairs) if pairs else np.zeros((0, 2), dtype=np.int64)

    def __len__(self) -> int:
        return len(self.pairs)

    def sample(self, count: int, rng: np.random.Generator) -> np.ndarray:
        """``count`` distinct windows at random (all of them, shuffled, if fewer)."""
        order = rng.permutation(len(self.pairs))
        return self.pairs[order[:count]]

    def evenly_spaced(self, count: int) -> np.ndarray:
        """A fixed subset of ``count`` windows spread over every run (the validation set)."""
        if count >= len(self.pairs):
            return self.pairs.copy()
        idx = np.unique(np.linspace(0, len(self.pairs) - 1, count).round().astype(np.int64))
        return self.pairs[idx]

    def batches(self, pairs: np.ndarray, batch_size: int,
                rng: Optional[np.random.Generator] = None) -> Iterator[np.ndarray]:
        """Groups of at most ``batch_size`` windows whose runs share a grid size.

        Runs of different resolutions cannot share a batch tensor; grouping by size (and
        shuffling the order of the groups when ``rng`` is given) keeps every window used.
        """
        by_shape: Dict[Tuple[int, ...], List[np.ndarray]] = {}
        for pair in pairs:
            by_shape.setdefault(self.runs[int(pair[0])].cells, []).append(pair)
        groups = []
        for shape in sorted(by_shape):
            items = by_shape[shape]
            groups += [np.stack(items[i:i + batch_size])
                       for i in range(0, len(items), batch_size)]
        if rng is not None:
            groups = [groups[i] for i in rng.permutation(len(groups))]
        yield from groups

    def load(self, pairs: np.ndarray):
        """The windows ``pairs`` stacked as torch tensors with a leading batch dimension:
        history, history_active [B, T, C, *cells]; target, next_active [B, C, *cells]."""
        import torch

        parts = [self.runs[int(r)].window(int(s), self.sequence_length) for r, s in pairs]
        return tuple(torch.from_numpy(np.stack([p[k] for p in parts])) for k in range(4))


def open_runs(paths: Sequence[Path], names: Optional[Sequence[str]] = None) -> List[Run]:
    """Open several runs; they must agree on dim and fields (one model serves them all)."""
    runs: List[Run] = []
    try:
        for i, p in enumerate(paths):
            runs.append(Run(p, None if names is None else names[i]))
        check_compatible(runs)
    except MPMNetError:
        for run in runs:
            run.close()
        raise
    return runs


def preload_runs(runs: Sequence[Run], budget_bytes: float) -> int:
    """Read runs into memory in order while their total stays within the budget; the
    others stay lazy. Returns the bytes preloaded."""
    used = 0
    for run in runs:
        if used + run.nbytes <= budget_bytes:
            run.preload()
            used += run.nbytes
    return used


def check_compatible(runs: Sequence[Run]) -> None:
    """Refuse a mix of dimensions or of field lists: the network is built for one of each."""
    if not runs:
        return
    dims = sorted({r.dim for r in runs})
    if len(dims) > 1:
        listing = ", ".join(f"{r.name} ({r.dim}-D)" for r in runs)
        raise MPMNetError(f"runs of different dimensions cannot be mixed: {listing}")
    fields = {tuple(r.fields) for r in runs}
    if len(fields) > 1:
        listing = ", ".join(f"{r.name} ({','.join(r.fields)})" for r in runs)
        raise MPMNetError(f"runs with different field lists cannot be mixed: {listing}")
