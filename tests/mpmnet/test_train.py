"""Training: the loss goes down, the CLI writes what it promises, runs are repeatable."""

import csv
import json

import numpy as np
import pytest
import torch

from mpmnet import evaluate, metrics, model, train
from mpmnet.data import Run, Windows

FIELDS = ["fluid_pressure", "ghost_pressure", "interface"]


def _loss(module, windows, pairs):
    history, history_active, target, next_active = windows.load(pairs)
    previous = history[:, -1] * history_active[:, -1] * next_active
    return metrics.improvement_loss(module.predict(history, history_active, next_active),
                                    target, previous, next_active)


def test_a_few_seconds_of_training_on_a_linear_field_reduce_the_loss(make_run):
    """Fields linear in time: the next change equals the last one. The untrained module
    (the previous step) has loss 1; a few dozen Adam steps must get well below that."""
    runs = [Run(make_run(f"lin{i}", kind="linear", cells=(16, 12), steps=20, seed=i))
            for i in range(2)]
    windows = Windows(runs, 3)
    torch.manual_seed(0)
    module = model.build(2)
    fixed = windows.evenly_spaced(8)
    with torch.no_grad():
        before = float(_loss(module, windows, fixed))
    optimiser = torch.optim.Adam(module.parameters(), lr=1e-3)
    rng = np.random.default_rng(0)
    for _ in range(40):
        loss = _loss(module, windows, windows.sample(4, rng))
        optimiser.zero_grad()
        loss.backward()
        optimiser.step()
    with torch.no_grad():
        after = float(_loss(module, windows, fixed))
    assert before == pytest.approx(1.0, abs=1e-3)
    assert after < 0.5 * before


@pytest.fixture
def family(make_run, write_split):
    """Two small sloshing runs to train on, one to validate on, one to test on."""
    train_runs = [make_run(f"slosh_{i}", kind="sloshing", cells=(20, 16), steps=24, dx=0.05,
                           seed=i) for i in range(2)]
    val = make_run("slosh_val", kind="sloshing", cells=(18, 16), steps=24, dx=0.05, seed=7)
    test = make_run("slosh_test", kind="sloshing", cells=(21, 15), steps=24, dx=0.05, seed=8)
    return write_split(train_runs, [val], [test])


def _train(split, out, *extra):
    return train.main(["--split", str(split), "--out", str(out), "--sequence-length", "3",
                       "--epochs", "2", "--windows-per-epoch", "12", "--validation-windows",
                       "6", "--threads", "1", "--seed", "3", *extra])


def _curves(path):
    with open(path) as fh:
        return [{k: v for k, v in row.items() if k != "elapsed_s"} for row in csv.DictReader(fh)]


def test_the_cli_writes_model_curves_and_metadata_and_is_deterministic(family, tmp_path):
    out = tmp_path / "a" / "m.pt"
    assert _train(family, out) == 0
    assert out.is_file()
    assert (tmp_path / "a" / "m.loss.png").stat().st_size > 1000
    rows = _curves(tmp_path / "a" / "m.loss.csv")
    assert [r["epoch"] for r in rows] == ["0", "1", "2"]
    assert rows[0]["fluid_pressure_model"] == rows[0]["fluid_pressure_previous_step"]

    module, meta = model.load(out)
    assert meta["dim"] == 2 and meta["sequence_length"] == 3 and meta["fields"] == FIELDS
    assert meta["trained_on"] == ["slosh_0", "slosh_1"]
    assert meta["validation"]["runs"] == ["slosh_val"]
    for f in FIELDS:
        assert set(meta["validation"]["relative_l2"][f]) == set(metrics.GUESSES)
    history = torch.rand(3, 3, 37, 21) * 1e3
    active = torch.ones(3, 3, 37, 21)
    next_active = (torch.rand(3, 37, 21) > 0.5).float()
    with torch.no_grad():
        y = module(history, active, next_active)
    assert y.shape == (3, 37, 21) and torch.all(y[next_active == 0] == 0)

    again = tmp_path / "b" / "m.pt"
    assert _train(family, again) == 0
    assert _curves(tmp_path / "b" / "m.loss.csv") == rows
    other_seed = tmp_path / "c" / "m.pt"
    assert _train(family, other_seed, "--seed", "4") == 0
    assert _curves(tmp_path / "c" / "m.loss.csv") != rows

    assert evaluate.main([str(out), "--split", str(family), "--windows", "4"]) == 0


def test_a_model_trained_on_a_field_constant_in_time_predicts_it(make_run, write_split,
                                                                  tmp_path):
    runs = [make_run(f"still_{i}", kind="constant", cells=(13, 11), steps=16, seed=i)
            for i in range(3)]
    split = write_split(runs[:2], runs[2:])
    out = tmp_path / "still.pt"
    assert _train(split, out) == 0
    module, _ = model.load(out)
    history, history_active, target, next_active = Run(runs[2]).window(5, 3)
    with torch.no_grad():
        y = module(*(torch.from_numpy(x) for x in (history, history_active, next_active)))
    error = np.linalg.norm(y.numpy() - target) / np.linalg.norm(target)
    assert error < 1e-4


def test_train_refuses_an_overlapping_split_with_exit_2(make_run, write_split, tmp_path, capsys):
    split = write_split([make_run("a", scene="dam")], [make_run("b", scene="dam")])
    out = tmp_path / "models" / "m.pt"
    assert _train(split, out) == 2
    assert "must not share" in capsys.readouterr().err
    assert not out.parent.exists()  # nothing written


def test_train_refuses_runs_too_short_for_the_history(make_run, write_split, tmp_path, capsys):
    split = write_split([make_run("a", steps=3)], [make_run("b", steps=10)])  # T = 3 needs 4
    assert _train(split, tmp_path / "m.pt") == 2
    assert "train runs have no window of 3+1 consecutive steps" in capsys.readouterr().err


def test_evaluate_refuses_runs_of_another_dimension(make_run, tmp_path, capsys):
    path = tmp_path / "m.pt"
    model.export(model.build(2), path, model.metadata(2, FIELDS, 3, ["x"], {}))
    cube = make_run("cube", cells=(5, 5, 5), steps=8)
    assert evaluate.main([str(path), str(cube)]) == 2
    assert "3-D" in capsys.readouterr().err
    flat = make_run("flat", cells=(9, 7), steps=8)
    assert evaluate.main([str(path), str(flat), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["windows"] == 5
    # the untrained model is the previous step
    for f in FIELDS:
        errors = result["relative_l2"][f]
        assert errors["model"] == pytest.approx(errors["previous_step"], rel=1e-6)
