"""Numerical presets: resolution, timestep, integrator and solver settings that trade accuracy for time.

Each preset was chosen from the accuracy-time study (`entangle_bench.studies.accuracy_time`, README); its measured
rod-shape error and cost are recorded there. A preset is a segment count plus `Numerics`; physics lives in
FilamentParams and GripperParams. Applying a preset writes its segment count into the filament parameters
(`apply_preset`, the one place presets apply), and user overrides (`--set gripper.filament.n_segments=..`) come after.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Literal, TypeVar

import mujoco

from entangle_bench.config import check_choice, check_range
from entangle_bench.errors import ParameterError
from entangle_bench.registry import Registry

C = TypeVar("C")

Integrator = Literal["euler", "implicitfast", "implicit", "rk4", "discrete"]
Solver = Literal["cg", "newton", "pgs"]


#: mjOption fields a task may switch per phase: option (a Numerics field too) -> (the Numerics field naming its
#: phases, the option's value outside them).
PER_PHASE_OPTIONS: dict[str, tuple[str, float]] = {
    "noslip_iterations": ("noslip_phases", 0),
    "impratio": ("impratio_phases", 1.0),
}


@dataclass(frozen=True)
class Numerics:
    """Discretization and solver settings of one simulation."""

    timestep_s: float = 2e-3
    integrator: Integrator = "euler"
    euler_implicit_damping: bool = False
    """MuJoCo's implicit joint damping inside the Euler integrator (costs a second factorization per step)."""
    solver: Solver = "cg"
    iterations: int = 30
    tolerance: float = 1e-6
    ls_iterations: int = 20
    impratio: float = 1.0
    """Ratio of frictional to normal constraint impedance; > 1 reduces creep of soft frictional contacts."""
    impratio_phases: tuple[str, ...] = ()
    """Task phases in which `impratio` applies (e.g. lift, hold, release: less creep while the grasp carries the
    load); 1 in the others; empty: every step. A filament wedged in a branch crotch during the approach is held
    by friction and sinks into the branch when friction is the stiffer constraint."""
    noslip_iterations: int = 0
    """Post-processing iterations of MuJoCo's noslip solver that remove frictional creep (0: off)."""
    noslip_phases: tuple[str, ...] = ()
    """Task phases in which the noslip solver runs (e.g. lift, hold, release: static friction while the grasp
    carries the load, at the solver's cost only there); empty: every step. Needs `noslip_iterations` > 0."""
    twist_armature_scale: float = 1000.0
    """Joint armature as a multiple of the segment's spin inertia (statics unchanged; MuJoCo applies it to all
    three DOFs of each ball joint, see `filament.add_filament`)."""
    bending_armature: bool = True
    """Put the twist armature on the bending DOFs too. A ball joint always does (MuJoCo gives it one armature
    for its three DOFs); with `gripper.filament.joints = hinges`, False leaves the bending hinges at the rod's
    own inertia, so the armature slows only the torsional waves it is meant for."""

    def __post_init__(self) -> None:
        check_range("numerics.timestep_s", self.timestep_s, 1e-6, 0.02)
        check_choice("numerics.integrator", self.integrator, ("euler", "implicitfast", "implicit", "rk4", "discrete"))
        check_choice("numerics.solver", self.solver, ("cg", "newton", "pgs"))
        check_range("numerics.iterations", self.iterations, 1, 10000)
        check_range("numerics.tolerance", self.tolerance, 0.0, 1.0)
        check_range("numerics.ls_iterations", self.ls_iterations, 1, 1000)
        check_range("numerics.impratio", self.impratio, 1.0, 1000.0)
        check_range("numerics.noslip_iterations", self.noslip_iterations, 0, 1000)
        if self.noslip_phases and not self.noslip_iterations:
            raise ParameterError(
                f"numerics.noslip_phases={list(self.noslip_phases)} needs numerics.noslip_iterations > 0 (got 0)"
            )
        check_range("numerics.twist_armature_scale", self.twist_armature_scale, 1.0, 1e6)

    def check_joints(self, joints: str) -> None:
        """Raise ParameterError if these numerics cannot be built with the filament joint model `joints`."""
        if not self.bending_armature and joints != "hinges":
            raise ParameterError(
                f"numerics.bending_armature = false needs gripper.filament.joints = 'hinges', got {joints!r}: "
                "MuJoCo gives a ball joint one armature for all three DOFs"
            )

    def phase_options(self, phase: str | None) -> dict[str, float]:
        """mjOption values, in task phase `phase`, of the per-phase options (PER_PHASE_OPTIONS) whose phases this
        names: the configured value inside them, the off value outside (and for `phase` None)."""
        options = {}
        for option, (field_name, off) in PER_PHASE_OPTIONS.items():
            phases = getattr(self, field_name)
            if phases:
                options[option] = getattr(self, option) if phase in phases else off
        return options

    def apply(self, spec: mujoco.MjSpec) -> None:
        """Write timestep, integrator and solver settings into `spec.option`."""
        opt = spec.option
        opt.timestep = self.timestep_s
        opt.integrator = {
            "euler": mujoco.mjtIntegrator.mjINT_EULER,
            "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
            "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
            "rk4": mujoco.mjtIntegrator.mjINT_RK4,
            "discrete": mujoco.mjtIntegrator.mjINT_DISCRETE,
        }[self.integrator]
        opt.solver = {
            "cg": mujoco.mjtSolver.mjSOL_CG,
            "newton": mujoco.mjtSolver.mjSOL_NEWTON,
            "pgs": mujoco.mjtSolver.mjSOL_PGS,
        }[self.solver]
        opt.iterations = self.iterations
        opt.tolerance = self.tolerance
        opt.ls_iterations = self.ls_iterations
        opt.impratio = self.impratio
        opt.noslip_iterations = self.noslip_iterations
        for option, value in self.phase_options(None).items():  # off until the task switches it per phase
            setattr(opt, option, value)
        if not self.euler_implicit_damping:
            opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_EULERDAMP


@dataclass(frozen=True)
class Preset:
    """A named point on the accuracy-time front: segments per filament and solver numerics."""

    name: str
    n_segments: int
    numerics: Numerics


#: Numerical presets by name. From the accuracy-time front (results/accuracy_time/report.md): fast uses 2 ms
#: because a 4 ms step tripled its curl error for 20 % less cost; balanced is the cheapest point under 2 % of L
#: that still runs 3x real time in the default trial. The study found accurate 4.5x cheaper with CG at 32
#: segments and 1 ms for the same rod error; that change waits for the stability map to be re-measured with
#: those numerics.
PRESETS: Registry[Preset] = Registry("preset")
PRESETS.add(
    "fast",
    Preset("fast", 12, Numerics(timestep_s=2e-3)),
    description="12 segments, 2 ms, Euler, CG: screening sweeps",
)
PRESETS.add(
    "balanced",
    Preset("balanced", 16, Numerics(timestep_s=2e-3)),
    description="16 segments, 2 ms, Euler, CG: the default, 3x real time",
)
PRESETS.add(
    "accurate",
    Preset(
        "accurate",
        40,
        Numerics(
            timestep_s=5e-4,
            integrator="implicitfast",
            solver="newton",
            iterations=100,
            tolerance=1e-8,
            twist_armature_scale=100.0,
        ),
    ),
    description="40 segments, 0.5 ms, implicitfast, Newton: reference runs",
)

DEFAULT_PRESET = "balanced"


def get_preset(name: str) -> Preset:
    """The named preset; unknown names raise UnknownNameError listing the known ones."""
    return PRESETS.get(name)


def apply_preset(config: C, name: str | None = None) -> C:
    """`config` with a preset's segment count and numerics (default: DEFAULT_PRESET); the one place presets apply.

    `config` is any frozen dataclass with `gripper.filament.n_segments` and `numerics` fields (task configs,
    `scene.SceneConfig`).
    """
    preset = get_preset(name or DEFAULT_PRESET)
    filament = dataclasses.replace(config.gripper.filament, n_segments=preset.n_segments)
    gripper = dataclasses.replace(config.gripper, filament=filament)
    return dataclasses.replace(config, gripper=gripper, numerics=preset.numerics)
