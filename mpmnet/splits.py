#!/usr/bin/env python3
"""Train / validation / test splits by scene and resolution, read from a JSON split file.

Consecutive steps of one run are nearly identical, so a split by random steps would measure
how well the network remembers a run, not how well it predicts an unseen one. The split file
therefore lists whole run folders per split, and a (scene_name, dx) pair may appear in one
split only: the validation and test errors are then errors on scenes or resolutions the
network never saw.

Split file (paths relative to the split file's folder, or to ``--data-root`` when given;
"test" may be empty)::

    {"format": "iqmpm-mpmnet-split", "format_version": 1,
     "description": "optional free text",
     "train": ["runs/dam_break_dx4", "runs/dam_break_dx2"],
     "validation": ["runs/dam_break_obstacle_dx4"],
     "test": ["runs/elastic_gate_dx4"]}

Command line: ``mpmnet/splits.py SPLIT.json [--data-root DIR] [--sequence-length T]`` checks
the file, opens
every run and prints one line per run; exit 2 (and the reason on stderr) when the file is
refused.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Sequence

if __package__ in (None, ""):  # run as a script: make the package importable
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from mpmnet import FORMAT_VERSION, MPMNetError  # noqa: E402
from mpmnet.data import Run, check_compatible  # noqa: E402

SPLIT_FORMAT = "iqmpm-mpmnet-split"
SPLIT_NAMES = ("train", "validation", "test")
_OPTIONAL_KEYS = ("description",)


@dataclass
class Split:
    """The runs of each split, opened and checked; ``source`` is the split file."""

    source: Path
    runs: Dict[str, List[Run]] = field(default_factory=dict)

    @property
    def train(self) -> List[Run]:
        return self.runs["train"]

    @property
    def validation(self) -> List[Run]:
        return self.runs["validation"]

    @property
    def test(self) -> List[Run]:
        return self.runs["test"]

    def all_runs(self) -> List[Run]:
        return [r for name in SPLIT_NAMES for r in self.runs[name]]

    @property
    def dim(self) -> int:
        return self.train[0].dim

    @property
    def fields(self) -> List[str]:
        return list(self.train[0].fields)

    def close(self) -> None:
        for run in self.all_runs():
            run.close()


def read_split_file(path: Path) -> Dict[str, List[str]]:
    """The split file's run lists, with its format checked (no run is opened)."""
    path = Path(path)
    try:
        doc = json.loads(path.read_text())
    except OSError as e:
        raise MPMNetError(f"{path}: cannot read the split file ({e.strerror})") from None
    except json.JSONDecodeError as e:
        raise MPMNetError(f"{path}: not JSON ({e})") from None
    if not isinstance(doc, dict):
        raise MPMNetError(f"{path}: the split file should be a JSON object")
    if doc.get("format") != SPLIT_FORMAT:
        raise MPMNetError(f"{path}: \"format\" should be \"{SPLIT_FORMAT}\", "
                          f"not {json.dumps(doc.get('format'))}")
    if doc.get("format_version") != FORMAT_VERSION or isinstance(doc.get("format_version"), bool):
        raise MPMNetError(f"{path}: \"format_version\" {json.dumps(doc.get('format_version'))} "
                          f"is not supported (this reader: {FORMAT_VERSION})")
    unknown = sorted(set(doc) - {"format", "format_version", *SPLIT_NAMES, *_OPTIONAL_KEYS})
    if unknown:
        raise MPMNetError(f"{path}: unknown keys {unknown} (known: format, format_version, "
                          f"{', '.join(SPLIT_NAMES)}, {', '.join(_OPTIONAL_KEYS)})")
    lists: Dict[str, List[str]] = {}
    for name in SPLIT_NAMES:
        entries = doc.get(name)
        if not isinstance(entries, list) or not all(isinstance(e, str) and e for e in entries):
            raise MPMNetError(f"{path}: \"{name}\" should be a list of run folders")
        if len(set(entries)) != len(entries):
            raise MPMNetError(f"{path}: \"{name}\" lists a run twice")
        lists[name] = entries
    for name in ("train", "validation"):
        if not lists[name]:
            raise MPMNetError(f"{path}: \"{name}\" is empty")
    seen: Dict[str, str] = {}
    for name in SPLIT_NAMES:
        for entry in lists[name]:
            if entry in seen:
                raise MPMNetError(f"{path}: run {entry} is in both {seen[entry]} and {name}")
            seen[entry] = name
    return lists


def check_disjoint(runs: Dict[str, List[Run]]) -> None:
    """Refuse a (scene_name, dx) pair found in two splits (dx equal to 1e-9 relative)."""
    for a_i, a in enumerate(SPLIT_NAMES):
        for b in SPLIT_NAMES[a_i + 1:]:
            for ra in runs[a]:
                for rb in runs[b]:
                    if ra.scene_name == rb.scene_name and math.isclose(ra.dx, rb.dx,
                                                                       rel_tol=1e-9):
                        raise MPMNetError(
                            f"scene '{ra.scene_name}' at dx {ra.dx:g} is in both {a} "
                            f"({ra.name}) and {b} ({rb.name}): splits must not share a "
                            "(scene_name, dx) pair")


def load_split(path: Path, data_root: Optional[Path] = None) -> Split:
    """Read a split file, open its runs and refuse overlapping or incompatible splits.

    Relative run paths are taken from ``data_root``, by default the split file's folder (a
    split file kept in the repository can then name runs in a data folder elsewhere).
    """
    path = Path(path)
    root = path.parent if data_root is None else Path(data_root)
    lists = read_split_file(path)
    split = Split(source=path, runs={name: [] for name in SPLIT_NAMES})
    try:
        for name in SPLIT_NAMES:
            for entry in lists[name]:
                target = Path(entry)
                if not target.is_absolute():
                    target = root / target
                split.runs[name].append(Run(target, name=entry))
        check_compatible(split.all_runs())
        check_disjoint(split.runs)
    except MPMNetError:
        split.close()
        raise
    return split


def _print_split(split: Split, sequence_length: int, out) -> None:
    print(f"{split.source}: {split.dim}-D, fields {','.join(split.fields)}, "
          f"windows of {sequence_length}+1 steps", file=out)
    print(f"{'split':<11} {'run':<32} {'scene':<24} {'dx':>10} {'cells':>14} {'steps':>6} "
          f"{'windows':>7}", file=out)
    for name in SPLIT_NAMES:
        for run in split.runs[name]:
            cells = "x".join(map(str, run.cells))
            print(f"{name:<11} {run.name:<32} {run.scene_name:<24} {run.dx:>10.4g} "
                  f"{cells:>14} {run.n_steps:>6} {len(run.window_starts(sequence_length)):>7}",
                  file=out)


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(
        prog="mpmnet/splits.py",
        description="Check an MPMNet split file and list its runs (exit 2 when refused).")
    parser.add_argument("split", type=Path, help="the split JSON file")
    parser.add_argument("--data-root", type=Path, default=None,
                        help="folder the run paths are relative to (default: the split "
                             "file's folder)")
    parser.add_argument("--sequence-length", type=int, default=4,
                        help="history length T for the window counts (default 4)")
    args = parser.parse_args(argv)
    try:
        split = load_split(args.split, args.data_root)
    except MPMNetError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    _print_split(split, args.sequence_length, sys.stdout)
    split.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
