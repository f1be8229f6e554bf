"""The learned warm start end to end (issue 22): the solver writes a dataset, a tiny model
trained on it for a few seconds loads in the C++ solver through its plugin, runs, and the
run's results equal the `previous` warm start's to the solver's tolerance; models that do
not fit the scene are refused as bad input (exit 2). Needs IQMPM_BIN (ctest sets it)."""

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import torch

REPO = Path(__file__).resolve().parent.parent.parent
SCENE = REPO / "benchmarks" / "floating_block" / "floating_block.json"
BIN = os.environ.get("IQMPM_BIN")

pytestmark = pytest.mark.skipif(not BIN, reason="IQMPM_BIN is not set (ctest sets it)")


def iqmpm(*args, check=True):
    result = subprocess.run([BIN, "run", str(SCENE), "--quiet", "--threads", "1", "--set", "write_frames=false",
                             "--set", "solver.method=pcg", *args], capture_output=True, text=True)
    if check and result.returncode != 0:
        raise AssertionError(f"iqmpm {' '.join(args)} exited {result.returncode}: {result.stderr[-2000:]}")
    return result


def final_metrics(out):
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "ok", summary["status"]
    return summary["final_metrics"]


@pytest.fixture(scope="module")
def tiny_model(tmp_path_factory):
    """Two coarse runs of the floating block (split by resolution), 30 steps each, and a
    model trained on them for a few seconds."""
    root = tmp_path_factory.mktemp("learned")
    for name, dx in (("train", "0.05"), ("validation", "0.04")):
        iqmpm("--out", str(root / name), "--set", f"dx={dx}", "--set", "end_time=0.03", "--set", "dt_max=0.001",
              "--set", "write_pressure_fields=true")
        assert (root / name / "pressure_fields.h5").is_file()
    split = {"format": "iqmpm-mpmnet-split", "format_version": 1, "train": ["train"], "validation": ["validation"], "test": []}
    (root / "split.json").write_text(json.dumps(split))
    model = root / "tiny.pt"
    subprocess.run([sys.executable, str(REPO / "mpmnet" / "train.py"), "--split", str(root / "split.json"), "--out", str(model),
                    "--sequence-length", "2", "--epochs", "1", "--windows-per-epoch", "8", "--validation-windows", "4",
                    "--threads", "1"], check=True, capture_output=True)
    return root, model


def test_a_trained_model_warm_starts_the_solver_without_changing_results(tiny_model):
    root, model = tiny_model
    common = ("--set", "dx=0.05", "--set", "end_time=0.03", "--set", "dt_max=0.001", "--set", "solver.tolerance=1e-10")
    iqmpm("--out", str(root / "previous"), *common)
    iqmpm("--out", str(root / "learned"), *common, "--set", "solver.warm_start=learned", "--set", f"solver.model={model}")
    previous, learned = final_metrics(root / "previous"), final_metrics(root / "learned")
    assert previous.keys() == learned.keys()
    for key, value in previous.items():
        # The same solve to a relative residual of 1e-10 from another guess: the block moves
        # by round-off only (measured ~1e-13 relative after 30 steps).
        assert learned[key] == pytest.approx(value, rel=1e-7, abs=1e-9), key
    with open(root / "learned" / "steps.csv") as f:
        steps = list(csv.DictReader(f))
    assert len(steps) == 30 and float(steps[-1]["warm_start_s"]) > 0  # the network ran and was timed


def write_module(path, dim=2, fields=("fluid_pressure", "ghost_pressure", "interface"), version=1):
    class Last(torch.nn.Module):
        def forward(self, history: torch.Tensor, history_active: torch.Tensor, next_active: torch.Tensor) -> torch.Tensor:
            return history[-1] * next_active

    meta = {"format": "iqmpm-mpmnet", "format_version": version, "dim": dim, "fields": list(fields), "sequence_length": 2}
    torch.jit.save(torch.jit.script(Last()), str(path), _extra_files={"mpmnet.json": json.dumps(meta)})


@pytest.mark.parametrize("case, needle", [
    (dict(dim=3), "is for 3-D scenes, this scene is 2-D"),
    (dict(fields=("fluid_pressure", "ghost_pressure")), "the model's fields are [fluid_pressure, ghost_pressure]"),
    (dict(version=2), "not format iqmpm-mpmnet version 1"),
])
def test_a_model_that_does_not_fit_is_bad_input(tmp_path, case, needle):
    model = tmp_path / "model.pt"
    write_module(model, **case)
    out = tmp_path / "out"
    result = iqmpm("--out", str(out), "--set", "end_time=0.01", "--set", "solver.warm_start=learned",
                   "--set", f"solver.model={model}", check=False)
    assert result.returncode == 2, result.stderr
    assert needle in result.stderr and "solver.model" in result.stderr
    assert not (out / "summary.json").exists()  # nothing written


def test_a_file_that_is_no_model_is_bad_input(tmp_path):
    result = iqmpm("--out", str(tmp_path / "out"), "--set", "solver.warm_start=learned", "--set", f"solver.model={SCENE}", check=False)
    assert result.returncode == 2 and "not a TorchScript model" in result.stderr
