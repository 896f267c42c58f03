"""What a log reader registers: a :class:`LogFormat` (a kind of the registry's ``reader`` role).

A format has a name (``swarmtrack replay --format NAME``), says whether it recognises a path (``accepts``, used
when ``--format`` is not given) and turns the logs into estimation steps (``steps``). Both are ``"module:function"``
references, imported when first used, so that listing the formats imports no reader library.
"""

from __future__ import annotations

from dataclasses import dataclass

from swarmtrack.registry import Ref, resolve


@dataclass(frozen=True)
class LogFormat:
    """``accepts(path) -> bool``; ``steps(paths, scenario, mapping, counts) -> Iterator[StepInputs]`` with
    ``mapping`` the parsed map file (or None) and ``counts`` a dict the reader adds what it skipped to (name →
    count, reported in ``metrics.json`` under ``replay``). ``needs_map``: the reader cannot run without a map
    file. ``phases``: its steps carry the scenario's profile phases (a run folder's do; a flight's log knows none).

    A *time-stamped* reader (a flight's pieces, read together in any mix: :mod:`swarmtrack.replay.timestamped`)
    also gives ``stamped(paths, scenario, mapping, counts)``: None when it has nothing to read, else a function of a
    ``counts`` dict giving its messages (:mod:`swarmtrack.replay.grid`'s ``Navigation``, ``Detection``, ``Truth``) in
    time-stamp order, once per pass over the logs; ``files`` says which files it recognises, for the message that
    names a log no reader recognises.
    """

    name: str
    description: str
    accepts: Ref
    steps: Ref
    needs_map: bool = False
    phases: bool = False
    stamped: Ref | None = None
    files: str = ""
    extra: tuple[str, str] | None = None
    """The extra and its distribution it reads with (``("logs", "rosbags")``: :mod:`swarmtrack.extras`); None: the
    core's."""

    def recognises(self, path) -> bool:
        return bool(resolve(self.accepts)(path))

    def open(self, paths, scenario, mapping, counts: dict):
        return resolve(self.steps)(paths, scenario, mapping, counts)


def reader_for(fmt: str | None, logs) -> LogFormat:
    """The reader named ``fmt``, or (None) the first registered one that recognises the first of ``logs``; a
    missing log or an unknown format is a :class:`~swarmtrack.replay.steps.LogError` naming it."""
    from pathlib import Path

    from swarmtrack import registry
    from swarmtrack.replay.steps import LogError

    if not logs:
        raise LogError("no log to replay")
    for log in logs:
        if not Path(log).exists():
            raise LogError(f"{log}: no such file or folder")
    known = registry.kinds(registry.READER)
    if fmt is not None:
        if fmt not in known:
            raise LogError(f"--format {fmt}: unknown; known: {', '.join(known)}")
        return known[fmt]
    for reader in known.values():
        if reader.recognises(Path(logs[0])):
            return reader
    raise LogError(f"{logs[0]}: not a log any reader recognises ({', '.join(known)}); name one with --format")
