"""PNG plots (matplotlib, Agg backend). Every chart has axis labels with units and a legend."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


@dataclass(frozen=True)
class Curve:
    x: np.ndarray
    y: np.ndarray
    label: str
    style: str = "-"  # "-" line, "o" markers only, "o-" both


def _finish(fig: plt.Figure, ax: plt.Axes, path: Path, title: str, xlabel: str,
            ylabel: str) -> Path:
    ax.set_title(title)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def line_plot(path: Path, curves: Sequence[Curve], title: str, xlabel: str,
              ylabel: str) -> Path:
    """Series or profiles on common axes."""
    fig, ax = plt.subplots(figsize=(7, 4.2))
    for c in curves:
        marker = "o" if "o" in c.style else None
        linestyle = "-" if "-" in c.style else "none"
        ax.plot(c.x, c.y, marker=marker, linestyle=linestyle, markersize=4, label=c.label)
    return _finish(fig, ax, path, title, xlabel, ylabel)


def loglog_plot(path: Path, curves: Sequence[Curve], title: str, xlabel: str, ylabel: str,
                slopes: Sequence[int] = ()) -> Path:
    """Log-log plot (convergence or cost), with optional reference slopes h^p."""
    fig, ax = plt.subplots(figsize=(6, 4.5))
    xs_all = []
    for c in curves:
        keep = (np.asarray(c.x) > 0) & (np.asarray(c.y) > 0)
        if not np.any(keep):
            continue
        x, y = np.asarray(c.x)[keep], np.asarray(c.y)[keep]
        xs_all.append((x, y))
        ax.plot(x, y, marker="o", linestyle="-" if len(x) > 1 else "none", label=c.label)
    if slopes and xs_all:
        x0, y0 = xs_all[0][0], xs_all[0][1]
        xr = np.array([x0.min(), x0.max()]) if x0.max() > x0.min() else np.array([x0[0] / 2, x0[0]])
        for p in slopes:
            ax.plot(xr, y0.max() * (xr / xr.max()) ** p, ":", color="grey",
                    label=f"slope {p}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    return _finish(fig, ax, path, title, xlabel, ylabel)
