"""Stored reference equilibria of the rod cases: PyElastica at >= 200 elements, written once and read by tests.

Curled rods hanging in gravity have no closed form. On the multi-turn coils the 3D boundary-value solver
(`analytic.kirchhoff_centerline`) does not converge (measured: out of memory at its node limit after
150 s, or more than 5 minutes), and the planar one finds the planar equilibrium even where that is a saddle
(coil12_vertical_plane_gravity). Their reference is a PyElastica run (`elastica_engine.solve_elastica`:
second-order clamp, shear/stretch stiffened 20x) at REFERENCE_ELEMENTS elements or more; coarser runs
(CONVERGENCE_ELEMENTS, 50) measure PyElastica's own convergence: at second order the finest run is off by
about a third of its difference from the run with half the elements. The reference of a case is its finest
stored run (`load_reference`). Such runs cost minutes each, so the centerlines are stored as small NPZ
files (`RodResult`, 201 points, about 12 KB) in a `references` folder beside the case files, named
`<case>_pyelastica_<elements>.npz`. Each file's settings hold the case itself and the hash of its physical
content (`reference_key`: every field but the description), the solver settings, the wall time, the
PyElastica version and the machine; a case edited after its reference was made is refused
(`StaleReferenceError`) rather than compared with a shape that belongs to another case.

Branch: every reference starts from the rest shape turned PERTURBATION_RAD out of its bending plane, so
that a case symmetric about that plane cannot settle on an unstable planar equilibrium (a saddle); on cases
whose planar equilibrium is stable the relaxation returns to it.

Regenerate with `entangle-bench references` (every stored run of every case) or
`entangle-bench references --cases tasks/rod_cases/NAME.json --elements 100,200`.
"""

from __future__ import annotations

import datetime
import hashlib
import json
import os
import platform
from importlib.metadata import version
from pathlib import Path

from entangle_bench.errors import FileFormatError, ParameterError
from entangle_bench.rods.case import RodCase, RodResult
from entangle_bench.rods.elastica_engine import slowest_frequency, solve_elastica

#: Elements of the stored reference.
REFERENCE_ELEMENTS = 200

#: Elements of the coarser run that measures the reference's own convergence.
CONVERGENCE_ELEMENTS = 100

#: Out-of-plane turn (rad over the length) of every reference's start shape (see module docstring).
PERTURBATION_RAD = 0.05

#: Relaxation limit in units of 1 / omega_slow (`elastica_engine.slowest_frequency`): multi-turn coils hanging
#: in gravity have slower, overdamped modes than the straight-rod estimate (coil12_sideways_gravity needs
#: 6.6 s simulated, 62 / omega_slow), so the limit is 200 instead of the solver's default 60.
MAX_TIME_PER_SLOWEST_PERIOD = 200.0

#: Points of a stored centerline.
POINTS = 201

#: Name of the folder beside the case files.
FOLDER_NAME = "references"


class StaleReferenceError(FileFormatError):
    """A stored reference was computed for different case content than the case now holds."""


def reference_key(case: RodCase) -> str:
    """Short hash (hex) of the case's physical content: every field of its file except the description."""
    data = case.to_dict()
    data.pop("description", None)
    return hashlib.sha1(json.dumps(data, sort_keys=True).encode()).hexdigest()[:12]


def reference_folder(case: RodCase) -> Path:
    """The `references` folder beside the case's file; ParameterError for a case not read from a file."""
    if not case.source or case.source.startswith("<"):
        raise ParameterError(f"case {case.name!r} was not read from a file, so it has no reference folder")
    return Path(case.source).parent / FOLDER_NAME


def reference_path(case: RodCase, n_elements: int, folder: Path | None = None) -> Path:
    """Path of the stored PyElastica reference of `case` at `n_elements` elements."""
    return Path(folder or reference_folder(case)) / f"{case.name}_pyelastica_{int(n_elements)}.npz"


def stored_elements(case: RodCase, folder: Path | None = None) -> list[int]:
    """Element counts of the stored references of `case`, ascending (empty if none)."""
    folder = Path(folder or reference_folder(case))
    prefix = f"{case.name}_pyelastica_"
    counts = []
    for path in folder.glob(f"{prefix}*.npz"):
        suffix = path.stem[len(prefix) :]
        if suffix.isdigit():
            counts.append(int(suffix))
    return sorted(counts)


def load_reference(case: RodCase, n_elements: int | None = None, folder: Path | None = None) -> RodResult:
    """The stored run of `case` at `n_elements` (default: the finest stored one, the case's reference).

    FileFormatError if absent, StaleReferenceError if computed for other case content.
    """
    if n_elements is None:
        stored = stored_elements(case, folder)
        n_elements = stored[-1] if stored else REFERENCE_ELEMENTS
    path = reference_path(case, n_elements, folder)
    if not path.exists():
        raise FileFormatError(
            f"{path}: no stored reference for case {case.name!r} at {n_elements} elements; "
            f"make it with `entangle-bench references --cases {case.source} --elements {n_elements}`"
        )
    result = RodResult.load_npz(path)
    stored_key = result.settings.get("case_key")
    if stored_key != reference_key(case):
        raise StaleReferenceError(
            f"{path}: computed for other content of case {case.name!r} (key {stored_key}, case now "
            f"{reference_key(case)}); regenerate it with `entangle-bench references --cases {case.source}`"
        )
    return result


def has_reference(case: RodCase, folder: Path | None = None) -> bool:
    """True if `case` has a stored run with at least REFERENCE_ELEMENTS elements (stale or not)."""
    try:
        stored = stored_elements(case, folder)
    except ParameterError:
        return False
    return bool(stored) and stored[-1] >= REFERENCE_ELEMENTS


def generate_reference(
    case: RodCase,
    n_elements: int = REFERENCE_ELEMENTS,
    folder: Path | None = None,
    perturbation: float = PERTURBATION_RAD,
    progress: bool = False,
) -> RodResult:
    """Run PyElastica on `case` at `n_elements` and store the result atomically; return it.

    Raises ParameterError (and writes nothing) if the run diverged or did not settle.
    """
    max_time_s = MAX_TIME_PER_SLOWEST_PERIOD / slowest_frequency(case)
    result = solve_elastica(
        case, n_elements, n_output=POINTS, perturbation=perturbation, max_time_s=max_time_s, progress=progress
    )
    if not result.settings["converged"]:
        raise ParameterError(
            f"PyElastica did not settle on case {case.name!r} at {n_elements} elements within "
            f"{result.settings['sim_time_s']:.3g} s simulated; no reference written"
        )
    settings = {
        **result.settings,
        "case_key": reference_key(case),
        "case_json": case.to_dict(),
        "pyelastica_version": version("pyelastica"),
        "numpy_version": version("numpy"),
        "python_version": platform.python_version(),
        "machine": f"{platform.system()} {platform.machine()}, {os.cpu_count()} CPUs",
        "created_utc": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
    }
    stored = RodResult(result.centerline, result.engine, result.wall_time_s, settings)
    stored.save_npz(reference_path(case, n_elements, folder))
    return stored
