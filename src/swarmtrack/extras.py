"""The drivers installed as extras (``pip install 'swarmtrack[NAME]'``), and the check a command makes before it starts.

``pip install swarmtrack`` gives the estimators, the models, the simulator (its MPC controller and set-membership
estimator too) and its analysis. The drivers are extras (pyproject.toml's ``[project.optional-dependencies]``, which
:data:`EXTRAS` mirrors; a test holds the two equal)::

    live       swarmtrack live | world | agent | keygen: Zenoh, the wire format, pymavlink (the live world and agent
               import the autopilot link: live --mavlink, agent --autopilot udp://)
    autopilot  swarmtrack engage; serial links (agent --autopilot serial://)
    logs       swarmtrack replay of ROS bags and PX4 ULog files (a run folder or CSV needs neither);
               swarmtrack export --format mcap|rosbag2 (csv needs neither)
    field      swarmtrack agent --field | monitor | stand-in: the live swarm's, and rosbags for the ROS 2 messages
               its sources carry (docs/field.md)
    foxglove   --foxglove: the live view over Foxglove's WebSocket protocol, and its MCAP files (foxglove-sdk)
    ros2       --ros2 and ros2:/// sources: ROS 2 topics through cyclonedds (no ROS installation), their message
               definitions from rosbags
    dask       swarmtrack sweep | reproduce --cluster (without it they run on a local process pool)
    all        every one of them (``make run`` and ``make test`` install ``.[dev]``, which has ``all``)

A command that needs one calls :func:`require` first: a package it needs that cannot be imported (looked up with
:func:`importlib.util.find_spec`, not imported) is one line naming the extra and how to install it, exit code 2,
before anything is written.
"""

from __future__ import annotations

from collections.abc import Iterable
from importlib.util import find_spec

import click

#: Each extra → its distributions → the top-level module each is imported as.
EXTRAS: dict[str, dict[str, str]] = {
    "live": {"eclipse-zenoh": "zenoh", "msgspec": "msgspec", "pymavlink": "pymavlink"},
    "autopilot": {"pymavlink": "pymavlink", "pyserial": "serial"},
    "logs": {"rosbags": "rosbags", "pyulog": "pyulog"},
    "field": {"eclipse-zenoh": "zenoh", "msgspec": "msgspec", "pymavlink": "pymavlink", "rosbags": "rosbags"},
    "dask": {"dask": "dask", "distributed": "distributed"},
    "foxglove": {"foxglove-sdk": "foxglove"},
    "ros2": {"cyclonedds": "cyclonedds", "rosbags": "rosbags"},
}


class MissingExtra(click.ClickException):
    """A command needs an extra that is not installed: one line naming it, exit code 2 (as
    :class:`~swarmtrack.cli_support.UsageFailure`)."""

    exit_code = 2


def missing(extra: str, packages: Iterable[str] | None = None) -> list[str]:
    """The distributions of ``extra`` (only ``packages`` of them, when given) whose module cannot be imported."""
    table = EXTRAS[extra]
    wanted = list(table) if packages is None else list(packages)
    unknown = [p for p in wanted if p not in table]
    if unknown:
        raise ValueError(f"{', '.join(unknown)}: not in the {extra!r} extra ({', '.join(table)})")
    return [p for p in wanted if find_spec(table[p]) is None]


def refusal(what: str, extra: str, gone: Iterable[str]) -> str:
    """The line that says ``what`` needs ``extra``, of which the distributions ``gone`` are missing."""
    return f"{what} needs the '{extra}' extra ({', '.join(gone)}): pip install 'swarmtrack[{extra}]'"


def require(extra: str, what: str, packages: Iterable[str] | None = None) -> None:
    """Refuse (:class:`MissingExtra`, exit 2) to go on when a distribution of ``extra`` is missing: every one of
    them, or only ``packages`` when ``what`` (e.g. ``"swarmtrack engage"``) needs no more."""
    gone = missing(extra, packages)
    if gone:
        raise MissingExtra(refusal(what, extra, gone))


def require_readers(names: Iterable[str], what: str = "swarmtrack replay") -> None:
    """:func:`require` what the replay readers ``names`` read with (their registrations' ``extra``,
    :class:`~swarmtrack.replay.formats.LogFormat`)."""
    from swarmtrack import registry

    readers = registry.kinds(registry.READER)
    for name in sorted(set(names)):
        need = readers[name].extra
        if need is not None:
            require(need[0], f"{what} of {name} logs", [need[1]])
