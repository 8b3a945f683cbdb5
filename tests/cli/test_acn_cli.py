"""`entangle-bench acn`: output on good archives and clean errors on bad ones."""

from __future__ import annotations

import re

import numpy as np
import pytest

from entangle_bench.cli import main
from entangle_bench.metrics.acn import acn_total


def perpendicular_pair() -> np.ndarray:
    """Two crossing straight lines of 11 points each, 2 mm apart (K=2, M=11)."""
    x = np.linspace(-0.05, 0.05, 11)
    zero = np.zeros_like(x)
    return np.stack([np.column_stack([x, zero, zero]), np.column_stack([zero, x, zero + 0.002])])


def test_prints_total_and_matrix(tmp_path, capsys):
    curves = perpendicular_pair()
    path = tmp_path / "pair.npz"
    np.savez(path, curves=curves)
    assert main(["acn", str(path)]) == 0
    out = capsys.readouterr().out
    total = float(re.search(r"total ACN: ([0-9.]+)", out).group(1))
    assert total == pytest.approx(acn_total(curves), abs=1e-4)
    assert 0.9 < total < 1.0
    assert "ACN matrix" in out and re.search(r"^\s+1\s+0\.9\d\d\s+0\.000$", out, re.MULTILINE)


def test_per_key_layout_and_local_summary(tmp_path, capsys):
    a, b = perpendicular_pair()
    path = tmp_path / "keys.npz"
    np.savez(path, second=b, first=a[:7])  # stored order, ragged lengths
    assert main(["acn", str(path), "--local-diameter", "0.02"]) == 0
    out = capsys.readouterr().out
    assert "curve 0: key 'second'" in out and "curve 1: key 'first'" in out
    assert "sphere diameter 20.0 mm" in out
    count_max = int(re.search(r"local filament count: mean [0-9.]+\s+max (\d+)", out).group(1))
    assert count_max == 2


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (None, "no such file"),
        (b"not a zip archive", "not an npz archive"),
        ({"curves": np.zeros((2, 5))}, r"key 'curves': expected shape \(K, M, 3\)"),
        ({"a": np.zeros((4, 2))}, r"key 'a': expected shape \(M, 3\)"),
        ({"curves": np.full((1, 3, 3), np.nan)}, r"key 'curves\[0\]': NaN or Inf"),
        ({"a": np.array([["x", "y", "z"]])}, "key 'a': expected real numbers"),
        ({"a": np.zeros((3, 3))}, "key 'a': zero-length segment"),
        ({}, "no curve arrays"),
    ],
)
def test_bad_files_give_exit_code_2(tmp_path, capsys, content, message):
    path = tmp_path / "bad.npz"
    if isinstance(content, bytes):
        path.write_bytes(content)
    elif isinstance(content, dict):
        np.savez(path, **content)
    assert main(["acn", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("entangle-bench: error: ")
    assert str(path) in err
    assert re.search(message, err), err


def test_a_text_file_named_npz_is_not_an_npz_archive(tmp_path, capsys):
    path = tmp_path / "notes.npz"
    path.write_text("curves: none\n")
    assert main(["acn", str(path)]) == 2
    err = capsys.readouterr().err
    assert "notes.npz: not an npz archive" in err and "pickle" not in err


def test_a_bad_local_diameter_fails_before_anything_is_printed(tmp_path, capsys):
    path = tmp_path / "pair.npz"
    np.savez(path, curves=perpendicular_pair())
    assert main(["acn", str(path), "--local-diameter", "-1"]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and "--local-diameter (m) = -1.0 is outside the allowed range (0, inf]" in captured.err
