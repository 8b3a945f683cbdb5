"""Stored PyElastica references of the multi-turn rod cases: present, current, converged, reproducible."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from entangle_bench.cli import main
from entangle_bench.errors import FileFormatError, ParameterError
from entangle_bench.rods import analytic as an
from entangle_bench.rods import references
from entangle_bench.rods.case import RodCase, load_case
from entangle_bench.rods.comparison import case_error, mirror_image
from entangle_bench.rods.references import (
    PERTURBATION_RAD,
    REFERENCE_ELEMENTS,
    StaleReferenceError,
    generate_reference,
    has_reference,
    load_reference,
    reference_folder,
    reference_key,
    stored_elements,
)

CASE_DIR = Path(__file__).resolve().parents[2] / "tasks" / "rod_cases"

#: Cases whose reference is stored (no closed form; the boundary-value solver fails or finds another branch),
#: with the measured PyElastica convergence: max distance / L between the 100- and 200-element runs, and
#: between the two finest runs.
STORED = {
    "coil12_sideways_gravity": 4.5e-4,
    "coil12_twisted_hanging": 1.7e-4,
    "coil12_vertical_plane_gravity": 3.3e-4,
    "coil5_planar_gravity": 2.2e-4,
    "coil5_sideways_gravity": 1.8e-4,
    "coil5_twisted_tilted_gravity": 3.4e-3,  # 200 vs 400: 8.3e-4 (second order); the reference is the 400 run
}


def _case(name: str) -> RodCase:
    return load_case(CASE_DIR / f"{name}.json")


def test_stored_cases_are_the_multi_turn_coils():
    stored = sorted(p.stem for p in CASE_DIR.glob("*.json") if has_reference(_case(p.stem)))
    assert stored == sorted(STORED)
    for name in STORED:
        case = _case(name)
        assert math.hypot(*case.intrinsic_curvature) * case.length >= 4 * math.pi  # at least two turns
        assert "Collisions are off" in case.description


@pytest.mark.parametrize("name", sorted(STORED))
def test_stored_reference_is_current_converged_and_documented(name):
    case = _case(name)
    counts = stored_elements(case)
    assert counts[-1] >= REFERENCE_ELEMENTS and 100 in counts
    reference = load_reference(case)
    settings = reference.settings
    assert settings["n_elements"] == counts[-1]
    assert settings["case_key"] == reference_key(case)
    assert settings["converged"] and settings["max_strain"] < 5e-4
    assert settings["perturbation_rad"] == PERTURBATION_RAD
    assert settings["pyelastica_version"] == "1.0.0"
    assert reference.engine == "pyelastica" and reference.wall_time_s > 0.0
    np.testing.assert_allclose(reference.centerline[0], case.base_position, atol=1e-12)
    length = np.sum(np.linalg.norm(np.diff(reference.centerline, axis=0), axis=1))
    assert length == pytest.approx(case.length, rel=2e-3)  # stretch below 5e-4, 201 chords of a coil
    # PyElastica's own convergence: the 100- and 200-element runs agree to the measured distance.
    coarse, fine = load_reference(case, 100), load_reference(case, 200)
    assert case_error(case, coarse.centerline, fine.centerline)[0] < 1.5 * STORED[name]


def test_twisted_coil_reference_converges_at_second_order():
    # 100 -> 200 -> 400 elements: differences 3.4e-3 and 8.3e-4 L (ratio 4.0), so the 400-element reference is
    # within about 3e-4 L of the converged shape.
    case = _case("coil5_twisted_tilted_gravity")
    runs = [load_reference(case, n).centerline for n in (100, 200, 400)]
    first, second = case_error(case, runs[0], runs[1])[0], case_error(case, runs[1], runs[2])[0]
    assert 3.0 < first / second < 5.0
    assert second < 1e-3


def test_planar_coil_reference_stays_planar_after_the_perturbation():
    # Started 0.05 rad out of plane, the 5 mm coil returns to its plane: the planar equilibrium is stable.
    case = _case("coil5_planar_gravity")
    reference = load_reference(case).centerline
    assert np.max(np.abs(reference[:, 1])) < 1e-8 * case.length
    np.testing.assert_allclose(mirror_image(case, reference), reference * [1, -1, 1], atol=1e-15)


def test_stale_or_missing_reference_is_refused():
    case = _case("coil5_sideways_gravity")
    edited = dataclasses.replace(case, youngs_modulus=0.9e6)
    assert has_reference(edited)  # same file name
    with pytest.raises(StaleReferenceError, match="regenerate"):
        load_reference(edited)
    load_reference(dataclasses.replace(case, description="reworded"))  # documentation only: still current
    with pytest.raises(FileFormatError, match="entangle-bench references"):
        load_reference(case, 123)
    with pytest.raises(ParameterError, match="not read from a file"):
        reference_folder(dataclasses.replace(case, source=""))
    assert not has_reference(dataclasses.replace(case, source=""))


def test_generate_reference_writes_settings_atomically(tmp_path, monkeypatch):
    case = dataclasses.replace(_case("coil5_sideways_gravity"), source=str(tmp_path / "probe.json"))
    result = generate_reference(case, 16)
    folder = tmp_path / "references"
    assert sorted(os.listdir(folder)) == ["coil5_sideways_gravity_pyelastica_16.npz"]
    assert stored_elements(case) == [16] and not has_reference(case)  # 16 < REFERENCE_ELEMENTS
    back = load_reference(case)
    np.testing.assert_array_equal(back.centerline, result.centerline)
    assert back.settings["case_json"] == json.loads(json.dumps(case.to_dict()))
    assert back.settings["machine"] and back.settings["created_utc"]
    monkeypatch.setattr(references, "MAX_TIME_PER_SLOWEST_PERIOD", 0.5)
    with pytest.raises(ParameterError, match="did not settle"):
        generate_reference(case, 16, folder=tmp_path / "never")
    assert not (tmp_path / "never").exists()


def test_references_cli_regenerates_into_the_case_folder(tmp_path, capsys):
    shutil.copy(CASE_DIR / "coil5_sideways_gravity.json", tmp_path)
    argv = ["references", "--cases", str(tmp_path / "coil5_sideways_gravity.json"), "--elements", "16"]
    assert main(argv) == 0
    assert "16 elements" in capsys.readouterr().out
    assert (tmp_path / "references" / "coil5_sideways_gravity_pyelastica_16.npz").exists()
    with pytest.raises(SystemExit):
        main(["references", "--cases", str(tmp_path / "coil5_sideways_gravity.json"), "--elements", "2"])


@pytest.mark.slow
def test_planar_coil_reference_matches_the_planar_elastica():
    # Independent check by the boundary-value solver (15 s): measured 1.1e-4 L, PyElastica's own error at 200
    # elements (a third of the 100-200 difference: 7e-5 L).
    case = _case("coil5_planar_gravity")
    bvp = an.planar_elastica_centerline(case)
    assert case_error(case, bvp, load_reference(case).centerline)[0] < 2e-4


@pytest.mark.slow
def test_regenerated_reference_matches_the_stored_one(tmp_path):
    # About a minute: rerun the 100-element run of one case and compare with the stored file.
    case = _case("coil12_twisted_hanging")
    fresh = generate_reference(case, 100, folder=tmp_path)
    stored = load_reference(case, 100)
    assert case_error(case, fresh.centerline, stored.centerline)[0] < 1e-8
