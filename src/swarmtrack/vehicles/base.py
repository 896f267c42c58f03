"""What a vehicle kind tells the world: how it is stepped, what a commanded member takes, who may use it.

A vehicle kind registers once (:func:`swarmtrack.registry.register_vehicle`) as a :class:`Vehicle`; the scenario's
``swarm.vehicle`` and a group's ``vehicle`` name it, and the world (:mod:`swarmtrack.sim.world`) and the builder
(:mod:`swarmtrack.sim.build`) read its attributes, never its name. Two ways to be stepped:

* ``physics``: acceleration-driven, integrated by the world's physics for a whole group at once — ``"quadrotor"``
  (:mod:`swarmtrack.vehicles.quadrotor`, L24 Sec. 3.1: attitude loop and tilt limits) or ``"double_integrator"``
  (:mod:`swarmtrack.vehicles.double_integrator`, L24 Sec. 2). A driven group flies its members' velocity profiles
  through the autopilot, a commanded one (the UAVs) holds its planar accelerations.
* ``kinematic``: a module stepping its own state (:class:`KinematicModel`, e.g.
  :mod:`swarmtrack.vehicles.ground_walker` and :mod:`swarmtrack.vehicles.fixed_wing`, IB21 Sec. 6). The swarm's
  members take their commands (``command_width`` numbers each); a driven group draws its own inputs (``draw_inputs``,
  stream ``walk/<group>/<member>``: a :class:`DrivenKinematicModel`). ``pack`` names the compiled fast path of a
  built-in (:func:`swarmtrack.vehicles.kernels.kinematic_step` knows ``"walker"`` and ``"fixed_wing"`` rows); a kind
  without one is stepped by its module's ``step`` (``step_compiled`` in a compiled run), whatever registered it.

This module imports nothing of swarmtrack: the registry, the schema and the world all read it.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from types import ModuleType
from typing import Any, Protocol

#: The acceleration-driven models the world's physics integrates.
PHYSICS = ("quadrotor", "double_integrator")
#: The kinematic rows the compiled pack steps (:func:`swarmtrack.vehicles.kernels.kinematic_step`).
PACKS = ("walker", "fixed_wing")


class KinematicModel(Protocol):
    """A module that steps a kinematic vehicle: its state ``(n, STATE_DIM)`` starts with ``[x, y]`` and has its
    heading in column ``HEADING``; ``u`` is (n, 1) (a commanded member's input, or the tick's draws); ``trig`` is the
    ``(cos, sin)`` of the current headings (the world computes them once per state)."""

    STATE_DIM: int
    HEADING: int

    def initial_state(self, xy, heading, params) -> Any:
        """``(n, STATE_DIM)`` states at ``xy`` (n, 2) heading ``heading`` (n,)."""

    def step(self, state, u, params, dt: float, trig=None) -> Any:
        """The next state (the numpy reference)."""

    def step_compiled(self, state, u, params, dt: float, trig=None) -> Any:
        """:meth:`step`'s numbers, faster (may be :meth:`step` itself)."""

    def truth4(self, state, params, trig=None) -> Any:
        """``(n, 4)`` ``[x, y, vx, vy]``."""


class DrivenKinematicModel(KinematicModel, Protocol):
    """A :class:`KinematicModel` a driven group may use (:attr:`Vehicle.group`): it draws its members' inputs. One
    only the swarm flies (its members take their commands) needs no :meth:`draw_inputs`."""

    def draw_inputs(self, rng, n_ticks: int, n: int, params) -> Any:
        """``(n_ticks, n)`` inputs of a driven member, drawn from its own stream ``rng``."""


def _module(ref: str | ModuleType) -> ModuleType:
    return importlib.import_module(ref) if isinstance(ref, str) else ref


def _callable(ref: str | Callable) -> Callable:
    if callable(ref):
        return ref
    module, _, attr = ref.partition(":")
    return getattr(importlib.import_module(module), attr)


@dataclass(frozen=True)
class Vehicle:
    """One vehicle kind. Exactly one of ``physics`` (a name in :data:`PHYSICS`) and ``kinematic`` (a module
    following :class:`KinematicModel`, or its dotted name, imported when first stepped) says how it is stepped.

    ``command_width``: what a commanded member takes per step (2: a planar acceleration; 1: a fixed wing's yaw
    acceleration). ``uav`` / ``group``: whether the swarm / a driven group (targets, decoys) may use it.
    ``params(section)``: its parameters (what its module's functions take) from the scenario section of the group
    or swarm using it (``"module:attribute"`` allowed); None: no parameters. ``keys``: the keys of that section only
    this kind reads (the schema refuses them, unless at their defaults, with another vehicle). ``pack``: the
    compiled fast path of a built-in kinematic kind (a name in :data:`PACKS`), None for the generic path."""

    name: str
    description: str = ""
    physics: str | None = None
    kinematic: str | ModuleType | None = None
    command_width: int = 2
    uav: bool = True
    group: bool = True
    params: str | Callable | None = None
    keys: tuple[str, ...] = ()
    pack: str | None = None

    def __post_init__(self) -> None:
        if (self.physics is None) == (self.kinematic is None):
            raise ValueError(f"vehicle {self.name!r}: give exactly one of physics and kinematic")
        if self.physics is not None and self.physics not in PHYSICS:
            raise ValueError(f"vehicle {self.name!r}: physics {self.physics!r} is not one of {PHYSICS}")
        if self.pack is not None and (self.kinematic is None or self.pack not in PACKS):
            raise ValueError(f"vehicle {self.name!r}: pack {self.pack!r} is for kinematic kinds, one of {PACKS}")
        if self.command_width < 1:
            raise ValueError(f"vehicle {self.name!r}: command_width must be at least 1")
        if not (self.uav or self.group):
            raise ValueError(f"vehicle {self.name!r}: neither the swarm nor a group may use it")

    @property
    def is_kinematic(self) -> bool:
        """Whether its own module steps it (no velocity profiles, no autopilot)."""
        return self.kinematic is not None

    def module(self) -> KinematicModel:
        """The module stepping a kinematic kind (imported on first use)."""
        if self.kinematic is None:
            raise ValueError(f"vehicle {self.name!r} is not kinematic")
        return _module(self.kinematic)

    def make_params(self, section) -> object:
        """Its parameters from the scenario ``section`` (a group's or the swarm's), or None."""
        return None if self.params is None else _callable(self.params)(section)
