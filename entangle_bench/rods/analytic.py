"""Reference equilibria of a clamped-free rod case (inextensible, unshearable Kirchhoff rod).

* `rest_centerline`: zero gravity. The material frame obeys R' = R [Omega0]x with a uniform rest
  Darboux vector, so R(s) = R0 expm(s [Omega0]x) and the centerline is a circular arc (no twist)
  or a helix (twist), integrated here in closed form (Rodrigues' formula).
* `small_deflection_centerline`: Euler-Bernoulli cantilever under its own weight,
  w(s) = q s^2 (6 L^2 - 4 L s + s^2) / (24 E I), tip q L^4 / (8 E I) (Timoshenko & Gere,
  Mechanics of Materials, table of beam deflections).
* `planar_elastica_centerline`: large-deflection planar Euler elastica under uniform gravity with
  in-plane rest curvature, E I theta'' = -rho A (L - s) (t x g) . e_z, theta(0) = 0,
  theta'(L) = kappa0, solved with scipy's collocation solver (Bisshopp & Drucker, Q. Appl.
  Math. 3, 1945, for the cantilever; Antman, Nonlinear Problems of Elasticity, ch. 4).
* `kirchhoff_centerline`: the general 3D static Kirchhoff rod with the same load,
  R' = R [Omega]x, x' = R e1, m' = -x' x n, m = R C (Omega - Omega0), C = diag(G J, E I, E I),
  n(s) = rho A g (L - s), R(0) = R0, x(0) = x0, m(L) = 0 (Antman, ch. 8), again by collocation,
  continued from the straight rod: first in gravity, then in the rest curvature.
* `peel_force_n`: steady peeling of a naturally curved rod off a frictionless cylinder it lies on unstressed.

Frames are 3x3 matrices whose columns are (t, d1, d2) in world coordinates (see `case.py`).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_bvp

from entangle_bench.config import check_range
from entangle_bench.errors import ParameterError
from entangle_bench.rods.case import RodCase

_BVP_TOL = 1e-8
_MAX_NODES = 200_000


def skew(v: np.ndarray) -> np.ndarray:
    """Return the 3x3 cross-product matrix [v]x of a 3-vector."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _exp_and_integral(omega: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return expm(s [omega]x) (n,3,3) and its integral from 0 to s applied to e1 (n,3).

    Closed form with w = |omega|, A = [omega]x: expm(sA) = I + sin(ws)/w A + (1-cos ws)/w^2 A^2,
    integral = s I + (1-cos ws)/w^2 A + (s - sin(ws)/w)/w^2 A^2 (series used for small w s).
    """
    s = np.asarray(s, dtype=float)
    a = skew(omega)
    a2 = a @ a
    w = float(np.linalg.norm(omega))
    ws = w * s
    small = np.abs(ws) < 1e-3
    safe = np.where(small, 1.0, ws)
    wd = w if w > 0.0 else 1.0  # every ws is "small" when w == 0
    # f1 = sin(ws)/w, f2 = (1-cos ws)/w^2, f3 = (s - sin(ws)/w)/w^2, as series when ws is small.
    f1 = np.where(small, s * (1 - ws**2 / 6 + ws**4 / 120), np.sin(safe) / wd)
    f2 = np.where(small, s**2 * (0.5 - ws**2 / 24 + ws**4 / 720), (1 - np.cos(safe)) / wd**2)
    f3 = np.where(
        small, s**3 * (1 / 6 - ws**2 / 120 + ws**4 / 5040), (s - np.sin(safe) / wd) / wd**2
    )
    eye = np.eye(3)
    rot = eye + f1[:, None, None] * a + f2[:, None, None] * a2
    integral = s[:, None] * eye[0] + f2[:, None] * a[:, 0] + f3[:, None] * a2[:, 0]
    return rot, integral


def peel_force_n(bending_stiffness_nm2: float, curvature_per_m: float) -> float:
    """Steady force that peels a rod of natural curvature kappa off a frictionless cylinder of radius 1/kappa, N.

    Wrapped, the rod is unstressed; peeled and pulled straight, it stores E I kappa^2 / 2 per unit length. With
    nothing dissipated, each unit of pull peels a unit length, so F = E I kappa^2 / 2 = E I / (2 R^2), the energy
    release rate of the elastica (Kendall, J. Phys. D 8, 1975, for the adhesive analogue).
    """
    check_range("bending_stiffness_nm2", bending_stiffness_nm2, 0.0, None, low_open=True)
    check_range("curvature_per_m", curvature_per_m, 0.0, None)
    return 0.5 * bending_stiffness_nm2 * curvature_per_m**2


def rest_pose(case: RodCase, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Zero-gravity equilibrium at arclengths `s` (m, may be negative): positions (n,3), frames.

    Frames are (n,3,3) with columns (t, d1, d2); R(s) = R0 expm(s [Omega0]x).
    """
    s = np.atleast_1d(np.asarray(s, dtype=float))
    r0 = case.base_frame
    rot, integral = _exp_and_integral(case.darboux, s)
    frames = np.einsum("ij,njk->nik", r0, rot)
    positions = np.asarray(case.base_position) + integral @ r0.T
    return positions, frames


def rest_centerline(case: RodCase, m: int = 201) -> np.ndarray:
    """Zero-gravity centerline (m,3) in m at uniform arclength: straight line, arc or helix."""
    check_range("m", m, 2, None)
    return rest_pose(case, np.linspace(0.0, case.length, int(m)))[0]


def helix_geometry(case: RodCase) -> tuple[float, float]:
    """Radius (m) and pitch (m per turn, signed) of the zero-gravity helix of a curved case.

    With curvature kappa = |(k1, k2)| and twist tau: radius kappa / (kappa^2 + tau^2),
    pitch 2 pi tau / (kappa^2 + tau^2).
    """
    kappa = math.hypot(*case.intrinsic_curvature)
    tau = case.intrinsic_twist
    denom = kappa**2 + tau**2
    if kappa == 0.0:
        raise ParameterError("helix_geometry needs a non-zero intrinsic_curvature")
    return kappa / denom, 2.0 * math.pi * tau / denom


def small_deflection_tip(case: RodCase) -> float:
    """Tip deflection q L^4 / (8 E I) (m) of the linear cantilever, q = rho A |g_perp|."""
    return _transverse_load(case)[0] * case.length**4 / (8.0 * case.bending_stiffness)


def _transverse_load(case: RodCase) -> tuple[float, np.ndarray]:
    """Load per length perpendicular to the base tangent (N/m) and its unit direction."""
    t = np.asarray(case.base_direction)
    g = np.asarray(case.gravity, dtype=float)
    g_perp = g - (g @ t) * t
    magnitude = float(np.linalg.norm(g_perp))
    direction = g_perp / magnitude if magnitude > 0.0 else np.zeros(3)
    return case.line_density * magnitude, direction


def small_deflection_centerline(case: RodCase, m: int = 201) -> np.ndarray:
    """Linear (Euler-Bernoulli) cantilever centerline (m,3) in m under the transverse gravity.

    Points are base + s t + w(s) e_g at s uniform in [0, L]; the axial gravity component and the
    arclength change of order w'^2 are neglected, which is the formula's own approximation.
    """
    check_range("m", m, 2, None)
    if any(case.intrinsic_curvature) or case.intrinsic_twist:
        raise ParameterError("small_deflection_centerline needs zero intrinsic curvature and twist")
    q, direction = _transverse_load(case)
    length, ei = case.length, case.bending_stiffness
    s = np.linspace(0.0, length, int(m))
    w = q * s**2 * (6 * length**2 - 4 * length * s + s**2) / (24.0 * ei)
    t = np.asarray(case.base_direction)
    return np.asarray(case.base_position) + s[:, None] * t + w[:, None] * direction


def planar_plane(case: RodCase) -> tuple[np.ndarray, float, float, float] | None:
    """In-plane unit axis e_y, kappa0 (1/m), g_x and g_y (m/s^2) when the case is planar, else None.

    Planar means zero twist, and gravity and the rest bending direction t' = k2 d1 - k1 d2 both
    lie in one plane through the base tangent t = e_x.
    """
    if case.intrinsic_twist != 0.0:
        return None
    r0 = case.base_frame
    t = r0[:, 0]
    k1, k2 = case.intrinsic_curvature
    bend = k2 * r0[:, 1] - k1 * r0[:, 2]
    g = np.asarray(case.gravity, dtype=float)
    g_perp = g - (g @ t) * t
    scale = max(float(np.linalg.norm(g)), 1e-300)
    if np.linalg.norm(g_perp) > 1e-12 * scale:
        e_y = g_perp / np.linalg.norm(g_perp)
    elif np.linalg.norm(bend) > 0.0:
        e_y = bend / np.linalg.norm(bend)
    else:
        e_y = r0[:, 1]
    if np.linalg.norm(np.cross(bend, e_y)) > 1e-9 * max(float(np.linalg.norm(bend)), 1e-300):
        return None
    return e_y, float(bend @ e_y), float(g @ t), float(g @ e_y)


def _ramp(solve_at, stage: str, x: np.ndarray, y: np.ndarray, first_step: float):
    """Continue `solve_at(lam, x, y)` (a solve_bvp result) from lam = 0 to 1; return (x, y, sol).

    The step starts at `first_step`, doubles after each success and shrinks 4x after a failure.
    """
    lam, step, sol = 0.0, first_step, None
    while lam < 1.0:
        trial = min(1.0, lam + step)
        result = solve_at(trial, x, y)
        if result.success:
            lam, x, y, sol = trial, result.x, result.y, result.sol
            step = min(1.0, 2.0 * step)
        else:
            step /= 4.0
            if step < 1e-6:
                raise ParameterError(f"elastica continuation in {stage} stalled at {lam:.4g}")
    return x, y, sol


def _homotopy(solve_at, x: np.ndarray, y: np.ndarray, load: float, curvature: float):
    """Solve `solve_at(g_scale, k_scale, x, y)` at (1, 1) starting from the straight rod at (0, 0).

    Stage 1 ramps gravity on the straight-rest rod (a plain cantilever); stage 2 ramps the rest
    curvature and twist at full gravity. Where several equilibria exist, the one connected to
    this path is returned. The first steps keep the dimensionless
    load rho A g L^3 / (E I) and the rest turning angle |Omega0| L near 1 per step.
    """
    sol = None
    if load > 0.0:
        x, y, sol = _ramp(
            lambda lam, a, b: solve_at(lam, 0.0, a, b), "gravity", x, y, min(1.0, 1.0 / load)
        )
    if curvature > 0.0 or sol is None:
        g_scale = 1.0 if load > 0.0 else 0.0
        x, y, sol = _ramp(
            lambda lam, a, b: solve_at(g_scale, lam, a, b),
            "rest curvature",
            x,
            y,
            min(1.0, 1.0 / max(curvature, 1e-300)),
        )
    return sol


def planar_elastica_centerline(case: RodCase, m: int = 201, tol: float = _BVP_TOL) -> np.ndarray:
    """Large-deflection planar elastica centerline (m,3) in m, uniform arclength, base to tip.

    Needs a planar case (see `planar_plane`); solves in sigma = s/L for theta, theta', x/L, y/L
    with scipy.integrate.solve_bvp, continued from the straight rod (see `_homotopy`).
    """
    check_range("m", m, 2, None)
    plane = planar_plane(case)
    if plane is None:
        raise ParameterError(f"case {case.name!r} is not planar; use kirchhoff_centerline")
    e_y, kappa0, g_x, g_y = plane
    length = case.length
    load = case.line_density * length**3 / case.bending_stiffness  # times g -> dimensionless
    k0 = kappa0 * length

    def solve_at(g_scale: float, k_scale: float, x: np.ndarray, y: np.ndarray):
        ax, ay = g_scale * load * g_x, g_scale * load * g_y
        k_end = k_scale * k0

        def rhs(sig, z):
            theta, dtheta = z[0], z[1]
            torque = (1.0 - sig) * (ay * np.cos(theta) - ax * np.sin(theta))
            return np.vstack([dtheta, -torque, np.cos(theta), np.sin(theta)])

        def bc(za, zb):
            return np.array([za[0], zb[1] - k_end, za[2], za[3]])

        return solve_bvp(rhs, bc, x, y, tol=tol, max_nodes=_MAX_NODES)

    sig = np.linspace(0.0, 1.0, 101)
    zeros = np.zeros_like(sig)
    guess = np.vstack([zeros, zeros, sig, zeros])
    sol = _homotopy(solve_at, sig, guess, load * math.hypot(g_x, g_y), abs(k0))
    z = sol(np.linspace(0.0, 1.0, int(m)))
    t = np.asarray(case.base_direction)
    return np.asarray(case.base_position) + length * (z[2][:, None] * t + z[3][:, None] * e_y)


def kirchhoff_centerline(case: RodCase, m: int = 201, tol: float = _BVP_TOL) -> np.ndarray:
    """3D Kirchhoff-rod equilibrium centerline (m,3) in m under gravity, uniform arclength.

    State in sigma = s/L: position x/L (3), frame R (9, row-major), moment m L / (E I) (3);
    solved with scipy.integrate.solve_bvp, continued from the straight rod (see `_homotopy`).
    """
    check_range("m", m, 2, None)
    length = case.length
    ei, gj = case.bending_stiffness, case.twist_stiffness
    compliance = np.array([ei / gj, 1.0, 1.0])
    omega0 = case.darboux * length
    gravity = np.asarray(case.gravity, dtype=float) * case.line_density * length**3 / ei
    r0 = case.base_frame
    x0 = np.asarray(case.base_position) / length

    def solve_at(g_scale: float, k_scale: float, x: np.ndarray, y: np.ndarray):
        load = g_scale * gravity
        rest = k_scale * omega0

        def rhs(sig, z):
            rot = z[3:12].T.reshape(-1, 3, 3)
            moment = z[12:15].T
            omega = rest + compliance * np.einsum("nji,nj->ni", rot, moment)
            tangent = rot[:, :, 0]
            # R' = R [omega]x: each row a of R changes at the rate a x omega.
            d_rot = np.cross(rot, omega[:, None, :], axis=2)
            d_moment = -np.cross(tangent, load[None, :] * (1.0 - sig)[:, None])
            return np.vstack([tangent.T, d_rot.reshape(-1, 9).T, d_moment.T])

        def bc(za, zb):
            return np.concatenate([za[:3] - x0, za[3:12] - r0.ravel(), zb[12:15]])

        return solve_bvp(rhs, bc, x, y, tol=tol, max_nodes=_MAX_NODES)

    sig = np.linspace(0.0, 1.0, 101)
    straight = x0[:, None] + r0[:, :1] * sig[None, :]
    guess = np.vstack(
        [straight, np.repeat(r0.reshape(9, 1), sig.size, axis=1), np.zeros((3, sig.size))]
    )
    sol = _homotopy(
        solve_at, sig, guess, float(np.linalg.norm(gravity)), float(np.linalg.norm(omega0))
    )
    return length * sol(np.linspace(0.0, 1.0, int(m)))[:3].T


def reference_centerline(case: RodCase, m: int = 201) -> tuple[np.ndarray, str]:
    """Best independent reference for `case`: (centerline (m,3) in m, method name).

    Zero gravity: closed-form arc/helix; planar case: planar elastica; otherwise the 3D
    Kirchhoff boundary-value solution.
    """
    if not any(case.gravity):
        return rest_centerline(case, m), "rest_shape"
    if planar_plane(case) is not None:
        return planar_elastica_centerline(case, m), "planar_elastica"
    return kirchhoff_centerline(case, m), "kirchhoff_bvp"
