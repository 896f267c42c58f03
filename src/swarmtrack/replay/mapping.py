"""The map file of ``swarmtrack replay --map``: which topic (or file) and field hold each UAV's navigation and
detections, and the ground truth.

The simplest map names topics only, for bags whose message types say what they hold::

    uavs:
      1: {navigation: /uav1/pose, detections: /uav1/target}   # PoseStamped, PoseWithCovarianceStamped, Odometry;
      2: {navigation: /uav2/pose, detections: /uav2/target}   # PointStamped of the target relative to the UAV
    truth: /target/pose                                        # optional ground truth

A source written as a mapping names the fields of other messages by dotted paths (``docs/replay.md``): a
detection's ``point`` (a message with ``x``, ``y``: the target relative to the UAV along the map frame's axes) or
its ``range`` and ``bearing`` fields (bearing in radians from the map frame's x axis, counter-clockwise), and a
navigation's or the truth's ``position`` (a message with ``x``, ``y``). ``log`` names the file a UAV's navigation is
in when each UAV has its own (a PX4 ULog, :mod:`swarmtrack.replay.ulog`; its ``navigation`` is then the ULog message's
name), resolved against the map file's folder or matched by file name to a log given on the command line, and
``time_offset`` (s) is added to that file's time stamps (a ULog's boot clock onto the other logs' clock). ``window``
bounds how far (s) a message may come after later-stamped ones and still be placed at its own time stamp;
``truth_gap`` how far apart (s) two truth samples may be for the truth between them to be interpolated; ``max_gap``
the longest stretch (s) of the logs without a message (:mod:`swarmtrack.replay.grid`).
"""

from __future__ import annotations

from pathlib import Path

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from swarmtrack.replay.grid import MAX_GAP, TRUTH_GAP, WINDOW
from swarmtrack.replay.steps import LogError


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class Source(_Strict):
    """A topic (ROS bag), a message name (ULog) or a column prefix (CSV), and, for messages whose type does not say
    where the position is, the dotted ``position`` path."""

    topic: str = Field(min_length=1)
    position: str | None = None


class DetectionSource(_Strict):
    """A detection topic: by type (``PointStamped``), or ``point`` / ``range`` + ``bearing`` field paths."""

    topic: str = Field(min_length=1)
    point: str | None = None
    range: str | None = None
    bearing: str | None = None

    @model_validator(mode="after")
    def _one_way(self):
        if (self.range is None) != (self.bearing is None):
            raise ValueError("range and bearing are named together")
        if self.point is not None and self.range is not None:
            raise ValueError("name either point or range and bearing")
        return self


def _topic(value):
    return {"topic": value} if isinstance(value, str) else value


class UavSources(_Strict):
    navigation: Source
    detections: DetectionSource | None = None
    log: Path | None = None
    time_offset: float = Field(default=0.0, allow_inf_nan=False)

    _nav = field_validator("navigation", mode="before")(classmethod(lambda cls, v: _topic(v)))
    _det = field_validator("detections", mode="before")(classmethod(lambda cls, v: _topic(v)))


class ReplayMap(_Strict):
    uavs: dict[int, UavSources] = Field(min_length=1)
    truth: Source | None = None
    window: float = Field(default=WINDOW, gt=0.0, allow_inf_nan=False)
    truth_gap: float = Field(default=TRUTH_GAP, ge=0.0, allow_inf_nan=False)
    max_gap: float = Field(default=MAX_GAP, gt=0.0, allow_inf_nan=False)

    _truth = field_validator("truth", mode="before")(classmethod(lambda cls, v: _topic(v)))

    @classmethod
    def checked(cls, data, scenario, origin: str = "map") -> ReplayMap:
        """``data`` (a dict, or a ``ReplayMap``) validated and checked against ``scenario`` (its UAVs exist); one
        readable :class:`LogError` otherwise."""
        try:
            mapping = data if isinstance(data, cls) else cls.model_validate(data if data is not None else {})
        except ValidationError as exc:
            err = exc.errors()[0]
            where = ".".join(str(p) for p in err["loc"])
            raise LogError(f"{origin}: {where}: {err['msg'].removeprefix('Value error, ')}") from None
        n = scenario.swarm.n_uavs
        extra = [i for i in mapping.uavs if i > n]
        if extra:
            raise LogError(f"{origin}: uavs.{extra[0]} is in the map but the scenario {scenario.name} has "
                           f"{n} UAV(s) (swarm.n_uavs)")
        return mapping

    @field_validator("uavs")
    @classmethod
    def _numbered(cls, uavs):
        bad = [i for i in uavs if i < 1]
        if bad:
            raise ValueError(f"UAVs are numbered from 1; got {bad[0]}")
        return dict(sorted(uavs.items()))


def load_map(path: Path, scenario) -> ReplayMap:
    """The map file at ``path``, checked against ``scenario`` (its UAVs exist); one readable error otherwise."""
    try:
        data = yaml.safe_load(Path(path).read_text(encoding="utf-8"))
    except OSError as exc:
        raise LogError(f"--map {path}: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise LogError(f"--map {path}: not a text (UTF-8) file, so not a map (byte {exc.start}: "
                       f"{exc.object[exc.start:exc.start + 1]!r}); a map is YAML (docs/replay.md)") from None
    except yaml.YAMLError as exc:
        raise LogError(f"--map {path}: not YAML ({str(exc).splitlines()[0]})") from None
    mapping = ReplayMap.checked(data, scenario, f"--map {path}")
    for sources in mapping.uavs.values():  # a UAV's own log is found beside the map file
        if sources.log is not None and not sources.log.is_absolute():
            sources.log = Path(path).parent / sources.log
    return mapping
