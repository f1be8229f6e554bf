#!/usr/bin/env python3
"""The offline metric of a saved model: per-field relative errors of its prediction and of
the cheap warm starts (previous step, linear extrapolation) against the solved fields.

    mpmnet/evaluate.py MODEL.pt RUN [RUN ...] [--windows N] [--threads 2]
    mpmnet/evaluate.py MODEL.pt --split SPLIT.json [--data-root DIR] [--which test]

The model is called through the contract's ``forward`` (one window at a time, no batch
dimension), exactly as the solver calls it. Exit 2: bad input (a run of another dimension
or field list than the model's, a history too short for its sequence length).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Dict, List, Optional, Sequence

if __package__ in (None, ""):  # run as a script: make the package importable
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from mpmnet import MPMNetError  # noqa: E402  (first: it sets OMP_WAIT_POLICY for torch)

import torch  # noqa: E402

from mpmnet import metrics, model  # noqa: E402
from mpmnet.data import Run, Windows, check_compatible, open_runs  # noqa: E402
from mpmnet.splits import SPLIT_NAMES, load_split  # noqa: E402


def evaluate_model(module, meta: Dict, runs: List[Run], windows: int) -> Dict:
    """The metric over ``windows`` evenly spaced windows of ``runs`` (all when fewer)."""
    check_compatible(runs)
    if runs[0].dim != meta.get("dim") or runs[0].fields != meta.get("fields"):
        raise MPMNetError(f"the model is for {meta.get('dim')}-D fields {meta.get('fields')}, "
                          f"the runs are {runs[0].dim}-D fields {runs[0].fields}")
    T = int(meta["sequence_length"])
    ws = Windows(runs, T)
    if len(ws) == 0:
        raise MPMNetError(f"the runs have no window of {T}+1 consecutive steps")

    def predict(history, history_active, next_active):  # the contract: one window at a time
        return torch.stack([module(history[b], history_active[b], next_active[b])
                            for b in range(history.shape[0])])

    return metrics.evaluate(predict, ws, ws.evenly_spaced(windows), runs[0].fields)


def main(argv: Optional[Sequence[str]] = None) -> int:
    p = argparse.ArgumentParser(prog="mpmnet/evaluate.py", description=__doc__.split("\n\n")[0])
    p.add_argument("model", type=Path, help="the TorchScript model (MODEL.pt)")
    p.add_argument("runs", type=Path, nargs="*", help="run folders or pressure_fields.h5 files")
    p.add_argument("--split", type=Path, help="take the runs from this split file")
    p.add_argument("--data-root", type=Path, default=None,
                   help="folder the split's run paths are relative to (default: its folder)")
    p.add_argument("--which", choices=SPLIT_NAMES, default="test",
                   help="which split of --split (default test)")
    p.add_argument("--windows", type=int, default=256,
                   help="evenly spaced windows to evaluate (default 256)")
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    args = p.parse_args(argv)
    if bool(args.runs) == bool(args.split):
        p.error("give either runs or --split")
    torch.set_num_threads(args.threads)
    try:
        module, meta = model.load(args.model)
    except (RuntimeError, ValueError, OSError) as e:
        print(f"error: {args.model}: not an MPMNet model ({e})", file=sys.stderr)
        return 2
    try:
        if args.split:
            split = load_split(args.split, args.data_root)
            runs = split.runs[args.which]
            if not runs:
                raise MPMNetError(f"{args.split}: the {args.which} split is empty")
        else:
            runs = open_runs(args.runs)
        result = evaluate_model(module, meta, runs, args.windows)
    except MPMNetError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(result, indent=1))
    else:
        print(f"{args.model}: {result['windows']} windows of {len(runs)} runs "
              f"({', '.join(r.name for r in runs)}); relative L2 error on the next step's "
              "active cells, mean over windows")
        print(metrics.format_table(result["relative_l2"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
