"""The MPMNet network and the TorchScript module the solver loads.

Two layers, so that training and the solver run the same code:

- ``MPMNet``: the network proper, on batched, normalised tensors whose spatial size is a
  multiple of 4. A small CNN autoencoder (two stride-2 stages) encodes each history frame;
  a ConvLSTM runs over the T latent frames; the decoder (transposed convolutions) turns its
  last hidden state back into full resolution. The decoder also sees the last frame's
  first-stage features and, at full resolution, the last frame and the next step's masks:
  the change of a pressure field is smooth in the bulk but not where cells appear or
  disappear, and those are only known at full resolution.
- ``MPMNetModule``: the contract ``forward(history, history_active, next_active)`` in Pa,
  without a batch dimension, any spatial size. It normalises (``NORMALISATION``), pads to a
  multiple of 4, runs the network, crops, and assembles the prediction in Pa. ``predict`` is
  the same with a batch dimension and is what training calls.

Why two scales. From one step to the next a pressure field changes by 1e-3 to 1e-2 of its
size, so a network that sees only the fields divided by their size would have to resolve
differences of 1e-3 between inputs of order 1 to beat the previous step; a float32 network
trained for minutes does not. Each frame therefore also carries its change from the frame
before, divided by the size of the last change, and the network predicts the next change in
those units (predicting "the last change again" is then an output of order 1). A cell that
had no unknown in the last frame has no change to continue; there the network predicts the
value itself, in units of the field's size. Its last convolution starts at zero, so an
untrained module returns the last frame (the "previous step" warm start): training starts
from the trivial guess and has to improve on it.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Dict, List, Tuple

import torch
import torch.nn as nn
import torch.nn.functional as F

from mpmnet import FORMAT_VERSION

MODEL_FORMAT = "iqmpm-mpmnet"
EXTRA_FILE = "mpmnet.json"
#: The spatial size the network works on is padded to a multiple of this (two stride-2 stages).
PAD_MULTIPLE = 4
#: The change scale is at least this fraction of the value scale (a field at rest).
MIN_CHANGE_SCALE = 1e-4
#: The sentence that goes into mpmnet.json.
NORMALISATION = (
    "Per sample and field, values are divided by S = the largest |value| over the last "
    "history frame's active cells and frame-to-frame changes (on cells active in both frames) "
    "by D = the largest |last frame - frame before| there (S = 1 where the field is absent or "
    "zero, D >= 1e-4 S); the network predicts the next change in units of D, added to the "
    "last frame where the cell was active in it, and the value in units of S elsewhere; the "
    "result in Pa is multiplied by next_active.")


def _conv(dim: int):
    return nn.Conv2d if dim == 2 else nn.Conv3d


def _conv_transpose(dim: int):
    return nn.ConvTranspose2d if dim == 2 else nn.ConvTranspose3d


class ConvLSTMCell(nn.Module):
    """A convolutional LSTM cell: the four gates from one convolution of [input, hidden]."""

    def __init__(self, dim: int, in_channels: int, hidden: int, kernel: int):
        super().__init__()
        self.hidden = hidden
        self.gates = _conv(dim)(in_channels + hidden, 4 * hidden, kernel, padding=kernel // 2)

    def forward(self, x: torch.Tensor, h: torch.Tensor, c: torch.Tensor
                ) -> Tuple[torch.Tensor, torch.Tensor]:
        i, f, o, g = torch.chunk(self.gates(torch.cat([x, h], dim=1)), 4, dim=1)
        c = torch.sigmoid(f) * c + torch.sigmoid(i) * torch.tanh(g)
        h = torch.sigmoid(o) * torch.tanh(c)
        return h, c


class MPMNet(nn.Module):
    """The network on normalised tensors: frames [B, T, 3C, *s] (values, masks, changes)
    and next_active [B, C, *s] -> [B, 2C, *s]: the next change (first C channels) and the
    value where there is no last value (last C); s % 4 == 0."""

    def __init__(self, dim: int, channels: int = 3, widths: Tuple[int, int] = (16, 32),
                 hidden: int = 32, kernel: int = 3):
        super().__init__()
        if dim not in (2, 3):
            raise ValueError(f"dim must be 2 or 3, not {dim}")
        Conv, ConvT = _conv(dim), _conv_transpose(dim)
        w1, w2 = widths
        self.dim = dim
        self.channels = channels
        self.hidden = hidden
        self.encode1 = nn.Sequential(Conv(3 * channels, w1, 3, stride=2, padding=1), nn.GELU(),
                                     Conv(w1, w1, 3, padding=1), nn.GELU())
        self.encode2 = nn.Sequential(Conv(w1, w2, 3, stride=2, padding=1), nn.GELU(),
                                     Conv(w2, w2, 3, padding=1), nn.GELU())
        self.lstm = ConvLSTMCell(dim, w2, hidden, kernel)
        self.up1 = ConvT(hidden, w1, 2, stride=2)
        self.decode1 = nn.Sequential(Conv(2 * w1, w1, 3, padding=1), nn.GELU())
        self.up2 = ConvT(w1, w1, 2, stride=2)
        self.decode2 = nn.Sequential(Conv(w1 + 4 * channels, w1, 3, padding=1), nn.GELU(),
                                     Conv(w1, 2 * channels, 3, padding=1))
        last = self.decode2[-1]
        nn.init.zeros_(last.weight)
        nn.init.zeros_(last.bias)

    def forward(self, frames: torch.Tensor, next_active: torch.Tensor) -> torch.Tensor:
        B, T = frames.shape[0], frames.shape[1]
        x = frames.reshape([B * T] + list(frames.shape[2:]))
        f1 = self.encode1(x)
        f2 = self.encode2(f1)
        f2 = f2.reshape([B, T] + list(f2.shape[1:]))
        f1_last = f1.reshape([B, T] + list(f1.shape[1:]))[:, T - 1]
        h = torch.zeros([B, self.hidden] + list(f2.shape[3:]), dtype=frames.dtype,
                        device=frames.device)
        c = torch.zeros_like(h)
        for t in range(T):
            h, c = self.lstm(f2[:, t], h, c)
        y = self.decode1(torch.cat([self.up1(h), f1_last], dim=1))
        return self.decode2(torch.cat([self.up2(y), frames[:, T - 1], next_active], dim=1))


class MPMNetModule(nn.Module):
    """The module the solver loads: raw Pa in and out (see the module docstring)."""

    def __init__(self, net: MPMNet):
        super().__init__()
        self.net = net
        self.dim = net.dim
        self.channels = net.channels
        self.pad_multiple = PAD_MULTIPLE
        self.min_change_scale = MIN_CHANGE_SCALE

    def scales(self, history: torch.Tensor, history_active: torch.Tensor
               ) -> Tuple[torch.Tensor, torch.Tensor]:
        """The value scale S and the change scale D, each [B, C] (``NORMALISATION``)."""
        B, T = history.shape[0], history.shape[1]
        last = history[:, T - 1] * history_active[:, T - 1]
        peak = last.abs().reshape([B, self.channels, -1]).amax(dim=2)
        value = torch.where(peak > 0, peak, torch.ones_like(peak))
        if T < 2:
            return value, value
        both = history_active[:, T - 1] * history_active[:, T - 2]
        step = ((last - history[:, T - 2]) * both).abs().reshape([B, self.channels, -1])
        change = torch.maximum(step.amax(dim=2), value * self.min_change_scale)
        return value, change

    def predict(self, history: torch.Tensor, history_active: torch.Tensor,
                next_active: torch.Tensor) -> torch.Tensor:
        """Batched prediction in Pa: history, history_active [B, T, C, *s] (oldest first),
        next_active [B, C, *s] -> [B, C, *s], zero outside next_active."""
        B, T, C = history.shape[0], history.shape[1], self.channels
        size: List[int] = list(history.shape[3:])
        value, change = self.scales(history, history_active)
        value = value.reshape([B, 1, C] + [1] * self.dim)
        change = change.reshape([B, 1, C] + [1] * self.dim)
        fields = history * history_active
        steps = torch.zeros_like(fields)
        if T > 1:
            both = history_active[:, 1:] * history_active[:, :-1]
            steps = torch.cat([steps[:, :1], (fields[:, 1:] - fields[:, :-1]) * both], dim=1)
        frames = torch.cat([fields / value, history_active, steps / change], dim=2)
        pad: List[int] = []
        for d in range(self.dim - 1, -1, -1):  # F.pad lists the last dimension first
            pad += [0, (self.pad_multiple - size[d] % self.pad_multiple) % self.pad_multiple]
        frames = F.pad(frames.reshape([B * T, 3 * C] + size), pad)
        frames = frames.reshape([B, T] + list(frames.shape[1:]))
        out = self.net(frames, F.pad(next_active, pad))
        for d in range(self.dim):
            out = out.narrow(2 + d, 0, size[d])
        had = history_active[:, T - 1]
        continued = fields[:, T - 1] + out[:, :C] * change[:, 0]
        appearing = out[:, C:] * value[:, 0]
        return (had * continued + (1 - had) * appearing) * next_active

    def forward(self, history: torch.Tensor, history_active: torch.Tensor,
                next_active: torch.Tensor) -> torch.Tensor:
        """The contract: [T, C, *s], [T, C, *s], [C, *s] in Pa -> [C, *s] in Pa."""
        return self.predict(history.unsqueeze(0), history_active.unsqueeze(0),
                            next_active.unsqueeze(0))[0]


def build(dim: int, channels: int = 3) -> MPMNetModule:
    """The module with the default (small) sizes: widths 16, 32; ConvLSTM hidden 32, kernel 3."""
    return MPMNetModule(MPMNet(dim, channels))


def metadata(dim: int, fields: List[str], sequence_length: int, trained_on: List[str],
             validation: Dict) -> Dict:
    """The ``mpmnet.json`` extra file (contract in mpmnet/README.md)."""
    return {"format": MODEL_FORMAT, "format_version": FORMAT_VERSION, "dim": int(dim),
            "fields": list(fields), "sequence_length": int(sequence_length),
            "normalisation": NORMALISATION, "trained_on": list(trained_on),
            "validation": validation}


def _strict_json(value):
    """NaN and infinities as null: ``json.dumps`` would write NaN, which is not JSON and
    which a strict parser (nlohmann::json in the solver) refuses. A metric is NaN when no
    validation window had the field."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _strict_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_strict_json(v) for v in value]
    return value


def save(scripted: torch.jit.ScriptModule, path: Path, meta: Dict) -> None:
    """Save a scripted module with ``mpmnet.json`` in the archive."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps(_strict_json(meta), indent=1, sort_keys=True, allow_nan=False)
    torch.jit.save(scripted.eval(), str(path), _extra_files={EXTRA_FILE: text})


def export(module: MPMNetModule, path: Path, meta: Dict) -> torch.jit.ScriptModule:
    """Script the module and save it with ``mpmnet.json`` in the archive."""
    scripted = torch.jit.script(module.eval())
    save(scripted, path, meta)
    return scripted


def load(path: Path) -> Tuple[torch.jit.ScriptModule, Dict]:
    """A saved model and its ``mpmnet.json`` (as the solver would see them)."""
    extra = {EXTRA_FILE: ""}
    module = torch.jit.load(str(path), map_location="cpu", _extra_files=extra)
    text = extra[EXTRA_FILE]
    meta = json.loads(text.decode() if isinstance(text, bytes) else text) if text else {}
    return module.eval(), meta
