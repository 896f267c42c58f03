"""A run in Foxglove: :class:`FoxgloveView`, a :class:`~swarmtrack.streams.frame.Tap` that serves each step live
over foxglove-sdk's WebSocket server and/or logs it into an MCAP file, and :func:`write_mcap`, a finished recording
through the same channels (so a recorded run looks the same as the live view).

Topics (foxglove-sdk channels; every message stamped with the log time ``stamp_epoch + t`` in ns, ``t`` the run's
time):

- ``/scene``: ``foxglove.SceneUpdate`` (protobuf, foxglove-sdk's own schema and encoder), frame ``map`` (the world's
  x east, y north, z up, m). Its entities, each sent every step (an empty one clears what the last step drew):

  - ``uavs``: a sphere per UAV at its position (at its altitude in a 3-D world, else z = 0) and its 1-based number
    as text on it;
  - ``target``: the followed target's truth, when known (z = 0);
  - ``estimates``: each UAV's estimate of the target, a small sphere at its ``[x, y]`` (z = 0) and, after the
    centres in the same list, its **95 %** confidence
    ellipse of the x-y block of the covariance (χ²₂ quantile 5.991: semi-axes ``sqrt(5.991 λ)`` of the block's
    eigenvalues λ, turned by the major eigenvector's angle), drawn as a translucent sphere flattened to
    :data:`ELLIPSE_THICKNESS` (pose: the centre and a rotation about z; size: the two axes' full lengths);
  - ``sets``: IB21's sets (``frame.polygons``) as line loops, the swarm's (``uav`` 0) green, a UAV's purple;
  - ``formation``: W20's formation (``frame.formation``), a small grey sphere where each UAV is meant to be.

  No ``FrameTransform`` is sent: everything is in ``map``, and Foxglove's 3D panel takes its frames from the
  entities' ``frame_id``.
- ``/plot/NAME`` for each per-UAV series of ``frame.plots`` (``/plot/error``, m; ``/plot/nees``; what a driver
  adds, e.g. ``/plot/latency_ms``): JSON messages ``{"t": run time s, "uav1": value, "uav2": ...}`` with a JSON
  schema, which Foxglove's Plot panel reads as ``/plot/error.uav1`` (x axis: the log time, or ``.t``).

An absent UAV (``frame.present`` False) and a NaN value are left out (no sphere, no field).

The server is foxglove-sdk's: its WebSocket subprotocol is ``foxglove.sdk.v1`` (the Foxglove app connects; viewers
that only know the protocol's older name ``foxglove.websocket.v1``, such as older Lichtblick releases, are refused
at the handshake). MCAP files hold the same channels, LZ4-compressed (see :func:`_writer`), with a ``swarmtrack``
metadata record (scenario, seed, UAVs, ``stamp_epoch``).

Cost. A step's messages are built only for the sinks that take them: with no client subscribed and no MCAP,
:meth:`FoxgloveView.send` asks the channels whether they have a sink (``Channel.has_sinks``) and returns (2 µs;
0.2 µs between two steps the rate cap lets through). The live view is capped at ``rate`` steps per second of
wall clock (default :data:`LIVE_RATE`, what a screen shows; None: every step), which bounds what a run faster
than real time pays for its viewers; an MCAP file gets every step. The numbers are prepared with numpy, but
foxglove-sdk's messages are Python objects made one by one, so a step costs about 70 µs with 3 UAVs and 400 µs
with 50 when it is built (``benchmarks/bench_foxglove.py``, against 530 and 780 µs of the simulator's own step;
a lockstep live step is about 10 ms). The live server and the file have contexts of their own (the rate cap
differs) with the same channels; a message is encoded once and logged to both.
"""

from __future__ import annotations

import contextlib
import errno
import json
import math
import time
from collections.abc import Callable
from math import isfinite
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from swarmtrack.outputs import check_new_destination, partial_files
from swarmtrack.streams.frame import PLOTTED, StepFrame, frames

if TYPE_CHECKING:
    import foxglove

    from swarmtrack.sim.recorder import Recording

#: The confidence of the drawn covariance ellipse, and the χ² quantile with 2 degrees of freedom that scales it
#: (``-2 ln(1 - 0.95)``, exact for 2 degrees of freedom).
CONFIDENCE = 0.95
CHI2_2D = -2.0 * math.log(1.0 - CONFIDENCE)
#: The flattened sphere's thickness (m): an ellipse, seen from above.
ELLIPSE_THICKNESS = 0.02
#: Steps per second of wall clock the live view is sent at most (an MCAP file gets every step).
LIVE_RATE = 50.0
SCENE_TOPIC, PLOT_PREFIX, FRAME_ID = "/scene", "/plot/", "map"
#: Diameters (m) of a UAV, the target, an estimate's centre, a formation point; a UAV's number's size (pixels).
UAV_SIZE, TARGET_SIZE, CENTRE_SIZE, FORMATION_SIZE = 0.4, 0.4, 0.15, 0.2
LABEL_PX = 14.0
#: RGBA of each kind of thing drawn.
COLORS = {"uav": (0.2, 0.5, 1.0, 1.0), "label": (1.0, 1.0, 1.0, 1.0), "target": (0.9, 0.1, 0.1, 1.0),
          "estimate": (1.0, 0.6, 0.0, 1.0), "ellipse": (1.0, 0.6, 0.0, 0.35), "swarm_set": (0.1, 0.8, 0.2, 1.0),
          "uav_set": (0.6, 0.3, 0.9, 1.0), "formation": (0.6, 0.6, 0.6, 0.8)}


_PLUS_MINUS = np.array([1.0, -1.0])


class PortInUse(OSError):
    """The WebSocket server's port is held by another program: the message names the host and port."""


def ellipse_axes(covariance: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The :data:`CONFIDENCE` ellipses of the x-y blocks of ``covariance`` (M, n, n), n ≥ 2: semi-major and
    semi-minor axes (M,) (m) and the major axis's angle from x (M,) (rad, in (−π/2, π/2]). The eigen-decomposition
    of each symmetric 2×2 block ``[[p, r], [r, q]]`` in closed form, vectorised over the UAVs (cheaper than
    ``numpy.linalg.eigh`` for small blocks): eigenvalues ``(p + q)/2 ± hypot((p − q)/2, r)``, the major
    eigenvector at ``atan2(2r, p − q)/2``; semi-axes ``sqrt(χ² λ)`` (:data:`CHI2_2D`); an eigenvalue made slightly
    negative by rounding counts as 0."""
    p, q = covariance[:, 0, 0], covariance[:, 1, 1]
    r2, d = covariance[:, 0, 1] + covariance[:, 1, 0], p - q  # 2r (the block symmetrised), p − q
    lam = (0.5 * (p + q))[:, None] + (0.5 * np.hypot(d, r2))[:, None] * _PLUS_MINUS
    axes = np.sqrt(CHI2_2D * np.maximum(lam, 0.0))
    return axes[:, 0], axes[:, 1], 0.5 * np.arctan2(r2, d)


class RateCap:
    """At most ``rate`` yeses per second of ``clock`` (s): :meth:`due` says yes at the first call and then once
    ``1/rate`` s have passed since the last yes. ``rate`` None: always yes."""

    def __init__(self, rate: float | None, clock: Callable[[], float] = time.monotonic):
        if rate is not None and not rate > 0:
            raise ValueError(f"rate {rate}: a positive number of steps per second, or None")
        self.period = 0.0 if rate is None else 1.0 / rate
        self.clock = clock
        self._next = -math.inf

    def due(self) -> bool:
        if not self.period:
            return True
        now = self.clock()
        if now < self._next:
            return False
        self._next = now + self.period
        return True


class _Scene:
    """Builds a step's ``/scene`` SceneUpdate with foxglove-sdk's message classes (imported on first use, so this
    module imports without the ``foxglove`` extra). The numbers are prepared with numpy and turned into Python
    floats once per array (``tolist``); what is left per UAV is making its message objects, which foxglove-sdk only
    offers one by one. The constant parts (colours, sizes, the identity rotation) are made once."""

    def __init__(self) -> None:
        from foxglove import messages as m

        self.m = m
        self.color = {k: m.Color(r=c[0], g=c[1], b=c[2], a=c[3]) for k, c in COLORS.items()}
        self.size = {k: m.Vector3(x=s, y=s, z=s) for k, s in
                     (("uav", UAV_SIZE), ("target", TARGET_SIZE), ("centre", CENTRE_SIZE),
                      ("formation", FORMATION_SIZE))}
        self.identity = m.Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)
        self.line_loop = m.LinePrimitiveLineType.LineLoop

    def _sphere(self, x: float, y: float, z: float, size: str, color: str) -> Any:
        m = self.m
        return m.SpherePrimitive(pose=m.Pose(position=m.Vector3(x=x, y=y, z=z), orientation=self.identity),
                                 size=self.size[size], color=self.color[color])

    def _uavs(self, frame: StepFrame) -> dict:
        """A sphere per UAV and its number on it (the same pose: at a distance, the number marks the UAV)."""
        m, q, c_uav, c_label, s_uav = self.m, self.identity, self.color["uav"], self.color["label"], self.size["uav"]
        z = [0.0] * len(frame.uav) if frame.uav_altitude is None else frame.uav_altitude.tolist()
        spheres, texts = [], []
        for number, (x, y), h, here in zip(frame.uavs.tolist(), frame.uav[:, :2].tolist(), z,
                                           frame.present.tolist(), strict=True):
            if here and isfinite(x) and isfinite(y) and isfinite(h):
                pose = m.Pose(position=m.Vector3(x=x, y=y, z=h), orientation=q)
                spheres.append(m.SpherePrimitive(pose=pose, size=s_uav, color=c_uav))
                texts.append(m.TextPrimitive(pose=pose, billboard=True, font_size=LABEL_PX, scale_invariant=True,
                                             color=c_label, text=str(number)))
        return {"spheres": spheres, "texts": texts}

    def _target(self, frame: StepFrame) -> dict:
        if frame.target is None:
            return {}
        x, y = frame.target[:2].tolist()
        return {"spheres": [self._sphere(x, y, 0.0, "target", "target")]} if isfinite(x) and isfinite(y) else {}

    def _estimates(self, frame: StepFrame) -> dict:
        """Each present UAV's estimate: a small sphere at its centre and its ellipse, sharing one pose (the centre
        and the ellipse's rotation, which a sphere does not show)."""
        if frame.estimate is None or frame.covariance is None:
            return {}
        m, c_ellipse, c_centre, s_centre = self.m, self.color["ellipse"], self.color["estimate"], self.size["centre"]
        major, minor, angle = ellipse_axes(frame.covariance)  # NaN where the block has one
        half = 0.5 * angle
        centres, ellipses = [], []
        for (x, y), a, b, qz, qw, here in zip(frame.estimate[:, :2].tolist(), major.tolist(), minor.tolist(),
                                              np.sin(half).tolist(), np.cos(half).tolist(), frame.present.tolist(),
                                              strict=True):
            if not (here and isfinite(x) and isfinite(y)):
                continue
            shown = isfinite(a) and isfinite(b)
            pose = m.Pose(position=m.Vector3(x=x, y=y, z=0.0),
                          orientation=m.Quaternion(x=0.0, y=0.0, z=qz, w=qw) if shown else self.identity)
            centres.append(m.SpherePrimitive(pose=pose, size=s_centre, color=c_centre))
            if shown:
                ellipses.append(m.SpherePrimitive(pose=pose, size=m.Vector3(x=2 * a, y=2 * b, z=ELLIPSE_THICKNESS),
                                                  color=c_ellipse))
        return {"spheres": centres + ellipses}

    def _sets(self, frame: StepFrame) -> dict:
        m, lines = self.m, []
        for owner, vertices in frame.polygons:
            points = [m.Point3(x=x, y=y, z=0.0) for x, y in np.asarray(vertices, dtype=float)[:, :2].tolist()
                      if isfinite(x) and isfinite(y)]
            if len(points) >= 2:
                lines.append(m.LinePrimitive(type=self.line_loop, thickness=2.0, scale_invariant=True, points=points,
                                             color=self.color["swarm_set" if owner == 0 else "uav_set"]))
        return {"lines": lines}

    def _formation(self, frame: StepFrame) -> dict:
        if frame.formation is None:
            return {}
        return {"spheres": [self._sphere(x, y, 0.0, "formation", "formation")
                            for x, y in np.asarray(frame.formation, dtype=float)[:, :2].tolist()
                            if isfinite(x) and isfinite(y)]}

    def update(self, frame: StepFrame, ns: int) -> bytes:
        """The step's SceneUpdate, encoded (protobuf), stamped ``ns`` (ns since the Unix epoch): every entity,
        an empty one too (it clears what the last step drew)."""
        m = self.m
        stamp = m.Timestamp(ns // 1_000_000_000, ns % 1_000_000_000)
        entities = [m.SceneEntity(timestamp=stamp, frame_id=FRAME_ID, id=name, **primitives)
                    for name, primitives in (("uavs", self._uavs(frame)), ("target", self._target(frame)),
                                             ("estimates", self._estimates(frame)), ("sets", self._sets(frame)),
                                             ("formation", self._formation(frame)))]
        return m.SceneUpdate(entities=entities).encode()


def plot_message(frame: StepFrame, values: np.ndarray, keys: list[str]) -> bytes:
    """A ``/plot/NAME`` message: ``{"t": frame.t, "uavK": value, ...}`` (JSON, UTF-8) of the present UAVs with a
    finite value; ``keys`` the field of each of ``frame.uavs``. Python's ``repr`` of a float: exact."""
    fields: dict[str, float] = {"t": frame.t}
    for key, value, here in zip(keys, values.tolist(), frame.present.tolist(), strict=True):
        if here and isfinite(value):
            fields[key] = value
    return json.dumps(fields).encode()


def _plot_schema(name: str, n_uavs: int) -> dict:
    each = {"type": "number", "description": f"{name} of this UAV (left out while it is absent or NaN)"}
    return {"title": f"swarmtrack.plot.{name}", "type": "object",
            "description": f"{name} of each UAV at one step of the run",
            "properties": {"t": {"type": "number", "description": "the run's time (s)"},
                           **{f"uav{i}": each for i in range(1, n_uavs + 1)}}}


class _Sink:
    """One foxglove-sdk context (the live server's, or the MCAP file's) and its channels: ``/scene``, and a
    ``/plot/NAME`` channel for each series, made when first seen (advertised to clients then)."""

    def __init__(self, n_uavs: int, plots: list[str]):
        import foxglove
        from foxglove.messages import SceneUpdate

        self.context = foxglove.Context()
        self.n_uavs = n_uavs
        self.scene = foxglove.Channel(SCENE_TOPIC, schema=SceneUpdate.get_schema(), message_encoding="protobuf",
                                      context=self.context)
        self.plots: dict[str, foxglove.Channel] = {}
        for name in plots:
            self.plot(name)

    def plot(self, name: str) -> foxglove.Channel:
        channel = self.plots.get(name)
        if channel is None:
            import foxglove

            channel = self.plots[name] = foxglove.Channel(PLOT_PREFIX + name, schema=_plot_schema(name, self.n_uavs),
                                                          context=self.context)
        return channel

    def watched(self) -> set[str]:
        return {c.topic() for c in (self.scene, *self.plots.values()) if c.has_sinks()}

    def close(self) -> None:
        for channel in (self.scene, *self.plots.values()):
            channel.close()


class _Logger:
    """Logs steps into sinks: each message built once, only when a sink's channel takes it, and logged to each
    such channel. ``stamp_ns``: the log time of the run's t = 0 (ns since the Unix epoch)."""

    def __init__(self, stamp_ns: int):
        self.stamp_ns = stamp_ns
        self.scene = _Scene()
        self._keys: dict[bytes, list[str]] = {}

    def keys(self, uavs: np.ndarray) -> list[str]:
        """The plot fields of ``uavs`` (``uav1`` ...), remembered for the swarm's usual list."""
        tag = uavs.tobytes()
        found = self._keys.get(tag)
        if found is None:
            found = self._keys[tag] = [f"uav{n}" for n in uavs.tolist()]
        return found

    def log(self, frame: StepFrame, sinks: list[_Sink]) -> None:
        ns = self.stamp_ns + round(frame.t * 1e9)
        scene = [s.scene for s in sinks if s.scene.has_sinks()]
        if scene:
            data = self.scene.update(frame, ns)
            for channel in scene:
                channel.log(data, log_time=ns)
        for name, values in frame.plots.items():
            plots = [c for c in (s.plot(name) for s in sinks) if c.has_sinks()]
            if plots:
                data = plot_message(frame, np.asarray(values, dtype=float), self.keys(frame.uavs))
                for channel in plots:
                    channel.log(data, log_time=ns)


def _ns(seconds: float) -> int:
    """``seconds`` (since the Unix epoch) in ns, its whole seconds apart (a float of ~1.7e18 ns is off by up to
    128 ns)."""
    whole, fraction = divmod(float(seconds), 1.0)
    return int(whole) * 1_000_000_000 + round(fraction * 1e9)


def _n_uavs(meta: dict) -> int:
    start, stop = meta["groups"]["uavs"]
    return stop - start


def _plots_of(meta: dict) -> list[str]:
    """The series every step of a run with these ``meta`` carries, advertised from the start: the errors
    (:func:`~swarmtrack.streams.frame.errors`: a followed target and an estimate with its covariance) and the
    recorded columns a frame plots as they are (:data:`~swarmtrack.streams.frame.PLOTTED`)."""
    probes = meta.get("probes", {})
    errors = meta.get("tracked") is not None and {"estimate", "covariance"} <= set(probes)
    return ["error", "nees"] * errors + [name for name in PLOTTED if list(probes.get(name, [None])) == []]


def _writer(path: Path, context: foxglove.Context, meta: dict, stamp_epoch: float):
    """foxglove-sdk's MCAP writer into ``path`` (a fresh temporary file), with the run's name as metadata. Its
    chunks are LZ4-compressed: the compression runs in the thread that logs (the run's), and LZ4 costs about a
    third of foxglove-sdk's default zstd there (26 against 70 µs for a 50-UAV scene of 20 kB) for files about a
    third larger (5.0 against 3.7 kB a step)."""
    import foxglove
    from foxglove.mcap import MCAPCompression, MCAPWriteOptions

    writer = foxglove.open_mcap(path, allow_overwrite=True, context=context,
                                writer_options=MCAPWriteOptions(compression=MCAPCompression.Lz4))
    writer.write_metadata("swarmtrack", {"scenario": str(meta.get("scenario", "")), "seed": str(meta.get("seed", "")),
                                         "uavs": str(_n_uavs(meta)), "stamp_epoch": repr(float(stamp_epoch))})
    return writer


class FoxgloveView:
    """A live Foxglove view of a run (the module docstring lists its topics): :meth:`open` starts foxglove-sdk's
    WebSocket server on ``host:port`` (``server``; port 0: a free one, :attr:`port` says which) and/or an MCAP
    file writer (``mcap``: written to a temporary file beside it, renamed at :meth:`close`; an existing file is
    refused, :class:`~swarmtrack.outputs.OutputError`); :meth:`send` each step; :meth:`close` stops both
    (idempotent). ``rate``: steps per second of wall clock sent to the live view at most (None: every step; the
    MCAP file gets every step). ``stamp_epoch``: the log time (s since the Unix epoch) of the run's t = 0, by
    default the wall clock at :meth:`open`. A port held by another program: :class:`PortInUse`."""

    def __init__(self, host: str = "127.0.0.1", port: int = 8765, mcap: Path | None = None, server: bool = True, *,
                 rate: float | None = LIVE_RATE, stamp_epoch: float | None = None):
        if not server and mcap is None:
            raise ValueError("a Foxglove view needs its server, an MCAP file, or both")
        self.host, self.mcap, self.server = host, None if mcap is None else Path(mcap), server
        self._port, self.stamp_epoch = port, stamp_epoch
        self._cap = RateCap(rate)
        self._live: _Sink | None = None
        self._file: _Sink | None = None
        self._logger: _Logger | None = None
        self._server: Any = None
        self._stack: contextlib.ExitStack | None = None

    @property
    def port(self) -> int:
        """The port the server listens on (the one asked for until :meth:`open`; a free one for 0)."""
        return self._port

    @property
    def url(self) -> str:
        """What Foxglove opens (Open connection → Foxglove WebSocket)."""
        return f"ws://{self.host}:{self.port}"

    def open(self, meta: dict) -> None:
        """Start the server and/or the MCAP file for the run of ``meta``; nothing is left running or written when
        one of them cannot start."""
        if self._logger is not None:
            raise RuntimeError("this Foxglove view is open already")
        if self.stamp_epoch is None:
            self.stamp_epoch = time.time()
        n, plots = _n_uavs(meta), _plots_of(meta)
        stack = contextlib.ExitStack()
        try:
            if self.mcap is not None:
                check_new_destination(self.mcap, option="mcap", rule="a Foxglove view never replaces a file")
                [tmp] = stack.enter_context(partial_files([self.mcap], keep_suffix=True, overwrite=False))
                self._file = _Sink(n, plots)
                stack.callback(self._file.close)
                stack.enter_context(_writer(tmp, self._file.context, meta, self.stamp_epoch))
            if self.server:
                self._live = _Sink(n, plots)
                stack.callback(self._live.close)
                self._server = _start_server(self.host, self._port, self._live.context,
                                             f"swarmtrack {meta.get('scenario', '')}".strip())
                stack.callback(self._server.stop)
                self._port = self._server.port  # the one chosen for port 0
        except BaseException as exc:
            self._live = self._file = self._server = None
            stack.__exit__(type(exc), exc, exc.__traceback__)  # the MCAP's temporary file removed (partial_files)
            raise
        self._stack = stack
        self._logger = _Logger(_ns(self.stamp_epoch))

    def watched(self) -> set[str]:
        """The topics a live client is subscribed to now."""
        return set() if self._live is None else self._live.watched()

    def send(self, frame: StepFrame) -> None:
        """Log one step: into the MCAP file, and to the live view's subscribers when the rate cap lets it."""
        file, live, logger = self._file, self._live, self._logger
        if logger is None:
            return
        if live is not None and self._cap.due():
            logger.log(frame, [live] if file is None else [file, live])
        elif file is not None:
            logger.log(frame, [file])

    def close(self) -> None:
        """Stop the server and finish the MCAP file (renamed into place); again: nothing."""
        stack, self._stack = self._stack, None
        self._logger = self._live = self._file = self._server = None
        if stack is not None:
            stack.close()


def _start_server(host: str, port: int, context: foxglove.Context, name: str):
    """foxglove-sdk's WebSocket server on ``host:port`` for ``context``'s channels; a port in use:
    :class:`PortInUse`."""
    import foxglove

    try:
        return foxglove.start_server(name=name, host=host, port=port, context=context)
    except RuntimeError as exc:
        text = str(exc).removeprefix("FoxgloveError: ")
        if "in use" in text.lower():
            in_use = PortInUse(f"{host}:{port} is in use (another program listens there): choose another port")
            in_use.errno = errno.EADDRINUSE
            raise in_use from None
        raise OSError(f"the Foxglove view cannot serve on {host}:{port}: {text}") from None


def write_mcap(recording: Recording, path: Path, stamp_epoch: float = 0.0) -> int:
    """Write every step of ``recording`` (:func:`~swarmtrack.streams.frame.frames`) into a new MCAP file ``path``
    through the live view's channels; log times ``stamp_epoch`` (s since the Unix epoch) + the run's time, by
    default the run's time itself (as ``swarmtrack export``'s ROS 2 bags). Written to a temporary file beside
    ``path`` and renamed at the end: an error or Ctrl-C leaves nothing (only that temporary file is deleted); an
    existing ``path`` is refused (:class:`~swarmtrack.outputs.OutputError`). Returns the number of steps."""
    path = Path(path)
    check_new_destination(path, option="mcap", rule="an export never replaces anything")
    sink = _Sink(_n_uavs(recording.meta), _plots_of(recording.meta))
    logger = _Logger(_ns(stamp_epoch))
    steps = 0
    try:
        with partial_files([path], keep_suffix=True, overwrite=False) as [tmp]:
            with _writer(tmp, sink.context, recording.meta, stamp_epoch):
                for frame in frames(recording):
                    logger.log(frame, [sink])
                    steps += 1
    finally:
        sink.close()
    return steps
