"""Rod-case comparison: the MuJoCo filament against PyElastica and the analytic/BVP reference.

Each case has one reference (`reference_result`): its finest stored PyElastica run (>= 200 elements) where
it has one (`references`: the multi-turn hanging coils), else the closed-form or boundary-value solution
(`analytic.reference_centerline`). For each case, `compare_case` solves the case with MuJoCo (a preset,
optionally another representation), with PyElastica at two resolutions (stored runs where present; the
coarser one measures PyElastica's own convergence) and with `analytic.reference_centerline` where that
converges, and returns one table row of max and RMS centerline distances divided by L plus the wall times.
`cached_result` stores computed solutions as NPZ files keyed by the case content.

Symmetric cases: a planar case (rest shape and gravity in one plane) can buckle out of that plane into
one of two mirror-image equilibria, and which one an engine reaches is decided by rounding. `case_error`
therefore measures the distance to the nearer of the pair; on a case whose equilibrium stays planar the
mirror image is the shape itself.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from entangle_bench.config import check_range
from entangle_bench.errors import FileFormatError, ParameterError
from entangle_bench.presets import DEFAULT_PRESET
from entangle_bench.rods.analytic import mirror_normal, planar_plane, reference_centerline
from entangle_bench.rods.case import RodCase, RodResult, case_key, centerline_error
from entangle_bench.rods.elastica_engine import solve_elastica
from entangle_bench.rods.references import has_reference, load_reference, stored_elements
from entangle_bench.rods.representations import DEFAULT_REPRESENTATION, solve_representation

#: Points of every compared centerline.
POINTS = 201


def mirror_image(case: RodCase, points: np.ndarray) -> np.ndarray:
    """`points` (M, 3) in m reflected across the case's mirror plane; unchanged if the case has none."""
    normal = mirror_normal(case)
    points = np.asarray(points, dtype=float)
    if normal is None:
        return points
    offset = (points - np.asarray(case.base_position)) @ normal
    return points - 2.0 * offset[:, None] * normal[None, :]


def case_error(case: RodCase, a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """(max, RMS) distance / L between centerlines `a` and `b`, or `b`'s mirror image if that is nearer.

    The mirror image counts only for planar cases (see module docstring); otherwise this is
    `centerline_error`.
    """
    direct = centerline_error(a, b, case.length)
    if mirror_normal(case) is None:
        return direct
    mirrored = centerline_error(a, mirror_image(case, b), case.length)
    return min(direct, mirrored)


def reference_result(case: RodCase) -> RodResult:
    """The case's reference: its finest stored PyElastica run if it has one, else `analytic_result`."""
    if has_reference(case):
        return load_reference(case)
    return analytic_result(case)


def reference_name(result: RodResult) -> str:
    """Short name of a reference result: the analytic method or 'pyelastica_<elements>'."""
    if result.engine == "analytic":
        return str(result.settings["method"])
    return f"{result.engine}_{result.settings['n_elements']}"


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
    representation: str = DEFAULT_REPRESENTATION,
    n_segments: int | None = None,
    cache_dir: Path | None = None,
    stored: bool = True,
) -> dict[str, Any]:
    """One comparison row for `case`: errors (max, RMS over the centerline, / L) and wall times (s).

    `elements` are PyElastica's two resolutions, the finer being the PyElastica reference. With `stored`
    a case that has stored references uses its two finest stored runs instead of running PyElastica; their
    wall times are those recorded when they were made. Errors against the case's reference
    (`reference_result`) are in the `mujoco_vs_reference_*` columns. A PyElastica run that diverges, or a
    boundary-value solution that does not converge, leaves NaN in its columns and a `note`.
    """
    use_stored = stored and has_reference(case) and len(stored_elements(case)) >= 2
    coarse, fine = stored_elements(case)[-2:] if use_stored else sorted(int(n) for n in elements)
    check_range("elements (coarse)", coarse, 4, None)
    if coarse == fine:
        raise ParameterError(f"elements must be two different resolutions, got {list(elements)}")
    mujoco_result = solve_representation(case, representation, n_segments, preset=preset, points=POINTS)
    notes = []
    exact: RodResult | None = None
    if has_reference(case) and planar_plane(case) is None:
        # The 3D boundary-value solver does not converge on the multi-turn hanging coils (measured: out of
        # memory at 200k nodes after 150 s, or over 5 min), which is why they have stored references.
        notes.append("analytic: 3D boundary-value solution not attempted (stored reference case)")
    else:
        try:
            exact = cached_result(case, "analytic", 0, cache_dir)
        except ParameterError as exc:  # the boundary-value continuation stalled
            notes.append(f"analytic: {exc}")

    def pyelastica(n: int) -> RodResult | None:
        try:
            if use_stored:
                return load_reference(case, n)
            return cached_result(case, "pyelastica", n, cache_dir)
        except (ParameterError, FileFormatError) as exc:  # diverged, or a stored file missing or stale
            notes.append(f"{n} elements: {exc}")
            return None

    pe_fine, pe_coarse = pyelastica(fine), pyelastica(coarse)
    reference = pe_fine if use_stored else exact
    nan2 = (float("nan"), float("nan"))

    def error(a: RodResult | None, b: RodResult | None) -> tuple[float, float]:
        return nan2 if a is None or b is None else case_error(case, a.centerline, b.centerline)

    mj_ref = error(mujoco_result, reference)
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
        "reference": reference_name(reference) if reference is not None else "",
        "analytic": exact.settings["method"] if exact is not None else "",
        "representation": representation,
        "preset": preset,
        "mujoco_segments": mujoco_result.settings["n_segments"],
        "mujoco_vs_reference_max": mj_ref[0],
        "mujoco_vs_reference_rms": mj_ref[1],
        "mujoco_vs_pyelastica_max": mj_pe[0],
        "mujoco_vs_pyelastica_rms": mj_pe[1],
        "mujoco_vs_analytic_max": mj_an[0],
        "mujoco_vs_analytic_rms": mj_an[1],
        "mujoco_wall_s": mujoco_result.wall_time_s,
        "mujoco_saddles_left": mujoco_result.settings["saddles_left"],
        "pyelastica_elements": fine,
        "pyelastica_vs_analytic_max": fine_an[0],
        "pyelastica_vs_analytic_rms": fine_an[1],
        "pyelastica_wall_s": pe_fine.wall_time_s if pe_fine is not None else float("nan"),
        "pyelastica_coarse_elements": coarse,
        "pyelastica_coarse_vs_analytic_max": coarse_an[0],
        "pyelastica_coarse_vs_fine_max": coarse_fine[0],
        "pyelastica_fine_error_estimate": coarse_fine[0] / ((fine / coarse) ** 2 - 1.0),
        "pyelastica_coarse_wall_s": pe_coarse.wall_time_s if pe_coarse is not None else float("nan"),
        "pyelastica_observed_order": order,
        "pyelastica_converged": converged,
        "pyelastica_stored": use_stored,
        "note": "; ".join(notes),
    }
