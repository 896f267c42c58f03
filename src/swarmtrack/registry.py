"""One registration per kind: what a scenario can name, and everything derived from it.

A *kind* is one choice a scenario makes for a *role* (``estimator: {kind: imm}``). It registers once, with
:func:`register`: its settings class (a pydantic model whose ``kind`` field is a literal with its name as default),
its builder, and what the analysis reads of its runs: metric accumulators, health checks and figures. Everything
else is derived from the registrations: the scenario schema's tagged sections (:mod:`swarmtrack.scenarios.schema`),
the simulator's builders (:mod:`swarmtrack.sim.build`), the metrics of ``metrics.json``
(:mod:`swarmtrack.analysis.metrics`), a run's figures (:mod:`swarmtrack.analysis.plots`) and the CLI's choices.

The built-in kinds live in :mod:`swarmtrack.capabilities` (a package per capability) and are registered the first
time the registry is asked; a third-party package registers its own from the entry-point group
``swarmtrack.capabilities`` (a module to import), or a script calls :func:`register` itself.

Vehicles are kinds too (role :data:`VEHICLE`): a :class:`~swarmtrack.vehicles.base.Vehicle` registered with
:func:`register_vehicle` (the built-in four in :mod:`swarmtrack.capabilities.vehicles`), which the schema's vehicle
choices and the world's stepping read.

Builders, figures and accumulator factories may be given as ``"module:attribute"`` strings, imported when first
used, so that validating a scenario does not import the simulator and a run without figures does not import
matplotlib.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NamedTuple

if TYPE_CHECKING:
    from swarmtrack.replay.formats import LogFormat
    from swarmtrack.vehicles.base import Vehicle

#: The roles a kind can fill.
ROLES = ("estimator", "controller", "sensor")
#: The role of vehicle kinds (:class:`~swarmtrack.vehicles.base.Vehicle`, registered with :func:`register_vehicle`):
#: named by ``swarm.vehicle`` and a group's ``vehicle`` (a name, not a ``kind``-tagged section), read by the world.
VEHICLE = "vehicle"
#: The role of log readers (:class:`~swarmtrack.replay.formats.LogFormat`, registered with :func:`register_reader`):
#: what ``swarmtrack replay`` reads recorded flights with.
READER = "reader"

#: The built-in capabilities, imported (and so registered) the first time the registry is asked.
BUILTIN = (
    "swarmtrack.capabilities.tracking_swarm",
    "swarmtrack.capabilities.static",
    "swarmtrack.capabilities.multi_model",
    "swarmtrack.capabilities.mpc",
    "swarmtrack.capabilities.set_membership",
    "swarmtrack.capabilities.multi_target",
    "swarmtrack.capabilities.vehicles",
    "swarmtrack.capabilities.readers",
)
#: Entry-point group of third-party capabilities (each entry point names a module that calls :func:`register`).
ENTRY_POINTS = "swarmtrack.capabilities"

#: A callable, or ``"module:attribute"`` naming one (imported on first use).
Ref = Callable | str


def resolve(ref: Ref) -> Callable:
    """The callable a :data:`Ref` names (or the object a ``"module:attribute"`` string names: a :data:`Declared`)."""
    if callable(ref):
        return ref
    module, _, attr = ref.partition(":")
    return getattr(importlib.import_module(module), attr)


def _always(rec) -> bool:
    return True


@dataclass(frozen=True)
class Metric:
    """A section of ``metrics.json``: ``make(recording)`` gives an accumulator (``add(chunk, keep, err)`` per chunk of
    the recording, then ``result()``) when ``applies(recording)``. An accumulator that also has ``warnings()``
    contributes them to the run's ``warnings``. ``scalars(section)`` flattens the section into the numbers a sweep
    stores per run (default: its top-level numbers as ``<section>_<key>``), of which ``headline`` are the ones
    ``swarmtrack summarize`` tabulates. A time-series section's accumulator class names its quantities' axis labels
    in ``labels``."""

    section: str
    make: Ref
    applies: Callable = _always
    scalars: Callable | None = None
    headline: tuple[str, ...] = ()

    def flatten(self, value) -> dict[str, float | None]:
        """The section's scalars (``scalars``, or its top-level numbers)."""
        if self.scalars is not None:
            return self.scalars(value)
        if not isinstance(value, dict):
            return {}
        return {f"{self.section}_{k}": v for k, v in value.items()
                if v is None or (isinstance(v, (int, float)) and not isinstance(v, bool))}


@dataclass(frozen=True)
class Figure:
    """A single run's figure: ``draw(recording, path)`` writes ``file`` when ``applies(recording)``."""

    file: str
    draw: Ref
    applies: Callable = _always


class Telemetry(NamedTuple):
    """``report(component) → {name: (R, ...) array}``: what a UAV's own process sends with its probes for the
    truth-side monitors; ``mirror(component, reports)`` puts the swarm's reports ``{name: (N, ...)}`` into the truth
    side's copy of the component (never run itself) before its monitors read it."""

    report: Callable
    mirror: Callable


class Measurement(NamedTuple):
    """How a sensor kind's measurement relates to a target's planar position relative to the UAV (what replay makes
    of a log's relative positions, :mod:`swarmtrack.replay.grid`, and ``swarmtrack export`` of recorded
    detections): ``of_relative(rel, pos) → (z, frame)`` for relative positions ``rel`` (M, 2) of UAVs at ``pos``
    (M, 2), with ``frame`` the :class:`~swarmtrack.sensors.detections.Detections` frame or None;
    ``relative_of(detections) → rel`` (M, 2), its inverse. Each a :data:`Ref`."""

    of_relative: Ref
    relative_of: Ref


#: A tuple, or ``"module:attribute"`` naming one (imported when first read): a kind's metrics, health checks or
#: figures, so that registering a kind imports nothing of the analysis.
Declared = tuple | str


@dataclass(frozen=True)
class Kind:
    """One registered kind: its ``role`` and ``name``, its ``settings`` class and its builder ``build``, and what the
    analysis reads of its runs (:attr:`metrics`: :class:`Metric` sections; :attr:`health`: checks, accumulators
    whose ``result()`` is a list of warnings; :attr:`figures`: :class:`Figure` s), each :data:`Declared`."""

    role: str
    name: str
    settings: type
    build: Ref
    declared_metrics: Declared = ()
    declared_health: Declared = ()
    declared_figures: Declared = ()
    batched: bool = False
    """Whether its component runs several worlds as one batch (per-UAV state only, no UAV named in its settings:
    :mod:`swarmtrack.sim.batch`)."""
    monitors: Ref | None = None
    """Truth-side checks recorded beside the probes (never onboard): ``monitors(world, component)`` gives
    ``name → f`` with ``f()`` an (N,) array per estimation step."""
    telemetry: Ref | None = None
    """What the monitors read of the component when it runs in the UAVs' own processes (the live swarm): a
    :class:`Telemetry`."""
    measurement: Measurement | None = None
    """A sensor's measurement as a function of the target's relative position, and back (:class:`Measurement`;
    None: its measurements are not made from relative positions)."""
    quiet: Ref | None = None
    """A sensor's frame without detections, as it hands it to UAVs with navigation ``nav`` (R, d):
    ``quiet(settings, nav) → Detections`` (a sensor that stamps what it explored, e.g. IB21's footprints, stamps
    them); None: a frame without detections is empty."""
    shapes: Ref | None = None
    """What a live view draws of the component's state: ``shapes(component) → [(uav, vertices (K, 2))]``, outlines
    in the map frame (:attr:`~swarmtrack.streams.frame.StepFrame.polygons`; IB21's sets); None: nothing. A kind
    that draws its sets is :attr:`animated` too."""
    module: str = field(default="", compare=False)

    @property
    def animated(self) -> bool:
        """Whether its runs can be animated (``swarmtrack run --animate``: a set-valued estimator's sets frame by
        frame, :mod:`swarmtrack.analysis.animation`): a kind that draws its sets (:attr:`shapes`)."""
        return self.shapes is not None

    def builder(self) -> Callable:
        return resolve(self.build)

    @property
    def metrics(self) -> tuple[Metric, ...]:
        return _tuple(self.declared_metrics)

    @property
    def health(self) -> tuple[Metric, ...]:
        return _tuple(self.declared_health)

    @property
    def figures(self) -> tuple[Figure, ...]:
        return _tuple(self.declared_figures)


def _tuple(declared: Declared) -> tuple:
    named: Any = resolve(declared) if isinstance(declared, str) else declared  # a string names a tuple
    return tuple(named)


class UnknownKind(ValueError):
    """A scenario named a kind that is not registered for its role (the message names the role and the known
    kinds)."""


_KINDS: dict[str, dict[str, Any]] = {role: {} for role in (*ROLES, VEHICLE, READER)}
_BASES: dict[str, type] = {}
_loaded = False


def declare_role(role: str, base: type) -> None:
    """The base class every settings class of ``role`` subclasses (the scenario schema declares its own)."""
    _BASES[role] = base


def _load() -> None:
    """Import the built-in capabilities and the entry points' once."""
    global _loaded
    if _loaded:
        return
    _loaded = True
    for module in BUILTIN:
        importlib.import_module(module)
    from importlib.metadata import entry_points

    for ep in entry_points(group=ENTRY_POINTS):
        ep.load()


def register(role: str, settings: type, build: Ref, *, metrics: Declared = (), health: Declared = (),
             figures: Declared = (), batched: bool = False, monitors: Ref | None = None, telemetry: Ref | None = None,
             measurement: Measurement | None = None, quiet: Ref | None = None, shapes: Ref | None = None) -> Kind:
    """Register a kind for ``role``: its name is the default of ``settings.kind`` (a string literal), ``settings``
    subclasses the role's base settings class (declared by the schema, :func:`declare_role`), and ``build`` makes
    the component (estimator and controller: ``build(settings, context)``; sensor: ``build(settings, scenario)``).
    ``metrics``, ``health`` and ``figures`` are :data:`Declared` (name the capability's module, so that registering
    the kind imports none of the analysis). A name is registered once per role."""
    if role not in ROLES:
        hint = "; a vehicle registers with register_vehicle" if role == VEHICLE else ""
        raise ValueError(f"unknown role {role!r}; roles: {', '.join(ROLES)}{hint}")
    _load()
    base = _BASES.get(role, object)
    if not (isinstance(settings, type) and issubclass(settings, base)):
        raise TypeError(f"{getattr(settings, '__name__', settings)!r} must subclass {base.__name__}")
    name = getattr(settings, "model_fields", {}).get("kind")
    name = None if name is None else name.default
    if not isinstance(name, str):
        raise TypeError(f"{settings.__name__}.kind needs a string default (its kind)")
    if name in _KINDS[role]:
        raise ValueError(f"{role} kind {name!r} is already registered (by {_KINDS[role][name].module})")
    declared_metrics, declared_health, declared_figures = (d if isinstance(d, str) else tuple(d)
                                                           for d in (metrics, health, figures))
    kind = Kind(role, name, settings, build, declared_metrics, declared_health, declared_figures,
                batched=batched, monitors=monitors, telemetry=telemetry, measurement=measurement,
                quiet=quiet, shapes=shapes, module=settings.__module__)
    _KINDS[role][name] = kind
    return kind


def register_vehicle(vehicle: Vehicle) -> Vehicle:
    """Register a vehicle kind (:class:`~swarmtrack.vehicles.base.Vehicle`: how the world steps it, its command
    width, whether the swarm and the driven groups may use it); a name is registered once."""
    _load()
    name = vehicle.name
    if not isinstance(name, str) or not name:
        raise TypeError(f"a vehicle needs a name; got {name!r}")
    if name in _KINDS[VEHICLE]:
        raise ValueError(f"vehicle kind {name!r} is already registered")
    _KINDS[VEHICLE][name] = vehicle
    return vehicle


def register_reader(reader: LogFormat) -> LogFormat:
    """Register a log reader (:class:`~swarmtrack.replay.formats.LogFormat`: its name, what it recognises, how it
    turns logs into estimation steps); a name is registered once."""
    _load()
    if not isinstance(reader.name, str) or not reader.name:
        raise TypeError(f"a log reader needs a name; got {reader.name!r}")
    if reader.name in _KINDS[READER]:
        raise ValueError(f"log reader {reader.name!r} is already registered")
    _KINDS[READER][reader.name] = reader
    return reader


def unregister(role: str, name: str) -> None:
    """Remove a registered kind (tests that register toy kinds clean up with it)."""
    _KINDS[role].pop(name, None)


def kinds(role: str) -> dict[str, Any]:
    """Every registered kind of ``role``, by name, in the names' order (whatever order the capabilities were
    imported in: the reference, the metrics and the figures list them the same way every time)."""
    _load()
    return dict(sorted(_KINDS[role].items()))


def get(role: str, name: Any) -> Any:
    """The kind ``name`` of ``role`` (a :class:`Kind`; for :data:`VEHICLE` a ``Vehicle``); anything that is not a
    registered name (of any type) is refused with :class:`UnknownKind`."""
    table = kinds(role)
    if not isinstance(name, str) or name not in table:
        raise UnknownKind(f"unknown {role} kind {name!r}; known: {', '.join(sorted(table))}")
    return table[name]


def all_metrics() -> list[Metric]:
    """Every registered metric section once (the first registration of a section name wins; roles in
    :data:`ROLES` order, kinds by name): what a sweep can find in a run's metrics."""
    seen: dict[str, Metric] = {}
    for role in ROLES:
        for kind in kinds(role).values():
            for metric in kind.metrics:
                seen.setdefault(metric.section, metric)
    return list(seen.values())


def of_run(meta: dict) -> list[Kind]:
    """The registered kinds a recording's run used (from its ``meta``: the ``sensor``, ``estimator`` and
    ``controller`` sections), skipping kinds not registered in this process."""
    out = []
    for role in ROLES:
        name = (meta.get(role) or {}).get("kind")
        if isinstance(name, str) and name in kinds(role):
            out.append(_KINDS[role][name])
    return out
