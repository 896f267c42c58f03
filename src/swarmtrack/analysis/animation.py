"""The animation of one guaranteed search-and-track run (IB21's videos; ``swarmtrack run SCENARIO --animate out.gif``).

The sets exist only onboard and only at each instant, so the frames are captured while the run runs: a
:class:`FrameCapture` is the step loop's ``on_step`` hook (:func:`swarmtrack.sim.engine.step_loop`), which records
nothing, so the recording and every metric are those of a run without it. It is called once per estimation step,
after the fusion and the step's record: it keeps every UAV's true position (the paths) and, every
``every`` seconds of simulated time, a frame: the sets of the view (three geometries, so a long run's frames stay
small), each UAV's footprint, the true targets and decoys, and Φ̄.

**What a frame shows.** The area X0, and the sets of the **union over the UAVs** (the default): X̄ drawn is ∪_i X̄_i
(what at least one UAV has not yet explored), Xᵁ is ∪_i Xᵁ_i, X is ∪_i ∪_j X_{i,j}. Every UAV's sets lie inside it,
so every true target is inside the drawn union while the guarantee holds, whichever UAV one asks. ``uav=k`` shows UAV
k's own sets instead (its Φ_k is the area of their union). Over the sets: each UAV's footprint (its colour) and path
over the last :data:`TRAIL` s (the whole path of a 400 s mission hides the sets), the true targets (green dots) and
decoys (grey crosses). The title gives t, Φ̄ (eq. 11) and the view.

Files are written beside their destination under a hidden temporary name and renamed into place when complete
(an interruption leaves nothing); an existing file is replaced only with ``overwrite``. GIF through matplotlib's
``PillowWriter``; MP4 through ``FFMpegWriter``, only where an ``ffmpeg`` executable exists.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import shapely

from swarmtrack.estimation.polygons import union_all
from swarmtrack.estimation.raster import to_polygon
from swarmtrack.estimation.setmembership import SetMembershipEstimator
from swarmtrack.models import fixed_wing
from swarmtrack.outputs import OutputError, check_file_destination, partial_files
from swarmtrack.sensors.footprint import footprint_corners, footprint_polygons
from swarmtrack.sim import engine

__all__ = ["FORMATS", "AnimationError", "Frame", "FrameCapture", "check_destination", "render", "simulate_animated",
           "view_sets"]

#: Output formats by file suffix.
FORMATS = (".gif", ".mp4")
FPS = 10  #: frames shown per second of the file (a frame per second of the run: 10× real time)
DPI = 80
TRAIL = 30.0  #: s of each UAV's path drawn behind it
SET_STYLE = {"unexplored": ("tab:blue", 0.22, r"$\bar X$ unexplored"),
             "unidentified": ("tab:orange", 0.55, r"$X^U$ detected, unidentified"),
             "identified": ("tab:red", 0.65, r"$X$ identified targets")}
"""Face colour, opacity and legend of each set (the colours of the parts in
:func:`swarmtrack.capabilities.set_membership.figures.plot_uncertainty`)."""


class AnimationError(ValueError):
    """A request that cannot give an animation (a scenario without sets, a destination, a missing encoder)."""


@dataclass(frozen=True)
class Frame:
    """One captured instant: ``t`` (s), the sets of the view (:func:`view_sets`: ``unexplored``, ``unidentified``,
    ``identified``, one geometry each), each UAV's footprint ``footprints`` (N,), the true positions ``targets``
    (T, 2) and ``decoys`` (D, 2), ``step`` (how many UAV positions of the path precede it) and ``phi_bar`` (Φ̄, m²)."""

    t: float
    unexplored: shapely.Geometry
    unidentified: shapely.Geometry
    identified: shapely.Geometry
    footprints: np.ndarray
    targets: np.ndarray
    decoys: np.ndarray
    step: int
    phi_bar: float


class FrameCapture:
    """The step loop's ``on_step`` hook (truth side, :func:`swarmtrack.sim.engine.step_loop`): captures a
    :class:`Frame` every ``every`` s of simulated time (the first at t = 0), its sets seen as ``uav``
    (:func:`view_sets`), and the UAVs' true positions at every call; it changes nothing. The simulation it watches
    is ``sim`` from the first call on."""

    def __init__(self, every: float = 1.0, uav: int | None = None):
        if every <= 0:
            raise AnimationError(f"--animate-every {every:g}: must be positive")
        self.every, self.uav, self.sim = float(every), uav, None
        self.frames: list[Frame] = []
        self.path: list[np.ndarray] = []
        self._next = 0.0

    def _start(self, sim) -> None:
        if not isinstance(sim.stack.estimator, SetMembershipEstimator):
            raise AnimationError("the animation shows a set-membership estimator's sets; this scenario has none "
                                 "(estimator.kind: setmembership)")
        n = sim.world.slices["uavs"].stop - sim.world.slices["uavs"].start
        if self.uav is not None and not 1 <= self.uav <= n:
            raise AnimationError(f"--animate-uav {self.uav}: the run has UAVs 1-{n}")
        self.sim, self.n_uavs = sim, n
        self.area = sim.meta["estimator"]["area"]
        self._params = sim.world.sensor.params

    def __call__(self, sim) -> None:
        if self.sim is None:
            self._start(sim)
        world = sim.world
        self.path.append(world.truth("uavs")[:, :2])
        if world.t >= self._next - 1e-9:
            self.frames.append(self._frame(world))
            self._next = (np.floor(world.t / self.every + 1e-9) + 1) * self.every

    def _frame(self, world) -> Frame:
        b = self.sim.stack.estimator.beliefs
        s = world.kinematic("uavs").state
        corners = footprint_corners(s[:, [fixed_wing.X, fixed_wing.Y]], s[:, fixed_wing.PSI], s[:, fixed_wing.Z],
                                    self._params.tan_half, self._params.orientation)
        phi = self.sim.stack.estimator.sample()["phi"]
        return Frame(float(world.t), **view_sets(b, self.uav), footprints=footprint_polygons(corners),
                     targets=world.truth("targets")[:, :2], decoys=world.truth("decoys")[:, :2], step=len(self.path),
                     phi_bar=float(np.mean(phi)))


def simulate_animated(scenario, every: float = 1.0, uav: int | None = None,
                      progress: Callable[[float], None] | None = None, record_to: Path | None = None):
    """:func:`swarmtrack.sim.engine.simulate` with a :class:`FrameCapture` as its ``on_step`` hook (a frame every
    ``every`` s, the sets seen as ``uav``): ``(recording, capture)``. The recording is the one ``simulate`` gives
    (same probes, same numbers: the capture only reads)."""
    if uav is not None and not 1 <= uav <= scenario.swarm.n_uavs:
        raise AnimationError(f"--animate-uav {uav}: the run has UAVs 1-{scenario.swarm.n_uavs}")
    capture = FrameCapture(every, uav)
    return engine.simulate(scenario, progress, record_to, on_step=capture), capture


def view_sets(beliefs, uav: int | None = None) -> dict[str, shapely.Geometry]:
    """The sets a frame draws, from the UAVs' ``beliefs`` (:class:`~swarmtrack.estimation.setmembership.Beliefs`):
    ``unexplored`` X̄, ``unidentified`` Xᵁ and ``identified`` X = ∪_j X_j, each the union over the UAVs (``uav``
    None) or UAV ``uav``'s own (1-based)."""
    rows = slice(None) if uav is None else slice(uav - 1, uav)
    grid = getattr(beliefs, "grid", None)  # raster sets (estimator.sets: raster): drawn as their member squares
    out = {}
    for name in ("unexplored", "unidentified", "identified"):
        sets = np.asarray(getattr(beliefs, name)[rows], dtype=object).ravel()
        if grid is not None:
            sets = [to_polygon(grid, f) for f in {id(f): f for f in sets}.values()]  # each distinct object once
        out[name] = union_all(sets)
    return out


def _polygonal(geom):
    """The polygons of ``geom`` as one (Multi)Polygon, or None when it has no area."""
    parts = [p for p in shapely.get_parts(geom) if isinstance(p, shapely.Polygon | shapely.MultiPolygon)
             and not p.is_empty]
    return shapely.union_all(parts) if parts else None


class _Canvas:
    """The animation's figure: the axes, area X0 and legend drawn once, and per frame only what moves (the sets,
    footprints, paths, targets, decoys and the title), so a frame costs one draw, not a new layout."""

    def __init__(self, capture: FrameCapture, title: str):
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
        from matplotlib.lines import Line2D
        from matplotlib.patches import Patch

        from swarmtrack.analysis.figure_style import DECOY_COLOR, TARGET_COLOR  # matplotlib: only when drawing

        self.capture, self.title = capture, title
        self.fig = Figure(figsize=(6.4, 7.2), dpi=DPI)
        FigureCanvasAgg(self.fig)
        self.fig.subplots_adjust(left=0.12, right=0.97, top=0.91, bottom=0.17)
        ax = self.ax = self.fig.subplots()
        x0, y0, x1, y1 = capture.area
        ax.plot([x0, x1, x1, x0, x0], [y0, y0, y1, y1, y0], color="black", lw=1.0, zorder=5)
        pad = 0.03 * max(x1 - x0, y1 - y0)
        ax.set_xlim(x0 - pad, x1 + pad)
        ax.set_ylim(y0 - pad, y1 + pad)
        ax.set_aspect("equal")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        handles = [Patch(facecolor=c, alpha=a, label=label) for c, a, label in SET_STYLE.values()]
        handles += [Patch(facecolor="none", edgecolor="black", label=f"footprints, paths (last {TRAIL:g} s)"),
                    Line2D([], [], ls="none", marker="o", color=TARGET_COLOR, mec="black", label="targets (true)"),
                    Line2D([], [], ls="none", marker="x", mew=2.0, color=DECOY_COLOR, label="decoys (true)")]
        ax.legend(handles=handles, fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.09), ncol=3)
        self.moving: list = []

    def draw(self, frame: Frame) -> None:
        """Replace what moves by ``frame``'s."""
        from shapely.plotting import patch_from_polygon

        from swarmtrack.analysis.figure_style import DECOY_COLOR, TARGET_COLOR, agent_color  # matplotlib

        for artist in self.moving:
            artist.remove()
        ax, self.moving = self.ax, []
        for name in SET_STYLE:
            poly = _polygonal(getattr(frame, name))
            if poly is not None:
                color, alpha, _ = SET_STYLE[name]
                self.moving.append(ax.add_artist(patch_from_polygon(poly, facecolor=color, alpha=alpha,
                                                                   edgecolor=color, lw=0.4)))
        trail = int(round(TRAIL / self.capture.sim.clock.dt_estimation))
        path = np.asarray(self.capture.path[max(0, frame.step - trail):frame.step])  # (k, N, 2)
        for i, fp in enumerate(frame.footprints):
            color = agent_color(i)
            self.moving.append(ax.add_artist(patch_from_polygon(fp, facecolor="none", edgecolor=color, lw=1.2)))
            self.moving += ax.plot(path[:, i, 0], path[:, i, 1], color=color, lw=0.8, alpha=0.8)
            self.moving += ax.plot(path[-1, i, 0], path[-1, i, 1], marker="o", ms=4, color=color)
        self.moving += ax.plot(frame.targets[:, 0], frame.targets[:, 1], "o", ms=6, color=TARGET_COLOR, mec="black",
                               mew=0.6, zorder=6)
        self.moving += ax.plot(frame.decoys[:, 0], frame.decoys[:, 1], "x", ms=7, mew=2.0, color=DECOY_COLOR,
                               zorder=6)
        ax.set_title(f"{self.title}\nt = {frame.t:g} s, " + r"$\bar\Phi$" + f" = {frame.phi_bar:,.0f} m$^2$",
                     fontsize=9)


def _writer(suffix: str):
    from matplotlib.animation import FFMpegWriter, PillowWriter
    from PIL import Image

    class PaletteWriter(PillowWriter):
        """matplotlib's GIF writer keeping each frame in 256 colours as it comes (the GIF's own depth), not as RGBA:
        a quarter of the memory (a 400 s run's 400 frames: ≈ 120 MB, not 470)."""

        def grab_frame(self, **savefig_kwargs):
            super().grab_frame(**savefig_kwargs)
            self._frames[-1] = self._frames[-1].convert("RGB").quantize(256, method=Image.Quantize.FASTOCTREE)

    if suffix == ".gif":
        return PaletteWriter(fps=FPS)
    if not FFMpegWriter.isAvailable():
        raise AnimationError("an .mp4 needs ffmpeg, which is not installed here; write a .gif instead")
    return FFMpegWriter(fps=FPS)


def check_destination(path: Path, overwrite: bool = False) -> None:
    """Refuse ``path`` before anything runs: a suffix other than :data:`FORMATS`, an .mp4 without ffmpeg, a folder,
    an existing file without ``overwrite``, a folder that does not exist or cannot be written to."""
    path = Path(path)
    if path.suffix.lower() not in FORMATS:
        raise AnimationError(f"--animate {path}: the file must end in {' or '.join(FORMATS)}")
    _writer(path.suffix.lower())
    try:
        check_file_destination(path, "--animate", overwrite)
    except OutputError as exc:
        raise AnimationError(str(exc)) from None


def render(capture: FrameCapture, path: Path, title: str = "", overwrite: bool = False,
           progress: Callable[[float], None] | None = None) -> Path:
    """Write the captured frames to ``path`` (.gif or .mp4) through a hidden temporary file renamed into place when
    complete, ``title`` above each (with the view, t and Φ̄); ``progress``: told the fraction of frames drawn.
    Returns ``path``."""
    path = Path(path)
    check_destination(path, overwrite)
    if not capture.frames:
        raise AnimationError("no frame was captured")
    uav = capture.uav
    canvas = _Canvas(capture, title + (" (sets: union over the UAVs)" if uav is None else f" (sets: UAV {uav}'s)"))
    try:  # a file that appeared while the run ran is never replaced without overwrite
        with partial_files([path.absolute()], keep_suffix=True, overwrite=overwrite) as (tmp,):
            writer = _writer(path.suffix.lower())
            with writer.saving(canvas.fig, str(tmp), DPI):
                for k, frame in enumerate(capture.frames):
                    canvas.draw(frame)
                    writer.grab_frame()
                    if progress is not None:
                        progress((k + 1) / len(capture.frames))
    except OutputError as exc:
        raise AnimationError(f"--animate {exc}") from None
    finally:
        canvas.fig.clear()
    return path
