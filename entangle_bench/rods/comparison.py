"""Rod-case comparison: the MuJoCo filament against PyElastica and the analytic/BVP reference.

For each case, `compare_case` solves the case with MuJoCo (a preset, optionally another representation),
with PyElastica at two resolutions (the finer one is the reference; the coarser one measures PyElastica's
own convergence) and with `analytic.reference_centerline`, and returns one table row of max and RMS
centerline distances divided by L plus the wall times. `cached_result` stores reference solutions as NPZ
files keyed by the case content, so repeated studies do not recompute them.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
from pathlib import Path
from typing import Any

from entangle_bench.config import check_range
from entangle_bench.errors import FileFormatError, ParameterError
from entangle_bench.presets import DEFAULT_PRESET
from entangle_bench.rods.analytic import reference_centerline
from entangle_bench.rods.case import RodCase, RodResult, centerline_error
from entangle_bench.rods.elastica_engine import solve_elastica
from entangle_bench.rods.representations import solve_representation

#: Points of every compared centerline.
POINTS = 201


def case_key(case: RodCase) -> str:
    """Short hash (hex) of the case's content: cached results are valid for identical cases only."""
    text = json.dumps(case.to_dict(), sort_keys=True)
    return hashlib.sha1(text.encode()).hexdigest()[:12]


def analytic_result(case: RodCase) -> RodResult:
    """`analytic.reference_centerline` as a RodResult (method and wall time in the settings)."""
    start = time.perf_counter()
    points, method = reference_centerline(case, POINTS)
    return RodResult(points, "analytic", time.perf_counter() - start, {"method": method})


def pyelastica_result(case: RodCase, n_elements: int) -> RodResult:
    """PyElastica equilibrium with `n_elements` elements at POINTS points."""
    return solve_elastica(case, n_elements, n_output=POINTS)


def cached_result(case: RodCase, engine: str, n_elements: int, cache_dir: Path | None) -> RodResult:
    """Reference result of `engine` ("analytic" or "pyelastica"), read from or written to `cache_dir`."""
    if engine not in ("analytic", "pyelastica"):
        raise ParameterError(f"engine = {engine!r} is not allowed; choose 'analytic' or 'pyelastica'")

    def solve() -> RodResult:
        return analytic_result(case) if engine == "analytic" else pyelastica_result(case, n_elements)

    if cache_dir is None:
        return solve()
    suffix = "" if engine == "analytic" else f"_{n_elements}"
    path = Path(cache_dir) / f"{case.name}_{engine}{suffix}_{case_key(case)}.npz"
    if path.exists():
        try:
            return RodResult.load_npz(path)
        except FileFormatError:
            path.unlink()
    result = solve()
    result.save_npz(path)
    return result


def compare_case(
    case: RodCase,
    preset: str = DEFAULT_PRESET,
    elements: tuple[int, int] = (50, 100),
    representation: str = "ball",
    n_segments: int | None = None,
    cache_dir: Path | None = None,
) -> dict[str, Any]:
    """One comparison row for `case`: errors (max, RMS over the centerline, / L) and wall times (s).

    `elements` are PyElastica's two resolutions, the finer being the PyElastica reference. A PyElastica
    run that diverges leaves NaN in its columns and a `note`.
    """
    coarse, fine = sorted(int(n) for n in elements)
    check_range("elements (coarse)", coarse, 4, None)
    if coarse == fine:
        raise ParameterError(f"elements must be two different resolutions, got {list(elements)}")
    mujoco_result = solve_representation(case, representation, n_segments, preset=preset, points=POINTS)
    exact = cached_result(case, "analytic", 0, cache_dir)
    notes = []

    def pyelastica(n: int) -> RodResult | None:
        try:
            return cached_result(case, "pyelastica", n, cache_dir)
        except ParameterError as exc:  # PyElastica diverged: keep the row, say so
            notes.append(f"{n} elements: {exc}")
            return None

    pe_fine, pe_coarse = pyelastica(fine), pyelastica(coarse)
    length = case.length
    nan2 = (float("nan"), float("nan"))

    def error(a: RodResult | None, b: RodResult | None) -> tuple[float, float]:
        return nan2 if a is None or b is None else centerline_error(a.centerline, b.centerline, length)

    mj_pe = error(mujoco_result, pe_fine)
    mj_an = error(mujoco_result, exact)
    fine_an = error(pe_fine, exact)
    coarse_an = error(pe_coarse, exact)
    coarse_fine = error(pe_coarse, pe_fine)
    order = (
        math.log(coarse_an[0] / fine_an[0]) / math.log(fine / coarse)
        if fine_an[0] > 0.0 and coarse_an[0] > 0.0
        else float("nan")
    )
    converged = all(r.settings.get("converged", True) for r in (pe_fine, pe_coarse) if r is not None)
    return {
        "case": case.name,
        "reference": exact.settings["method"],
        "representation": representation,
        "preset": preset,
        "mujoco_segments": mujoco_result.settings["n_segments"],
        "mujoco_vs_pyelastica_max": mj_pe[0],
        "mujoco_vs_pyelastica_rms": mj_pe[1],
        "mujoco_vs_analytic_max": mj_an[0],
        "mujoco_vs_analytic_rms": mj_an[1],
        "mujoco_wall_s": mujoco_result.wall_time_s,
        "pyelastica_elements": fine,
        "pyelastica_vs_analytic_max": fine_an[0],
        "pyelastica_vs_analytic_rms": fine_an[1],
        "pyelastica_wall_s": pe_fine.wall_time_s if pe_fine is not None else float("nan"),
        "pyelastica_coarse_elements": coarse,
        "pyelastica_coarse_vs_analytic_max": coarse_an[0],
        "pyelastica_coarse_vs_fine_max": coarse_fine[0],
        "pyelastica_coarse_wall_s": pe_coarse.wall_time_s if pe_coarse is not None else float("nan"),
        "pyelastica_observed_order": order,
        "pyelastica_converged": converged,
        "note": "; ".join(notes),
    }
