"""Rod-case files, rod results and the shared centerline helpers."""

from __future__ import annotations

import copy
import json
import os
from pathlib import Path

import numpy as np
import pytest

from entangle_bench.errors import FileFormatError, ParameterError
from entangle_bench.rods.case import (
    RodCase,
    RodResult,
    centerline_error,
    load_case,
    resample_centerline,
)

CASE_DIR = Path(__file__).resolve().parents[2] / "tasks" / "rod_cases"
CASE_FILES = sorted(CASE_DIR.glob("*.json"))

VALID = {
    "name": "probe",
    "description": "a test rod",
    "length": 0.3,
    "radius": 7e-4,
    "youngs_modulus": 1e6,
    "poisson_ratio": 0.5,
    "density": 1100.0,
    "gravity": [0.0, 0.0, -9.81],
    "base": {"position": [0.0, 0.0, 0.5], "direction": [0.0, 0.0, -1.0], "normal": [1.0, 0, 0]},
    "intrinsic_curvature": [0.0, 50.0],
    "intrinsic_twist": 0.0,
}


def _write(tmp_path: Path, data: object) -> Path:
    path = tmp_path / "case.json"
    path.write_text(json.dumps(data))
    return path


def test_case_files_load_and_are_described():
    assert len(CASE_FILES) == 13
    for path in CASE_FILES:
        case = load_case(path)
        assert case.name == path.stem
        assert len(case.description) > 20
        assert case.source == str(path)


def test_round_trip_through_json(tmp_path):
    case = load_case(_write(tmp_path, VALID))
    again = RodCase.from_dict(json.loads(json.dumps(case.to_dict())), source="again")
    assert again == case
    assert case.to_dict() == {**VALID, "base": {**VALID["base"], "normal": [1.0, 0.0, 0.0]}}


def test_derived_quantities():
    case = RodCase.from_dict(VALID)
    assert case.area == pytest.approx(np.pi * 7e-4**2, rel=1e-12)
    assert case.bending_stiffness == pytest.approx(1e6 * np.pi * 7e-4**4 / 4, rel=1e-12)
    assert case.shear_modulus == pytest.approx(1e6 / 3, rel=1e-12)
    frame = case.base_frame
    np.testing.assert_allclose(frame.T @ frame, np.eye(3), atol=1e-15)
    assert np.linalg.det(frame) == pytest.approx(1.0)
    np.testing.assert_allclose(frame[:, 2], [0.0, -1.0, 0.0], atol=1e-15)  # d2 = t x d1


def test_direction_and_normal_are_normalised():
    data = copy.deepcopy(VALID)
    data["base"]["direction"] = [0.0, 0.0, -4.0]
    data["base"]["normal"] = [0.5, 0.0, 0.0]
    case = RodCase.from_dict(data)
    assert case.base_direction == (0.0, 0.0, -1.0)
    assert case.base_normal == (1.0, 0.0, 0.0)


def _mutated(key: str, value: object) -> dict:
    data = copy.deepcopy(VALID)
    target = data
    parts = key.split(".")
    for part in parts[:-1]:
        target = target[part]
    if value is KeyError:
        del target[parts[-1]]
    else:
        target[parts[-1]] = value
    return data


BAD = [
    ("length", KeyError, "length", "missing"),
    ("intrinsic_twist", KeyError, "intrinsic_twist", "missing"),
    ("base.normal", KeyError, "base.normal", "missing"),
    ("length", "0.3", "length", "number"),
    ("poisson_ratio", True, "poisson_ratio", "number"),
    ("name", "", "name", "non-empty"),
    ("name", 3, "name", "string"),
    ("description", 5, "description", "string"),
    ("gravity", [0.0, -9.81], "gravity", "3 numbers"),
    ("intrinsic_curvature", [1.0, 2.0, 3.0], "intrinsic_curvature", "2 numbers"),
    ("base.position", "origin", "base.position", "list"),
    ("gravity", [0.0, "x", 0.0], "gravity[1]", "number"),
    ("length", 0.0, "length", "> 0"),
    ("radius", -1e-3, "radius", "> 0"),
    ("youngs_modulus", 0, "youngs_modulus", "> 0"),
    ("density", -5.0, "density", "> 0"),
    ("poisson_ratio", 0.6, "poisson_ratio", "(-1, 0.5]"),
    ("poisson_ratio", -1.0, "poisson_ratio", "(-1, 0.5]"),
    ("base.direction", [0.0, 0.0, 0.0], "base.direction", "non-zero"),
    ("base.normal", [0.0, 0.0, 0.0], "base.normal", "non-zero"),
    ("base.normal", [0.0, 0.6, -0.8], "base.normal", "perpendicular"),
    ("colour", "red", "colour", "unknown field"),
    ("base.orientation", [1, 0, 0], "base.orientation", "unknown field"),
    ("base", [0, 0, 0], "base", "object"),
]


@pytest.mark.parametrize(("key", "value", "field", "problem"), BAD)
def test_invalid_case_names_file_and_field(tmp_path, key, value, field, problem):
    path = _write(tmp_path, _mutated(key, value))
    with pytest.raises(FileFormatError) as info:
        load_case(path)
    message = str(info.value)
    assert str(path) in message
    assert field in message
    assert problem in message


def test_not_an_object_and_not_json(tmp_path):
    with pytest.raises(FileFormatError, match="JSON object"):
        load_case(_write(tmp_path, [1, 2]))
    bad = tmp_path / "broken.json"
    bad.write_text("{'length': 1")
    with pytest.raises(FileFormatError, match="broken.json.*not valid JSON"):
        load_case(bad)
    with pytest.raises(FileFormatError, match="missing.json"):
        load_case(tmp_path / "missing.json")


def test_direct_construction_is_checked():
    with pytest.raises(ParameterError, match="poisson_ratio"):
        RodCase.from_dict(VALID).__class__(
            name="x",
            length=1.0,
            radius=0.1,
            youngs_modulus=1.0,
            poisson_ratio=0.7,
            density=1.0,
            gravity=(0, 0, 0),
            base_position=(0, 0, 0),
            base_direction=(1, 0, 0),
            base_normal=(0, 1, 0),
        )


def test_result_npz_round_trip_is_atomic(tmp_path):
    points = np.cumsum(np.random.default_rng(1).normal(size=(11, 3)), axis=0)
    result = RodResult(points, "probe", 1.25, {"n_elements": 10, "converged": True})
    path = tmp_path / "sub" / "result.npz"
    result.save_npz(path)
    assert sorted(os.listdir(path.parent)) == ["result.npz"]
    back = RodResult.load_npz(path)
    np.testing.assert_array_equal(back.centerline, points)
    assert (back.engine, back.wall_time_s, back.settings) == ("probe", 1.25, result.settings)


def test_result_rejects_bad_input(tmp_path):
    with pytest.raises(ParameterError, match="centerline"):
        RodResult(np.zeros((5, 2)), "x", 0.0)
    with pytest.raises(ParameterError, match="wall_time_s"):
        RodResult(np.zeros((5, 3)), "x", -1.0)
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"not a zip")
    with pytest.raises(FileFormatError, match="junk.npz"):
        RodResult.load_npz(junk)
    partial = tmp_path / "partial.npz"
    np.savez(partial, centerline=np.zeros((3, 3)))
    with pytest.raises(FileFormatError, match="missing field 'engine'"):
        RodResult.load_npz(partial)


def _circle(angles: np.ndarray, radius: float) -> np.ndarray:
    return radius * np.column_stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)])


def test_resample_places_points_at_uniform_arclength():
    radius = 0.05
    uneven = np.sort(np.random.default_rng(2).uniform(0.0, 2.0, 60))
    uneven[0], uneven[-1] = 0.0, 2.0
    out = resample_centerline(_circle(uneven, radius), 41)
    expected = _circle(np.linspace(0.0, 2.0, 41), radius)
    assert np.max(np.linalg.norm(out - expected, axis=1)) < 1e-5 * radius
    linear = resample_centerline(_circle(uneven, radius), 41, method="linear")
    assert np.max(np.linalg.norm(linear - expected, axis=1)) < 3e-3 * radius
    line = np.array([[0.0, 0, 0], [1.0, 0, 0], [3.0, 0, 0]])
    np.testing.assert_allclose(resample_centerline(line, 4)[:, 0], [0.0, 1.0, 2.0, 3.0])
    with pytest.raises(ParameterError, match="repeated"):
        resample_centerline(np.zeros((4, 3)), 5)
    with pytest.raises(ParameterError, match="method"):
        resample_centerline(line, 4, method="quadratic")


def test_centerline_error_is_distance_over_length():
    a = _circle(np.linspace(0.0, 1.0, 51), 0.1)
    assert centerline_error(a, a, 0.1) == (0.0, 0.0)
    shifted = a + np.array([0.0, 0.0, 0.002])
    max_err, rms_err = centerline_error(a, shifted, 0.1)
    assert max_err == pytest.approx(0.02, rel=1e-9)
    assert rms_err == pytest.approx(0.02, rel=1e-9)
    # Different sample counts are compared at the same arclength fractions.
    coarse = _circle(np.linspace(0.0, 1.0, 21), 0.1)
    assert centerline_error(a, coarse, 0.1)[0] < 1e-6
