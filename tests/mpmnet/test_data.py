"""Reading pressure_fields.h5 into windows: consecutive steps of one run, the file checked."""

import h5py
import numpy as np
import pytest

import synth
from mpmnet import MPMNetError
from mpmnet.data import Run, Windows, open_runs


def _numbered_run(tmp_path, name, step, cells=(5, 4), run_id=0):
    """A run whose every value is 1000 * run_id + the row's step number (so a window tells
    which run and which steps it came from); the first cell of field 1 is inactive."""
    S = len(step)
    fields = np.zeros((S, 3) + cells, np.float32)
    value = 1000 * run_id + np.asarray(step, np.float32)
    fields[:] = value.reshape((S,) + (1,) * (1 + len(cells)))
    active = np.ones(fields.shape, np.uint8)
    active[:, 1, 0, 0] = 0
    return synth.write_pressure_fields(tmp_path / name, fields, active, dx=0.01,
                                       scene_name=name, step=step)


def test_windows_are_consecutive_steps_of_one_run(tmp_path):
    steps_a = [1, 2, 3, 5, 6, 7, 8, 9, 11]  # gaps after 3 and 9
    steps_b = [20, 21, 22, 23]
    runs = [Run(_numbered_run(tmp_path, "a", steps_a, run_id=1)),
            Run(_numbered_run(tmp_path, "b", steps_b, run_id=2))]
    T = 2
    ws = Windows(runs, T)
    # a: rows 0 (steps 1,2,3), 3 (5,6,7), 4 (6,7,8), 5 (7,8,9); b: rows 0 and 1
    assert sorted(map(tuple, ws.pairs.tolist())) == [(0, 0), (0, 3), (0, 4), (0, 5), (1, 0),
                                                     (1, 1)]
    for r, s in ws.pairs:
        history, history_active, target, next_active = runs[r].window(s, T)
        values = [h[0, 0, 0] for h in history] + [target[0, 0, 0]]
        run_id, first = divmod(values[0], 1000)
        assert all(divmod(v, 1000)[0] == run_id for v in values)  # one run
        assert np.array_equal(np.diff(values), np.ones(T))  # consecutive steps
        assert history.shape == (T, 3, 5, 4) and target.shape == (3, 5, 4)
        assert history[:, 1, 0, 0].tolist() == [0, 0] and target[1, 0, 0] == 0  # masked
        assert history_active[:, 1, 0, 0].tolist() == [0, 0] and next_active[1, 0, 0] == 0


def test_batches_group_runs_of_one_size(tmp_path, make_run):
    runs = open_runs([make_run("a", cells=(8, 6), steps=12), make_run("b", cells=(10, 6),
                                                                          steps=12)])
    ws = Windows(runs, 3)
    pairs = ws.sample(len(ws), np.random.default_rng(0))
    seen = 0
    for batch in ws.batches(pairs, 4, np.random.default_rng(1)):
        assert len({runs[r].cells for r in batch[:, 0]}) == 1
        history, _, target, _ = ws.load(batch)
        assert history.shape[:3] == (len(batch), 3, 3) and target.shape[0] == len(batch)
        seen += len(batch)
    assert seen == len(ws) == 2 * (12 - 3)


@pytest.mark.parametrize("fixed_strings", [False, True])
def test_string_attributes_of_either_kind_are_read(make_run, fixed_strings):
    run = Run(make_run("kinds", scene="dam break", fixed_strings=fixed_strings))
    assert run.scene_name == "dam break" and run.fields[2] == "interface"


def test_three_d_run_reads(make_run):
    run = Run(make_run("cube", kind="sloshing", cells=(6, 5, 7), steps=6))
    assert run.dim == 3 and run.cells == (6, 5, 7) and run.scene_name == "cube"
    assert run.fields == ["fluid_pressure", "ghost_pressure", "interface"]
    history, history_active, target, next_active = run.window(0, 4)
    assert history.shape == (4, 3, 6, 5, 7) and target.shape == (3, 6, 5, 7)
    assert len(run.window_starts(4)) == 2


@pytest.mark.parametrize("attr, value, message", [
    ("format", "something-else", "format"),
    ("format_version", np.int32(2), "format_version 2"),
    ("units", np.bytes_("bar"), "units"),
    ("dim", np.int32(4), "dim should be 2 or 3"),
    ("cells", np.array([16, 13], np.int32), "shape"),
])
def test_a_file_off_the_contract_is_refused(make_run, attr, value, message):
    folder = make_run("bad")
    with h5py.File(folder / "pressure_fields.h5", "r+") as f:
        f.attrs[attr] = value
    with pytest.raises(MPMNetError, match=message):
        Run(folder)


def test_a_missing_run_is_refused(tmp_path):
    with pytest.raises(MPMNetError, match="no such file"):
        Run(tmp_path / "nowhere")


def test_runs_of_two_dimensions_are_refused(make_run):
    with pytest.raises(MPMNetError, match="dimensions"):
        open_runs([make_run("flat"), make_run("cube", cells=(4, 4, 4))])
