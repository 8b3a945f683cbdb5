"""PyElastica 1.0 reference engine: damped Cosserat-rod dynamics run to static equilibrium.

Model (Gazzola, Dudte, McCormick & Mahadevan, R. Soc. Open Sci. 5, 171628, 2018): one
`CosseratRod` of `n` elements, clamped with `OneEndFixedBC` on node 0 and element 0.

Clamp placement (second order): the clamp fixes element 0's director, i.e. the tangent at the
*midpoint* of element 0, so the rod is built with element length h = L / (n - 1/2) and total
length n h = L + h/2, with the midpoint of element 0 on the case's base point. Node 0 lies h/2
behind the base inside the clamp and is dropped from the output; node i >= 1 sits at arclength
(i - 1/2) h from the base. The output centerline is [base point, node 1, ..., node n] resampled to
uniform arclength (`resample_centerline`, cubic).

Inextensibility: the shear/stretch matrix is multiplied by `shear_factor` (default 20), and the
mass moment of inertia by the same factor so that the stable time step is set by the axial wave
speed alone, dt = cfl h / sqrt(shear_factor E / rho). Rotational inertia has no effect on a
static equilibrium.

Rest curvature: PyElastica's `rest_kappa` is the Darboux vector in its material frame
(d1, d2, d3 = t) with d' = kappa x d, the same convention as the case file, so
rest_kappa = (k1, k2, tau).

Relaxation: `AnalyticalLinearDamper` with uniform constant nu = 2 omega_slow, where omega_slow
estimates the slowest mode (`slowest_frequency`): that mode is then critically damped and every
faster one decays at least as fast. `PositionVerlet` steps until, at two consecutive checks
0.5 / omega_slow apart, the nodes moved less than `settle_tol` L since the previous check and
the largest node speed divided by omega_slow is below `settle_tol` L, or until `max_time_s` of
simulated time (then settings["converged"] is False). With rest curvature or twist the rod
starts by default from its exact discrete rest shape (zero elastic energy): this is already the
equilibrium in zero gravity, and gravity then deforms it from there.

Equilibrium branch: a case that is symmetric about its bending plane (planar rest shape, gravity in
that plane) keeps the symmetry exactly in these dynamics, so it can settle on an unstable planar
equilibrium. `perturbation` (rad) starts from a shape turned out of the bending plane by that angle
over the length (the discrete rest shape with an extra curvature perturbation / L perpendicular to
the rest bending direction); the relaxation then leaves a planar saddle the way a physical rod does.

Wall time: `wall_time_s` covers building and stepping. PyElastica's numba kernels are compiled
on first use and cached on disk; the very first call on a machine adds about 30 s.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import time
from collections.abc import Iterator
from typing import Any, Literal

import numpy as np
from elastica import (
    AnalyticalLinearDamper,
    BaseSystemCollection,
    Constraints,
    CosseratRod,
    Damping,
    Forcing,
    GravityForces,
    OneEndFixedBC,
)
from elastica.timestepper.symplectic_steppers import PositionVerlet
from tqdm import tqdm

from entangle_bench.config import check_choice, check_range
from entangle_bench.errors import ParameterError
from entangle_bench.rods.analytic import rest_pose
from entangle_bench.rods.case import RodCase, RodResult, resample_centerline

ENGINE_NAME = "pyelastica"
_FIRST_MODE = 1.875104**2
_HANGING_CHAIN_MODE = 1.2024  # first zero of J0, 2.4048, over 2


class _Simulator(BaseSystemCollection, Constraints, Forcing, Damping):
    """PyElastica system collection with clamps, forcing and damping."""


def slowest_frequency(case: RodCase) -> float:
    """Estimate (rad/s) of the slowest mode: sqrt(omega_b^2 + omega_g^2).

    omega_b = 1.875^2 sqrt(E I / (rho A L^4)) is the first bending mode of a cantilever and
    omega_g = 1.2024 sqrt(|g| / L) the first mode of a hanging chain (Bernoulli), which
    dominates for rods that gravity holds in tension.
    """
    bending = _FIRST_MODE * math.sqrt(case.bending_stiffness / (case.line_density * case.length**4))
    chain = _HANGING_CHAIN_MODE * math.sqrt(float(np.linalg.norm(case.gravity)) / case.length)
    return math.hypot(bending, chain)


@contextlib.contextmanager
def _without_inertia_warning() -> Iterator[None]:
    """Drop PyElastica's root-logger warning that thin rods have a small moment of inertia.

    `allocate` compares the mass moment of inertia with an absolute tolerance, which sub-mm
    filaments always trip; the warning says nothing about the run. The filter is removed after.
    """
    log_filter = logging.Filter()
    log_filter.filter = lambda record: (
        not record.getMessage().startswith(  # type: ignore
            "Mass moment of inertia matrix smaller than tolerance"
        )
    )
    root = logging.getLogger()
    root.addFilter(log_filter)
    try:
        yield
    finally:
        root.removeFilter(log_filter)


def stable_time_step(case: RodCase, n_elements: int, shear_factor: float, cfl: float) -> float:
    """Explicit step (s): cfl h / sqrt(shear_factor E / rho), with h = L / (n - 1/2)."""
    h = case.length / (n_elements - 0.5)
    return cfl * h / math.sqrt(shear_factor * case.youngs_modulus / case.density)


def perturbed_start(case: RodCase, perturbation: float) -> RodCase:
    """`case` with extra curvature `perturbation` / L (rad over the length) out of its bending plane.

    The extra curvature is perpendicular to the rest curvature (k1, k2) in the (d1, d2) plane, or along d1
    for a straight rod; only its discrete rest shape is used, as a start shape.
    """
    k1, k2 = case.intrinsic_curvature
    kappa = math.hypot(k1, k2)
    direction = (-k2 / kappa, k1 / kappa) if kappa > 0.0 else (1.0, 0.0)
    extra = perturbation / case.length
    return dataclasses.replace(
        case, intrinsic_curvature=(k1 + extra * direction[0], k2 + extra * direction[1])
    )


def build_rod(
    case: RodCase,
    n_elements: int,
    shear_factor: float = 20.0,
    initial: Literal["straight", "rest"] = "straight",
    perturbation: float = 0.0,
) -> CosseratRod:
    """PyElastica rod for `case`: clamp-midpoint placement, stiffened shear, rest curvature.

    `initial` "straight" lays it along the base tangent, "rest" in its discrete rest shape; a non-zero
    `perturbation` (rad) starts from the rest shape of `perturbed_start(case, perturbation)` instead.
    """
    h = case.length / (n_elements - 0.5)
    t0 = np.asarray(case.base_direction, dtype=float)
    start = np.asarray(case.base_position) - 0.5 * h * t0
    with _without_inertia_warning():
        rod = CosseratRod.straight_rod(
            n_elements,
            start,
            t0,
            np.asarray(case.base_normal, dtype=float),
            n_elements * h,
            case.radius,
            case.density,
            youngs_modulus=case.youngs_modulus,
            shear_modulus=case.shear_modulus,
        )
    rod.shear_matrix[...] *= shear_factor
    rod.mass_second_moment_of_inertia[...] *= shear_factor
    rod.inv_mass_second_moment_of_inertia[...] /= shear_factor
    k1, k2 = case.intrinsic_curvature
    rod.rest_kappa[...] = np.array([k1, k2, case.intrinsic_twist])[:, None]
    if perturbation != 0.0:
        positions, directors = discrete_rest_shape(perturbed_start(case, perturbation), n_elements)
        rod.position_collection[...] = positions
        rod.director_collection[...] = directors
    elif initial == "rest":
        positions, directors = discrete_rest_shape(case, n_elements)
        rod.position_collection[...] = positions
        rod.director_collection[...] = directors
    return rod


def discrete_rest_shape(case: RodCase, n_elements: int) -> tuple[np.ndarray, np.ndarray]:
    """Zero-energy state of the discrete rod: node positions (3, n+1) in m, directors (3, 3, n).

    Element i has the continuous rest frame at its midpoint s = i h (so the relative rotation of
    neighbours is exactly expm(h [Omega0]x)) and length h; node 0 sits h/2 behind the base.
    """
    h = case.length / (n_elements - 0.5)
    _, frames = rest_pose(case, h * np.arange(n_elements))
    tangents = frames[:, :, 0]
    nodes = np.empty((n_elements + 1, 3))
    nodes[0] = np.asarray(case.base_position) - 0.5 * h * tangents[0]
    nodes[1:] = nodes[0] + h * np.cumsum(tangents, axis=0)
    # PyElastica stores directors as rows (d1, d2, d3 = t) per element: Q[j, :, i].
    directors = np.transpose(frames[:, :, [1, 2, 0]], (2, 1, 0))
    return nodes.T.copy(), directors.copy()


def solve_elastica(
    case: RodCase,
    n_elements: int = 50,
    *,
    n_output: int = 201,
    shear_factor: float = 20.0,
    cfl: float = 0.7,
    damping_ratio: float = 1.0,
    settle_tol: float = 1e-6,
    max_time_s: float | None = None,
    initial: Literal["auto", "straight", "rest"] = "auto",
    perturbation: float = 0.0,
    progress: bool = False,
) -> RodResult:
    """Relax `case` to equilibrium with PyElastica; return the centerline (n_output, 3) in m.

    `damping_ratio` scales the damping constant 2 omega_slow; `settle_tol` is the stopping tolerance
    as a fraction of L; `max_time_s` (simulated s) defaults to 60 / omega_slow; `initial` "auto"
    starts from the discrete rest shape when the case has rest curvature or twist, else straight;
    a non-zero `perturbation` (rad) starts instead from the rest shape turned out of its bending plane
    (`perturbed_start`; recorded as initial "perturbed_rest").
    """
    check_range("n_elements", n_elements, 4, None)
    check_range("n_output", n_output, 2, None)
    check_range("shear_factor", shear_factor, 1.0, None)
    check_range("cfl", cfl, 0.0, 1.0, low_open=True)
    check_range("damping_ratio", damping_ratio, 0.0, None, low_open=True)
    check_range("settle_tol", settle_tol, 0.0, None, low_open=True)
    check_choice("initial", initial, ("auto", "straight", "rest"))
    check_range("perturbation", perturbation, -1.0, 1.0)
    curved = any(case.intrinsic_curvature) or case.intrinsic_twist != 0.0
    start_shape = ("rest" if curved else "straight") if initial == "auto" else initial
    if perturbation != 0.0:
        start_shape = "rest"  # of the perturbed case: `build_rod`
    omega_slow = slowest_frequency(case)
    if max_time_s is None:
        max_time_s = 60.0 / omega_slow
    check_range("max_time_s", max_time_s, 0.0, None, low_open=True)
    dt = stable_time_step(case, n_elements, shear_factor, cfl)
    nu = 2.0 * omega_slow * damping_ratio
    check_time = 0.5 / omega_slow
    steps_per_check = max(1, round(check_time / dt))

    wall_start = time.perf_counter()
    sim = _Simulator()
    rod = build_rod(case, n_elements, shear_factor, start_shape, perturbation)
    sim.append(rod)
    sim.constrain(rod).using(
        OneEndFixedBC, constrained_position_idx=(0,), constrained_director_idx=(0,)
    )
    if any(case.gravity):
        sim.add_forcing_to(rod).using(
            GravityForces, acc_gravity=np.asarray(case.gravity, dtype=float)
        )
    sim.dampen(rod).using(AnalyticalLinearDamper, uniform_damping_constant=nu, time_step=dt)
    sim.finalize()
    stepper = PositionVerlet()

    tol = settle_tol * case.length
    sim_time, steps, quiet_checks = 0.0, 0, 0
    previous = rod.position_collection.copy()
    converged = False
    change = speed_measure = math.inf
    bar = tqdm(total=max_time_s, unit="sim s", disable=not progress, desc=f"pyelastica {case.name}")
    while sim_time < max_time_s:
        for _ in range(steps_per_check):
            sim_time = float(stepper.step(sim, sim_time, dt))
        steps += steps_per_check
        bar.update(steps_per_check * dt)
        current = rod.position_collection
        if not np.all(np.isfinite(current)):
            bar.close()
            raise ParameterError(
                f"PyElastica diverged on case {case.name!r} at t = {sim_time:.4g} s with "
                f"dt = {dt:.3g} s; reduce cfl = {cfl:g}"
            )
        change = float(np.max(np.linalg.norm(current - previous, axis=0)))
        speed_measure = float(np.max(np.linalg.norm(rod.velocity_collection, axis=0))) / omega_slow
        previous = current.copy()
        quiet_checks = quiet_checks + 1 if max(change, speed_measure) < tol else 0
        if quiet_checks >= 2:
            converged = True
            break
    bar.close()
    nodes = rod.position_collection.T
    polyline = np.vstack([np.asarray(case.base_position), nodes[1:]])
    centerline = resample_centerline(polyline, n_output)
    wall = time.perf_counter() - wall_start
    settings: dict[str, Any] = {
        "case": case.name,
        "n_elements": int(n_elements),
        "dt_s": dt,
        "shear_factor": shear_factor,
        "damping_per_s": nu,
        "initial": start_shape if perturbation == 0.0 else "perturbed_rest",
        "perturbation_rad": perturbation,
        "steps": steps,
        "sim_time_s": sim_time,
        "converged": converged,
        "last_change_m": change,
        "last_speed_over_omega_slow_m": speed_measure,
        "max_strain": float(np.max(np.abs(rod.sigma))),
    }
    return RodResult(centerline=centerline, engine=ENGINE_NAME, wall_time_s=wall, settings=settings)
