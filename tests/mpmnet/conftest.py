"""Tests of MPMNet (the Python half): the repository root and this folder on sys.path,
torch on one thread, and a factory of synthetic runs and split files."""

import json
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
REPO = HERE.parent.parent
for p in (str(REPO), str(HERE)):
    if p not in sys.path:
        sys.path.insert(0, p)

import mpmnet  # noqa: E402,F401  (before torch: sets OMP_WAIT_POLICY)
import torch  # noqa: E402

torch.set_num_threads(1)

import synth  # noqa: E402


@pytest.fixture
def make_run(tmp_path):
    """make_run(name, kind="linear", cells=(16, 12), steps=30, dx=0.01, scene=None, **kw)
    writes tmp_path/name/pressure_fields.h5 and returns the folder."""

    def make(name, kind="linear", cells=(16, 12), steps=30, dx=0.01, scene=None, step=None,
             seed=0, **kw):
        if kind == "linear":
            fields, active = synth.linear_fields(cells, steps, dx, seed=seed)
        elif kind == "constant":
            fields, active = synth.constant_fields(cells, steps, dx, seed=seed)
        elif kind == "sloshing":
            fields, active = synth.sloshing_fields(cells, steps, dx, seed=seed)
        else:
            raise ValueError(kind)
        folder = tmp_path / name
        synth.write_pressure_fields(folder, fields, active, dx=dx,
                                    scene_name=scene or name, step=step, **kw)
        return folder

    return make


@pytest.fixture
def write_split(tmp_path):
    """write_split(train, validation, test=(), change=None) -> path of a split file whose
    entries are the folders' paths relative to tmp_path; ``change`` overrides keys."""

    def write(train, validation, test=(), name="split.json", change=None):
        rel = lambda folders: [str(Path(f).relative_to(tmp_path)) for f in folders]  # noqa: E731
        doc = {"format": "iqmpm-mpmnet-split", "format_version": 1,
               "train": rel(train), "validation": rel(validation), "test": rel(test)}
        doc.update(change or {})
        path = tmp_path / name
        path.write_text(json.dumps(doc))
        return path

    return write
