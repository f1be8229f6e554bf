"""Readers: clear errors naming the file and column; the CLI exits non-zero without traceback."""

import subprocess
from pathlib import Path

import numpy as np
import pytest

from compare.cli import main
from compare.io import CompareError, read_metrics, read_run, read_summary, read_table
from compare_synth import write_metrics, write_summary

REPO = Path(__file__).resolve().parents[2]
WRAPPER = REPO / "compare" / "compare"


def test_metrics_roundtrip(tmp_path):
    t = np.linspace(0, 1, 5)
    write_metrics(tmp_path, t, {"front_x": 2 * t})
    m = read_metrics(tmp_path)
    np.testing.assert_allclose(m.t, t)
    np.testing.assert_allclose(m.column("front_x"), 2 * t)


def test_missing_column_names_column_and_file(tmp_path):
    write_metrics(tmp_path, np.linspace(0, 1, 3), {"front_x": np.zeros(3)})
    with pytest.raises(CompareError) as info:
        read_metrics(tmp_path).column("height_left")
    assert "height_left" in str(info.value)
    assert str(tmp_path / "metrics.csv") in str(info.value)


def test_missing_time_column(tmp_path):
    (tmp_path / "metrics.csv").write_text("time,front_x\n0,1\n")
    with pytest.raises(CompareError, match=r"missing column 't'"):
        read_metrics(tmp_path)


def test_non_numeric_cell_is_located(tmp_path):
    (tmp_path / "metrics.csv").write_text("t,front_x\n0,1\n0.1,abc\n")
    with pytest.raises(CompareError, match=r"column 'front_x', data row 2: 'abc'"):
        read_metrics(tmp_path)


def test_unreadable_files(tmp_path):
    with pytest.raises(CompareError, match="cannot read .*nothing.csv"):
        read_table(tmp_path / "nothing.csv")
    (tmp_path / "summary.json").write_text("{not json")
    with pytest.raises(CompareError, match="summary.json: not valid JSON"):
        read_summary(tmp_path)
    (tmp_path / "bin.csv").write_bytes(b"\xff\xfe\x00\x81")
    with pytest.raises(CompareError, match="bin.csv"):
        read_table(tmp_path / "bin.csv")


def test_failed_run_is_read_without_metrics(tmp_path):
    write_summary(tmp_path, status="diverged at step 12")
    run = read_run(tmp_path, "iqmpm")
    assert not run.ok and run.metrics is None and run.status == "diverged at step 12"


def test_reference_csv_with_comments(tmp_path):
    (tmp_path / "r.csv").write_text("# Source: test\n# more\nT,Z\n0,1\n1,2\n")
    table = read_table(tmp_path / "r.csv")
    assert table.comments == ["Source: test", "more"]
    np.testing.assert_allclose(table.numbers("Z"), [1, 2])


def test_cli_missing_column_exits_nonzero_without_traceback(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    t = np.linspace(0, 1, 5)
    write_metrics(a, t, {"front_x": t})
    write_metrics(b, t, {"front_x": t})
    proc = subprocess.run([str(WRAPPER), "series", str(a), str(b), "--metric", "height_left"],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert "compare: error:" in proc.stderr
    assert "height_left" in proc.stderr and str(a / "metrics.csv") in proc.stderr
    assert "Traceback" not in proc.stderr


def test_cli_unreadable_file(tmp_path, capsys):
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "metrics.csv").write_bytes(b"\x00\xff\xfe")
    assert main(["series", str(tmp_path / "a"), str(tmp_path / "a")]) == 2
    err = capsys.readouterr().err
    assert "metrics.csv" in err and "Traceback" not in err


def test_cli_series_prints_errors(tmp_path, capsys):
    t = np.linspace(0, 1, 11)
    write_metrics(tmp_path / "a", t, {"front_x": 1.1 * (t + 1)})
    write_metrics(tmp_path / "b", t, {"front_x": t + 1})
    assert main(["series", str(tmp_path / "a"), str(tmp_path / "b")]) == 0
    out = capsys.readouterr().out
    assert "| front_x |" in out and "| 10.00 |" in out


def test_readme_holds_the_current_registry_table():
    from compare.registry import registry_markdown

    assert registry_markdown() in (REPO / "compare" / "README.md").read_text()
