"""Splits by scene and resolution: the split file is checked, overlaps and mixes refused."""

import json
import subprocess
import sys

import pytest

from mpmnet import MPMNetError
from mpmnet.splits import load_split, main
from conftest import REPO


def test_a_good_split_loads(make_run, write_split, capsys):
    a1 = make_run("a_dx1", scene="a", dx=0.01)
    a2 = make_run("a_dx2", scene="a", dx=0.02)  # the same scene at another resolution
    b = make_run("b_dx1", scene="b", dx=0.01)
    c = make_run("c_dx1", scene="c", dx=0.01)
    path = write_split([a1, b], [a2], [c])
    split = load_split(path)
    assert [r.name for r in split.train] == ["a_dx1", "b_dx1"]
    assert [r.name for r in split.validation] == ["a_dx2"]
    assert [r.name for r in split.test] == ["c_dx1"]
    assert split.dim == 2 and split.fields == ["fluid_pressure", "ghost_pressure", "interface"]
    assert main([str(path)]) == 0
    out = capsys.readouterr().out
    assert "validation" in out and "a_dx2" in out


def test_a_scene_and_dx_in_two_splits_is_refused(make_run, write_split):
    first = make_run("dam_a", scene="dam", dx=0.01)
    second = make_run("dam_b", scene="dam", dx=0.01, seed=1)  # another run, same pair
    path = write_split([first], [second])
    with pytest.raises(MPMNetError, match="scene 'dam' at dx 0.01 is in both train"):
        load_split(path)
    test_only = write_split([make_run("other", scene="other")], [first], [second],
                            name="split2.json")
    with pytest.raises(MPMNetError, match="both validation .* and test"):
        load_split(test_only)


@pytest.mark.parametrize("change, message", [
    ({"format_version": 2}, "format_version"),
    ({"format_version": "1"}, "format_version"),
    ({"format": "something"}, "format"),
    ({"valdation": []}, "unknown keys"),
    ({"validation": []}, "validation\" is empty"),
    ({"test": "c"}, "\"test\" should be a list"),
])
def test_a_split_file_of_the_wrong_format_is_refused_with_exit_2(make_run, write_split, capsys,
                                                                change, message):
    path = write_split([make_run("a")], [make_run("b")], change=change)
    with pytest.raises(MPMNetError, match=message):
        load_split(path)
    assert main([str(path)]) == 2
    assert message.split(" ")[0].strip("\"") in capsys.readouterr().err


def test_a_dimension_mix_is_refused(make_run, write_split):
    path = write_split([make_run("flat")], [make_run("cube", cells=(4, 4, 4))])
    with pytest.raises(MPMNetError, match="dimensions"):
        load_split(path)


def test_the_cli_exits_2_on_an_overlap(make_run, write_split):
    run = make_run("a")
    doc_path = write_split([run], [make_run("a2", scene="a")])
    result = subprocess.run([sys.executable, str(REPO / "mpmnet" / "splits.py"), str(doc_path)],
                            capture_output=True, text=True)
    assert result.returncode == 2, result.stderr
    assert "must not share a (scene_name, dx) pair" in result.stderr
    json.loads(doc_path.read_text())  # the file itself is untouched


def test_run_paths_can_be_relative_to_a_data_root(make_run, tmp_path):
    """A split file kept apart from the data (e.g. in the repository) names runs relative
    to --data-root."""
    make_run("a")
    make_run("b")
    elsewhere = tmp_path / "repo" / "splits"
    elsewhere.mkdir(parents=True)
    path = elsewhere / "family.json"
    path.write_text(json.dumps({"format": "iqmpm-mpmnet-split", "format_version": 1,
                                "train": ["a"], "validation": ["b"], "test": []}))
    with pytest.raises(MPMNetError, match="no such file"):
        load_split(path)
    assert [r.name for r in load_split(path, tmp_path).train] == ["a"]
    assert main([str(path), "--data-root", str(tmp_path)]) == 0
