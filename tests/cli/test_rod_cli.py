"""`entangle-bench rod` and `entangle-bench compare`, in-process."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from entangle_bench.cli import main
from entangle_bench.rods.case import RodResult, load_case

CASE_DIR = Path(__file__).resolve().parents[2] / "tasks" / "rod_cases"


def test_rod_writes_centerline_and_settings(tmp_path, capsys):
    out = tmp_path / "soft.npz"
    case = load_case(CASE_DIR / "soft_cantilever.json")
    assert main(["rod", str(CASE_DIR / "soft_cantilever.json"), "--out", str(out), "--preset", "fast"]) == 0
    result = RodResult.load_npz(out)
    assert result.centerline.shape == (201, 3)
    np.testing.assert_allclose(result.centerline[0], case.base_position, atol=1e-12)
    length = np.sum(np.linalg.norm(np.diff(result.centerline, axis=0), axis=1))
    assert length == pytest.approx(case.length, rel=1e-3)  # inextensible, base to tip
    assert result.settings["preset"] == "fast" and result.settings["n_segments"] == 12
    assert result.wall_time_s > 0.0
    assert "soft_cantilever: mujoco (12 segments)" in capsys.readouterr().out


def test_rod_segments_and_pyelastica_engine(tmp_path):
    case_file = str(CASE_DIR / "stiff_cantilever.json")
    mj, pe = tmp_path / "mj.npz", tmp_path / "pe.npz"
    assert main(["rod", case_file, "--out", str(mj), "--segments", "10", "--points", "51"]) == 0
    assert main(["rod", case_file, "--out", str(pe), "--engine", "pyelastica", "--segments", "12"]) == 0
    a, b = RodResult.load_npz(mj), RodResult.load_npz(pe)
    assert a.settings["n_segments"] == 10 and a.centerline.shape == (51, 3)
    assert b.engine == "pyelastica" and b.settings["n_elements"] == 12
    # Two engines, same small-deflection cantilever: tips agree to 1e-3 L (deflection is 9e-3 L).
    assert np.linalg.norm(a.centerline[-1] - b.centerline[-1]) < 1e-3 * 0.035


@pytest.mark.parametrize(
    "edit, field",
    [
        (lambda d: d.pop("radius"), "'radius'"),
        (lambda d: d.update(length="long"), "length"),
        (lambda d: d["base"].update(normal=[1.0, 0.0, 0.0]), "base.normal"),
        (lambda d: d.update(colour="red"), "'colour'"),
    ],
    ids=["missing", "wrong-type", "not-perpendicular", "unknown"],
)
def test_bad_case_file_exits_2_naming_the_field(tmp_path, capsys, edit, field):
    data = json.loads((CASE_DIR / "soft_cantilever.json").read_text())
    edit(data)
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(data))
    out = tmp_path / "never.npz"
    assert main(["rod", str(bad), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "bad.json" in err and field in err
    assert not out.exists()


def test_compare_one_case_writes_table(tmp_path, capsys):
    cases = tmp_path / "cases"
    cases.mkdir()
    shutil.copy(CASE_DIR / "soft_cantilever.json", cases)
    out = tmp_path / "out"
    argv = ["compare", "--cases", str(cases), "--elements", "6,12", "--out", str(out), "--no-progress"]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "soft_cantilever" in printed and "planar_elastica" in printed
    table = pd.read_csv(out / "compare.csv")
    assert len(table) == 1
    row = table.iloc[0]
    assert row["mujoco_segments"] == 16 and row["pyelastica_elements"] == 12
    # Both engines near the BVP; PyElastica's error falls with resolution (second order: ~4x).
    assert row["mujoco_vs_analytic_max"] < 3e-3
    assert row["mujoco_vs_pyelastica_max"] < 5e-3
    assert row["pyelastica_coarse_vs_analytic_max"] > 2.0 * row["pyelastica_vs_analytic_max"]
    assert row["mujoco_wall_s"] > 0.0 and row["pyelastica_wall_s"] > 0.0


def test_compare_uses_stored_references(tmp_path, capsys):
    # A multi-turn coil: the stored PyElastica runs (100 and 200 elements) are read, not rerun, and the 3D
    # boundary-value solver is not attempted.
    cases = tmp_path / "cases"
    cases.mkdir()
    name = "coil12_twisted_hanging"
    shutil.copy(CASE_DIR / f"{name}.json", cases)
    (cases / "references").mkdir()
    for n in (100, 200):
        shutil.copy(CASE_DIR / "references" / f"{name}_pyelastica_{n}.npz", cases / "references")
    out = tmp_path / "out"
    argv = ["compare", "--cases", str(cases), "--representation", "hinges", "--segments", "16"]
    assert main([*argv, "--out", str(out), "--no-progress"]) == 0
    assert "pyelastica_200" in capsys.readouterr().out
    row = pd.read_csv(out / "compare.csv").iloc[0]
    assert row["reference"] == "pyelastica_200" and bool(row["pyelastica_stored"])
    assert (row["pyelastica_coarse_elements"], row["pyelastica_elements"]) == (100, 200)
    assert row["mujoco_vs_reference_max"] == pytest.approx(3.3e-2, rel=0.05)  # measured 3.3e-2 (hinges, 16)
    assert row["mujoco_vs_reference_max"] == row["mujoco_vs_pyelastica_max"]
    assert row["pyelastica_coarse_vs_fine_max"] == pytest.approx(1.72e-4, rel=0.01)
    assert "not attempted" in row["note"] and np.isnan(row["mujoco_vs_analytic_max"])


def test_compare_empty_folder_exits_2(tmp_path, capsys):
    assert main(["compare", "--cases", str(tmp_path), "--out", str(tmp_path / "o")]) == 2
    assert "no rod case files" in capsys.readouterr().err


def test_packaged_cases_are_named_like_tasks_from_any_folder(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["rod", "soft_cantilever", "--out", "soft.npz", "--preset", "fast", "--points", "11"]) == 0
    assert RodResult.load_npz(tmp_path / "soft.npz").centerline.shape == (11, 3)
    assert "soft_cantilever: mujoco" in capsys.readouterr().out


def test_a_path_means_a_file_relative_to_the_current_folder(tmp_path, monkeypatch, capsys):
    data = json.loads((CASE_DIR / "stiff_cantilever.json").read_text())
    data["name"] = "mine"
    (tmp_path / "soft_cantilever").write_text(json.dumps(data))  # a file wins over the packaged case's name
    monkeypatch.chdir(tmp_path)
    assert main(["rod", "soft_cantilever", "--out", "mine.npz", "--points", "11"]) == 0
    assert capsys.readouterr().out.startswith("mine: mujoco")


@pytest.mark.parametrize(("argument", "message"), [
    ("no_such_case", "unknown rod case 'no_such_case'; known: arc_zero_gravity"),
    ("cases/soft_cantilever.json", "no such rod-case file; packaged rod cases, by name: arc_zero_gravity"),
])
def test_unknown_rod_case_lists_the_packaged_ones(tmp_path, monkeypatch, capsys, argument, message):
    monkeypatch.chdir(tmp_path)
    assert main(["rod", argument, "--out", "x.npz"]) == 2
    assert message in capsys.readouterr().err and not (tmp_path / "x.npz").exists()
