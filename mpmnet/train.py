#!/usr/bin/env python3
"""Train MPMNet on the runs of a split file and export the TorchScript model.

    mpmnet/train.py --split SPLIT.json [--data-root DIR] --out MODEL.pt [--sequence-length 4]
                    [--epochs N] [--minutes M] [--threads 2] [--seed 0]

An epoch is a fixed number of windows drawn at random from all training windows
(``--windows-per-epoch``): a family of runs of 1000 steps has far more windows than a CPU can
visit in minutes, and neighbouring windows are nearly identical anyway. Validation uses a
fixed, evenly spaced subset of the validation windows, so that its numbers are comparable
from epoch to epoch. The weights with the best validation loss are the ones exported.

Writes MODEL.pt (with ``mpmnet.json``), MODEL.loss.csv (one row per epoch; row 0 is the
untrained network, which equals the previous-step guess) and MODEL.loss.png. With the same
seed and ``--epochs`` the result is the same bit for bit; ``--minutes`` ends training when
the time is up (at the batch that reaches it, minus the time of the last validation and the
export), so how far it gets depends on the machine. Ctrl-C ends training the same way and
exports the best weights so far (exit 130). Exit 2: bad input (nothing written).
"""

from __future__ import annotations

import argparse
import copy
import csv
import math
import sys
import time
from pathlib import Path
from typing import Dict, List, Optional, Sequence

if __package__ in (None, ""):  # run as a script: make the package importable
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from mpmnet import MPMNetError  # noqa: E402  (first: it sets OMP_WAIT_POLICY for torch)

import numpy as np  # noqa: E402
import torch  # noqa: E402

from mpmnet import metrics, model  # noqa: E402
from mpmnet.data import Windows, preload_runs  # noqa: E402
from mpmnet.splits import load_split  # noqa: E402


def _clock(seconds: float) -> str:
    seconds = max(0, int(round(seconds)))
    h, rest = divmod(seconds, 3600)
    return f"{h}:{rest // 60:02d}:{rest % 60:02d}" if h else f"{rest // 60}:{rest % 60:02d}"


class Progress:
    """One status line on stderr: rewritten in place on a terminal, every 10 % otherwise."""

    def __init__(self, stream=sys.stderr):
        self.stream = stream
        self.tty = stream.isatty()
        self.last_tenth = -1

    def update(self, epoch: str, done: int, total: int, loss: float, elapsed: float,
               eta: Optional[float]) -> None:
        tenth = int(10 * done / max(total, 1))
        if not self.tty and tenth == self.last_tenth and done != total:
            return
        self.last_tenth = tenth
        width = 24
        filled = int(width * done / max(total, 1))
        bar = "#" * filled + "." * (width - filled)
        eta_text = _clock(eta) if eta is not None else "?"
        line = (f"epoch {epoch} [{bar}] batch {done}/{total} loss {loss:.3e} "
                f"elapsed {_clock(elapsed)} eta {eta_text}")
        if self.tty:
            self.stream.write("\r" + line + "\033[K")
            if done == total:
                self.stream.write("\n")
        else:
            self.stream.write(line + "\n")
        self.stream.flush()

    def message(self, text: str) -> None:
        if self.tty:
            self.stream.write("\r\033[K")
        self.stream.write(text + "\n")
        self.stream.flush()


def parse_args(argv: Optional[Sequence[str]]) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="mpmnet/train.py", description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--split", type=Path, required=True, help="split JSON file (mpmnet/README.md)")
    p.add_argument("--data-root", type=Path, default=None,
                   help="folder the split's run paths are relative to (default: the split "
                        "file's folder)")
    p.add_argument("--out", type=Path, required=True, help="model file to write (MODEL.pt)")
    p.add_argument("--sequence-length", type=int, default=4, help="history length T")
    p.add_argument("--epochs", type=int, default=None,
                   help="epochs (default: 30, or until --minutes when that is given)")
    p.add_argument("--minutes", type=float, default=None, help="wall-clock budget")
    p.add_argument("--threads", type=int, default=2, help="torch CPU threads")
    p.add_argument("--seed", type=int, default=0, help="seed of weights and window sampling")
    p.add_argument("--batch-size", type=int, default=4, help="windows per batch")
    p.add_argument("--windows-per-epoch", type=int, default=1024,
                   help="training windows drawn at random per epoch")
    p.add_argument("--validation-windows", type=int, default=128,
                   help="size of the fixed validation subset")
    p.add_argument("--learning-rate", type=float, default=1e-3,
                   help="Adam learning rate at the start (cosine decay to 5 %% of it)")
    p.add_argument("--memory-gb", type=float, default=4.0,
                   help="runs read into memory up to this size; the rest are read lazily")
    args = p.parse_args(argv)
    if args.sequence_length < 1:
        p.error("--sequence-length must be >= 1")
    if args.epochs is not None and args.epochs < 1:
        p.error("--epochs must be >= 1")
    if args.minutes is not None and args.minutes <= 0:
        p.error("--minutes must be > 0")
    if args.threads < 1 or args.batch_size < 1 or args.windows_per_epoch < 1 \
            or args.validation_windows < 1:
        p.error("--threads, --batch-size, --windows-per-epoch, --validation-windows must be >= 1")
    if args.epochs is None and args.minutes is None:
        args.epochs = 30
    return args


def side_file(out: Path, suffix: str) -> Path:
    """MODEL.pt -> MODEL.loss.png (beside the model)."""
    return out.with_name(out.stem + suffix)


def learning_rate(base: float, done: float) -> float:
    """Cosine decay from ``base`` to 5 % of it over the training (``done`` from 0 to 1): the
    late small steps settle the weights, which a constant rate leaves noisy."""
    done = min(max(done, 0.0), 1.0)
    return base * (0.05 + 0.95 * 0.5 * (1.0 + math.cos(math.pi * done)))


def _log_scale_if_positive(ax) -> None:
    """Log scale when the plotted data allow it (a field that never changes has errors 0)."""
    values = np.concatenate([np.asarray(line.get_ydata(), float) for line in ax.get_lines()]
                            or [np.zeros(0)])
    if np.any(values[np.isfinite(values)] > 0):
        ax.set_yscale("log")


def write_curves(rows: List[Dict], fields: List[str], csv_path: Path, png_path: Path) -> None:
    """The loss curves as CSV and as a PNG (losses; validation errors against the guesses)."""
    columns = ["epoch", "windows_seen", "elapsed_s", "train_loss", "validation_loss"] + [
        f"{f}_{g}" for f in fields for g in metrics.GUESSES]
    with open(csv_path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=columns)
        writer.writeheader()
        for row in rows:
            writer.writerow({k: row.get(k, "") for k in columns})

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    epochs = [r["epoch"] for r in rows]
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(11, 4))
    train = [(r["epoch"], r["train_loss"]) for r in rows if r.get("train_loss") != ""]
    if train:
        ax0.plot(*zip(*train), "o-", label="train")
    ax0.plot(epochs, [r["validation_loss"] for r in rows], "s-", label="validation")
    _log_scale_if_positive(ax0)
    ax0.set_xlabel("epoch")
    ax0.set_ylabel("loss (error / previous-step error)")
    ax0.legend()
    ax0.grid(True, which="both", alpha=0.3)
    styles = {"model": "-", "previous_step": "--", "linear_extrapolation": ":"}
    for i, f in enumerate(fields):
        for g in metrics.GUESSES:
            ys = [r[f"{f}_{g}"] for r in rows]
            if all(isinstance(y, float) and math.isnan(y) for y in ys):
                continue
            ax1.plot(epochs, ys, styles[g], color=f"C{i}", label=f"{f} ({g})")
    _log_scale_if_positive(ax1)
    ax1.set_xlabel("epoch")
    ax1.set_ylabel("validation relative L2 error")
    ax1.legend(fontsize=7)
    ax1.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(png_path, dpi=100)
    plt.close(fig)


def train(args: argparse.Namespace) -> int:
    progress = Progress()
    start = time.monotonic()
    torch.set_num_threads(args.threads)
    torch.manual_seed(args.seed)
    torch.use_deterministic_algorithms(True)
    rng = np.random.default_rng(args.seed)

    try:
        split = load_split(args.split, args.data_root)
        train_set = Windows(split.train, args.sequence_length)
        val_set = Windows(split.validation, args.sequence_length)
        for name, ws in (("train", train_set), ("validation", val_set)):
            if len(ws) == 0:
                raise MPMNetError(f"{args.split}: the {name} runs have no window of "
                                  f"{args.sequence_length}+1 consecutive steps")
        try:  # the output folder now, not after the training
            args.out.parent.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise MPMNetError(f"{args.out}: cannot write there ({e.strerror})") from None
    except MPMNetError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    used = preload_runs(split.train + split.validation, args.memory_gb * 1024 ** 3)
    fields = split.fields
    progress.message(
        f"{split.dim}-D, fields {','.join(fields)}, T = {args.sequence_length}: "
        f"{len(split.train)} train runs ({len(train_set)} windows), {len(split.validation)} "
        f"validation runs ({len(val_set)} windows); {used / 1024 ** 2:.0f} MB in memory; "
        f"{args.threads} threads")

    module = model.build(split.dim, len(fields))
    # Scripted now, not after training: a module that does not script fails in seconds, and
    # the export cannot be broken by the source files changing during a long training
    # (TorchScript compiles from the source on disk). The best weights are copied in at the end.
    scripted = torch.jit.script(module)
    optimiser = torch.optim.Adam(module.parameters(), lr=args.learning_rate)
    val_pairs = val_set.evenly_spaced(args.validation_windows)

    def loss_of(history, history_active, next_active, target):
        previous = history[:, -1] * history_active[:, -1] * next_active
        return metrics.improvement_loss(module.predict(history, history_active, next_active),
                                        target, previous, next_active)

    def validate() -> Dict:
        module.eval()
        t0 = time.monotonic()
        result = metrics.evaluate(module.predict, val_set, val_pairs, fields,
                                  args.batch_size, loss_of)
        result["seconds"] = time.monotonic() - t0
        module.train()
        return result

    result = validate()
    rows = [curve_row(0, 0, "", result, time.monotonic() - start)]
    best = {"epoch": 0, "result": result, "state": copy.deepcopy(module.state_dict())}
    progress.message(f"untrained (= previous step): validation loss {result['loss']:.4e} "
                     f"on {result['windows']} windows\n" + metrics.format_table(
                         result["relative_l2"]))
    budget = None if args.minutes is None else 60.0 * args.minutes
    reserve = result["seconds"] + 5.0  # the last validation and the export
    epochs = args.epochs if args.epochs is not None else 10 ** 9
    epochs_text = str(args.epochs) if args.epochs is not None else "?"
    seen = 0
    batch_seconds: List[float] = []
    status = 0
    stop = False
    epoch = 0
    try:
        while epoch < epochs and not stop:
            epoch += 1
            pairs = train_set.sample(args.windows_per_epoch, rng)
            batches = list(train_set.batches(pairs, args.batch_size, rng))
            losses, weights = [], []
            for i, batch in enumerate(batches):
                t0 = time.monotonic()
                done = []  # the fraction of the training done, by epochs and by time
                if args.epochs is not None:
                    done.append((epoch - 1 + i / len(batches)) / args.epochs)
                if budget is not None:
                    done.append((t0 - start) / max(budget - reserve, 1e-9))
                for group in optimiser.param_groups:
                    group["lr"] = learning_rate(args.learning_rate, max(done))
                history, history_active, target, next_active = train_set.load(batch)
                loss = loss_of(history, history_active, next_active, target)
                optimiser.zero_grad(set_to_none=True)
                loss.backward()
                torch.nn.utils.clip_grad_norm_(module.parameters(), 1.0)
                optimiser.step()
                losses.append(float(loss) * len(batch))
                weights.append(len(batch))
                seen += len(batch)
                batch_seconds.append(time.monotonic() - t0)
                elapsed = time.monotonic() - start
                per_batch = float(np.mean(batch_seconds[-50:]))
                eta = (len(batches) - i - 1 + (epochs - epoch) * len(batches)) * per_batch \
                    + (epochs - epoch + 1) * reserve if args.epochs is not None else None
                if budget is not None:
                    left = max(budget - elapsed, 0.0)
                    eta = left if eta is None else min(eta, left)
                progress.update(f"{epoch}/{epochs_text}", i + 1, len(batches),
                                sum(losses) / sum(weights), elapsed, eta)
                if budget is not None and elapsed + per_batch + reserve >= budget:
                    stop = True
                    if i + 1 < len(batches):
                        progress.message(f"time budget of {args.minutes:g} min reached in "
                                         f"epoch {epoch} (batch {i + 1}/{len(batches)})")
                    break
            if weights:
                end_epoch(epoch, seen, sum(losses) / sum(weights), validate(),
                          time.monotonic() - start, rows, best, module, progress)
    except KeyboardInterrupt:
        progress.message("interrupted: exporting the best weights so far")
        status = 130

    module.load_state_dict(best["state"])
    module.eval()
    validation = {
        "metric": "mean over validation windows of |guess - solved|_2 / |solved|_2 on the "
                  "next step's active cells, per field",
        "runs": [r.name for r in split.validation], "windows": best["result"]["windows"],
        "best_epoch": best["epoch"], "loss": best["result"]["loss"],
        "relative_l2": best["result"]["relative_l2"]}
    meta = model.metadata(split.dim, fields, args.sequence_length,
                          [r.name for r in split.train], validation)
    meta["training"] = {"epochs": len(rows) - 1, "windows_seen": seen, "seed": args.seed,
                        "seconds": round(time.monotonic() - start, 1),
                        "batch_size": args.batch_size,
                        "windows_per_epoch": args.windows_per_epoch,
                        "learning_rate": args.learning_rate, "threads": args.threads}
    scripted.load_state_dict(best["state"])
    model.save(scripted, args.out, meta)
    check_export(args.out, module, val_set, val_pairs[:1])
    write_curves(rows, fields, side_file(args.out, ".loss.csv"), side_file(args.out, ".loss.png"))
    progress.message(
        f"best epoch {best['epoch']} (validation loss {best['result']['loss']:.4e}); wrote "
        f"{args.out}, {side_file(args.out, '.loss.png').name}, "
        f"{side_file(args.out, '.loss.csv').name} in {_clock(time.monotonic() - start)}\n"
        + metrics.format_table(best["result"]["relative_l2"]))
    split.close()
    return status


def curve_row(epoch: int, seen: int, train_loss, result: Dict, elapsed: float) -> Dict:
    """One row of the loss curves (MODEL.loss.csv)."""
    row = {"epoch": epoch, "windows_seen": seen, "elapsed_s": round(elapsed, 2),
           "train_loss": train_loss, "validation_loss": result["loss"]}
    for f, errors in result["relative_l2"].items():
        for g, value in errors.items():
            row[f"{f}_{g}"] = value
    return row


def end_epoch(epoch: int, seen: int, train_loss: float, result: Dict, elapsed: float,
              rows: List[Dict], best: Dict, module, progress: Progress) -> None:
    """Record an epoch's row, keep the weights if they are the best, and report."""
    rows.append(curve_row(epoch, seen, train_loss, result, elapsed))
    improved = result["loss"] < best["result"]["loss"]
    if improved:
        best.update(epoch=epoch, result=result, state=copy.deepcopy(module.state_dict()))
    model_err = ", ".join(f"{f} {e['model']:.3e} (prev {e['previous_step']:.3e})"
                          for f, e in result["relative_l2"].items())
    progress.message(f"epoch {epoch}: train loss {train_loss:.4e}, validation loss "
                     f"{result['loss']:.4e}{' *best*' if improved else ''}; relative L2 "
                     f"{model_err}")


def check_export(path: Path, module, windows: Windows, pairs: np.ndarray) -> None:
    """The saved file, loaded back, must give what the trained module gives, through the
    contract's forward (no batch dimension): a guard against a scripting difference."""
    history, history_active, _, next_active = windows.load(pairs)
    loaded, _ = model.load(path)
    with torch.no_grad():
        eager = module.predict(history, history_active, next_active)[0]
        saved = loaded(history[0], history_active[0], next_active[0])
    scale = float(eager.abs().max()) or 1.0
    if float((saved - eager).abs().max()) > 1e-4 * scale:
        raise RuntimeError("the scripted module disagrees with the trained one")


def main(argv: Optional[Sequence[str]] = None) -> int:
    return train(parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
