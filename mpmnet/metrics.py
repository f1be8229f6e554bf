"""The training loss and the offline metric (shared by train.py and evaluate.py).

The metric is what a warm start is for: the relative L2 error of the starting guess against
the solved fields of the step, per field, on the step's active cells, averaged over windows
(each window is one pressure solve). It is reported for the network and for the two cheap
warm starts it has to beat (docs/method.md §10): the previous step, and the linear
extrapolation of the last two steps.
"""

from __future__ import annotations

from typing import Callable, Dict, List, Sequence

import numpy as np
import torch

from mpmnet.data import Windows

#: The guesses the metric reports, in the order of the tables.
GUESSES = ("model", "previous_step", "linear_extrapolation")


#: In the loss, the previous step's error is floored at this fraction of the solved field.
LOSS_FLOOR = 1e-5


def improvement_loss(prediction: torch.Tensor, target: torch.Tensor, previous: torch.Tensor,
                     next_active: torch.Tensor) -> torch.Tensor:
    """The error of the prediction relative to the error of the previous-step guess, per
    (window, field), on the active cells, averaged over the pairs that have any.

    1 means "as good as the previous step", 0.1 ten times better. Measuring the error
    against the previous step's and not against the field puts every window and field on
    one footing: a field that hardly changes (error 1e-5 of its size) and one whose cells
    appear and disappear (1e-1) count alike, as they do for the iterations of a solve. The
    denominator is floored at ``LOSS_FLOOR`` times the solved field's norm, so that a step
    that does not change is not a division by zero. All in Pa: the ratio has no units.
    """
    B, C = target.shape[0], target.shape[1]
    act = next_active.reshape(B, C, -1)
    t = target.reshape(B, C, -1) * act
    err = ((prediction.reshape(B, C, -1) - t) * act).norm(dim=2)
    prev = ((previous.reshape(B, C, -1) - t) * act).norm(dim=2)
    denominator = prev + LOSS_FLOOR * t.norm(dim=2)
    present = denominator > 0
    ratio = err / torch.where(present, denominator, torch.ones_like(denominator))
    return ratio[present].mean() if bool(present.any()) else ratio.sum() * 0


def linear_extrapolation(history: torch.Tensor, history_active: torch.Tensor,
                         next_active: torch.Tensor) -> torch.Tensor:
    """2 p[T-1] - p[T-2] where the unknown existed in both steps, p[T-1] where only in the
    last, 0 where it did not exist; masked by next_active. Batched [B, T, C, *s]."""
    last = history[:, -1] * history_active[:, -1]
    if history.shape[1] < 2:
        return last * next_active
    both = history_active[:, -1] * history_active[:, -2]
    extrapolated = last + both * (last - history[:, -2] * history_active[:, -2])
    return extrapolated * next_active


def guesses(predict: Callable, history, history_active, next_active) -> Dict[str, torch.Tensor]:
    """The three warm starts of a batch, in Pa."""
    return {"model": predict(history, history_active, next_active),
            "previous_step": history[:, -1] * history_active[:, -1] * next_active,
            "linear_extrapolation": linear_extrapolation(history, history_active, next_active)}


def relative_errors(guess: torch.Tensor, target: torch.Tensor, next_active: torch.Tensor):
    """[B, C] relative L2 errors on the active cells, and [B, C] whether the target is
    nonzero there (a window whose target is zero has no relative error)."""
    B, C = target.shape[0], target.shape[1]
    act = next_active.reshape(B, C, -1)
    t = (target.reshape(B, C, -1) * act).double()
    e = ((guess - target).reshape(B, C, -1) * act).double()
    norm = t.norm(dim=2)
    valid = norm > 0
    return e.norm(dim=2) / torch.where(valid, norm, torch.ones_like(norm)), valid


class MetricSum:
    """Accumulates per-field relative errors of each guess over windows."""

    def __init__(self, fields: Sequence[str]):
        self.fields = list(fields)
        self.sums = {g: np.zeros(len(self.fields)) for g in GUESSES}
        self.counts = np.zeros(len(self.fields))
        self.windows = 0

    def add(self, batch_guesses: Dict[str, torch.Tensor], target, next_active) -> None:
        for name, guess in batch_guesses.items():
            rel, valid = relative_errors(guess, target, next_active)
            self.sums[name] += (rel * valid).sum(dim=0).numpy()
        self.counts += valid.sum(dim=0).numpy()
        self.windows += target.shape[0]

    def result(self) -> Dict[str, Dict[str, float]]:
        """{field: {guess: mean relative L2 error}} (NaN where no window had the field)."""
        out: Dict[str, Dict[str, float]] = {}
        for i, f in enumerate(self.fields):
            n = self.counts[i]
            out[f] = {g: (float(self.sums[g][i] / n) if n > 0 else float("nan"))
                      for g in GUESSES}
        return out


def evaluate(predict: Callable, windows: Windows, pairs: np.ndarray, fields: List[str],
             batch_size: int = 4, loss_of: Callable = None) -> Dict:
    """The metric (and, with ``loss_of``, the mean loss) of ``predict`` over ``pairs``.

    ``predict(history, history_active, next_active)`` is batched and returns Pa;
    ``loss_of(history, history_active, next_active, target)`` returns a scalar loss (the mean
    over windows of the batch's losses is reported).
    """
    total = MetricSum(fields)
    losses = []
    with torch.no_grad():
        for batch in windows.batches(pairs, batch_size):
            history, history_active, target, next_active = windows.load(batch)
            total.add(guesses(predict, history, history_active, next_active), target,
                      next_active)
            if loss_of is not None:
                losses.append(float(loss_of(history, history_active, next_active, target))
                              * len(batch))
    result = {"windows": total.windows, "relative_l2": total.result()}
    if loss_of is not None:
        result["loss"] = sum(losses) / max(total.windows, 1)
    return result


def format_table(relative_l2: Dict[str, Dict[str, float]]) -> str:
    """The per-field errors as a small text table (one row per field)."""
    lines = [f"{'field':<16}" + "".join(f"{g:>22}" for g in GUESSES)]
    for f, row in relative_l2.items():
        lines.append(f"{f:<16}" + "".join(f"{row[g]:>22.4e}" for g in GUESSES))
    return "\n".join(lines)
