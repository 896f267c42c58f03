"""System identification of the UAV's position-controlled dynamics (W20 Secs. 2.5.1.2 and 5.4.1).

The input is the setpoint of the UAV's own position controller (W20 eq. 2.29), the state per axis is
``[p, v]``, and W20 fits, axis by axis and with no coupling between x and y,

    ``[p, v]_{k+1} = A [p, v]_k + B u_k``        (W20 eq. 2.30; ``A`` 2x2, ``B`` 2x1)

by linear least squares (eqs. 2.31-2.36): the regressor matrix ``G`` holds the samples ``1..n−1`` of
``[p, v, u]`` (eq. 2.33), the targets ``l`` the samples ``2..n`` (eq. 2.32), one row of ``[A | B]`` at a time
(eqs. 2.34, 2.36). Here both rows are solved in one ``numpy.linalg.lstsq`` call (the same problem), never by
inverting ``GᵀG``. The two axes are assembled into the 4-state model of eq. 5.32, state ``[x, y, vx, vy]``,
input ``[ux, uy]``.

A log is a mapping of column name to 1-D array (a ``dict``, or a ``pandas.DataFrame``) with the columns
``t, x, y, vx, vy, ux, uy`` (s, m, m/s, m setpoint): ``u_k`` is the setpoint held from ``t_k`` to ``t_{k+1}``,
sampled at a fixed period ``T``. CSV files carry the same columns (:func:`write_log_csv`, :func:`read_log_csv`).

What the identified model says of the MPC's limits (issue 42): :func:`vehicle_bound` (the input bound a vehicle's
acceleration limit allows), :func:`error_tube` and :func:`navigation_margin` (the separation constraint's tightening);
numpy only, so that validating a scenario derives them without loading the controller.

Onboard-side code: nothing of the simulator is imported here at module level; :func:`step_response_log`, which
flies the simulator's quadrotor to make a log, imports it when called.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

COLUMNS = ("t", "x", "y", "vx", "vy", "ux", "uy")
AXES = {"x": ("x", "vx", "ux"), "y": ("y", "vy", "uy")}
MIN_SAMPLES = 10
"""Fewest samples per axis: 10 samples give 9 regression rows for the 3 unknowns of each row of eq. 2.30 (three
times as many equations as unknowns). A chosen floor, not from W20; a useful log has hundreds (W20 flew steps that
settle in seconds, sampled at a fraction of a second)."""
TIME_TOLERANCE = 1e-6
"""Sample intervals may differ from their mean by this fraction of it (plus the float resolution of the stamps)."""
MAX_CONDITION = 1e10
"""Largest condition number of the column-scaled regressor matrix ``G`` accepted: beyond it ``[p, v, u]`` are
(nearly) linearly dependent and the least-squares solution is not determined by the data."""


def _frozen(array) -> np.ndarray:
    out = np.array(array, dtype=float)
    out.setflags(write=False)
    return out


@dataclass(frozen=True)
class AxisModel:
    """One axis of eq. 2.30: ``A`` (2, 2), ``B`` (2, 1) and the fit on position in percent (:func:`fit_percent`)."""

    A: np.ndarray
    B: np.ndarray
    fit: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "A", _frozen(self.A).reshape(2, 2))
        object.__setattr__(self, "B", _frozen(self.B).reshape(2, 1))


@dataclass(frozen=True)
class LinearModel:
    """A UAV model ``x_{k+1} = A x_k + B u_k`` with state ``[x, y, vx, vy]`` and input ``[ux, uy]`` (the position
    controller's setpoint), period ``T`` s, as the W20 MPC uses it (eq. 5.32)."""

    A: np.ndarray
    B: np.ndarray
    T: float
    source: str = ""

    def __post_init__(self) -> None:
        A, B = check_model(self.A, self.B)
        object.__setattr__(self, "A", _frozen(A))
        object.__setattr__(self, "B", _frozen(B))


@dataclass(frozen=True)
class Identified:
    """The result of :func:`identify`: the 4-state model (``A`` 4x4, ``B`` 4x2, eq. 5.32 layout), its period ``T``
    s, the per-axis models and fits, and the number of samples used."""

    A: np.ndarray
    B: np.ndarray
    T: float
    x: AxisModel
    y: AxisModel
    n_samples: int

    @property
    def fits(self) -> dict[str, float]:
        """Fit on position per axis, percent."""
        return {"x": self.x.fit, "y": self.y.fit}

    @property
    def model(self) -> LinearModel:
        return LinearModel(self.A, self.B, self.T, source="identified")


def spectral_radius(A) -> float:
    """Largest eigenvalue modulus of ``A``."""
    return float(np.max(np.abs(np.linalg.eigvals(np.asarray(A, dtype=float)))))


def check_model(A, B) -> tuple[np.ndarray, np.ndarray]:
    """``(A, B)`` as float arrays, or ValueError naming the cause: not numbers, wrong shape (``A`` must be 4x4 and
    ``B`` 4x2, the eq. 5.32 layout), non-finite entries, or unstable (spectral radius of ``A`` ≥ 1)."""
    try:
        A = np.array(A, dtype=float)
        B = np.array(B, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"model A and B must be matrices of numbers ({exc})") from None
    if A.shape != (4, 4):
        raise ValueError(f"model A must be 4x4 (state [x, y, vx, vy]), got shape {A.shape}")
    if B.shape != (4, 2):
        raise ValueError(f"model B must be 4x2 (state [x, y, vx, vy], input [ux, uy]), got shape {B.shape}")
    if not (np.isfinite(A).all() and np.isfinite(B).all()):
        raise ValueError("model A and B must be finite (found NaN or inf)")
    rho = spectral_radius(A)
    if rho >= 1.0:
        raise ValueError(f"model A is unstable: spectral radius {rho:.6g} ≥ 1")
    return A, B


# The two models W20 identified, exactly as printed. Steady-state gains below are (I − A)⁻¹ B, computed from these
# numbers; a setpoint-tracking vehicle would give position gain 1 and velocity gain 0.
W20_SIMULATOR = LinearModel(
    A=[[0.920, 0, 0.084, 0], [0, 0.920, 0, 0.084], [-0.228, 0, 0.905, 0], [0, -0.228, 0, 0.905]],
    B=[[0.0006019, 0], [0, 0.0006019], [0.02375, 0], [0, 0.02375]],
    T=0.2,
    source="W20 eq. 5.32 (V-REP quadrotor)",
)
"""W20 eq. 5.32, identified on V-REP's quadrotor from one step in x and y. Stable: eigenvalues 0.9125 ± 0.1382i
(spectral radius 0.923) on each axis. It does not behave like position and velocity of a vehicle tracking its
setpoint: the steady state of a unit setpoint step is position 0.0767 m and velocity 0.0659 m/s (a vehicle at rest
with a non-zero velocity), and ``b1/(1 − a11) = 0.0006019/0.080 ≈ 0.0075``; ``a12 = 0.084`` where a position-velocity
pair sampled at ``T`` has ``a12 ≈ T`` (0.2 s) and ``b2 = 0.02375`` where a PD-type loop has ``b2 ≈ −a21 = 0.228``.
The identification sample time is not stated in the thesis; ``T = 0.2`` s here is the MPC period of Table 5.5,
at which the thesis used the model."""

W20_PELICAN = LinearModel(
    A=[[0.945, 0, 0.052, 0], [0, 0.943, 0, 0.052], [-0.151, 0, 0.799, 0], [0, -0.152, 0, 0.853]],
    B=[[0.00268, 0], [0, 0.00235], [0.123, 0], [0, 0.111]],
    T=0.2,
    source="W20 Sec. 5.4.1.2 (AscTec Pelican)",
)
"""W20 Sec. 5.4.1.2, the AscTec Pelican (x from trial 2, y from trial 4; Tables 5.3-5.4, fits 53-89 %). Stable:
eigenvalues 0.872 ± 0.050i in x (spectral radius 0.873) and 0.898 ± 0.077i in y (0.901). Its unit-step steady state
is position 0.367 m with velocity 0.336 m/s in x and 0.376 m with 0.367 m/s in y (``b1/(1 − a11)`` = 0.049 and
0.041), so it is not position/velocity of a setpoint-tracking vehicle either, and ``a12 = 0.052`` is not 0.2 s.
Sample time not stated; ``T = 0.2`` s as for :data:`W20_SIMULATOR`."""

SWARMTRACK_QUADROTOR = LinearModel(
    A=[[0.979105, 0.0, 0.170013, 0.0], [0.0, 0.979088, 0.0, 0.16999], [-0.210066, 0.0, 0.688698, 0.0],
       [0.0, -0.210253, 0.0, 0.688449]],
    B=[[0.0204696, 0.0], [0.0, 0.0204874], [0.207084, 0.0], [0.0, 0.207276]],
    T=0.2,
    source="swarmtrack identify --simulator",
)
"""The project's own quadrotor (:mod:`swarmtrack.vehicles.quadrotor`) flown by its position controller
(:mod:`swarmtrack.control.position`), identified by ``swarmtrack identify --simulator`` (fit 96.0 % on x and y; a
test holds it equal to a fresh identification). What the project's MPC scenarios use."""

NAMED_MODELS: dict[str, LinearModel] = {"swarmtrack-quadrotor": SWARMTRACK_QUADROTOR, "w20-simulator": W20_SIMULATOR,
                                        "w20-pelican": W20_PELICAN}


def simulate_axis(A, B, state0, u) -> np.ndarray:
    """Free run of one axis: states ``(n, 2)`` from ``state0`` ``[p, v]`` driven by ``u`` ``(n,)``
    (``u[-1]`` is not used: it acts after the last sample)."""
    A = np.asarray(A, dtype=float)
    b = np.asarray(B, dtype=float).reshape(2)
    u = np.asarray(u, dtype=float)
    out = np.empty((u.shape[0], 2))
    out[0] = state0
    for k in range(u.shape[0] - 1):
        out[k + 1] = A @ out[k] + b * u[k]
    return out


def fit_percent(A, B, position, velocity, u) -> float:
    """Fit on position, percent: ``100·(1 − ‖p − p̂‖/‖p − p̄‖)`` with ``p̂`` the free run of the model from the first
    measured state driven by the logged inputs (:func:`simulate_axis`) and ``p̄`` the mean of ``p`` over the log.
    This is MATLAB's ``compare`` fit, the "percentage fit" W20 uses in Tables 5.3-5.4; its eq. 5.33 as printed is
    garbled (a sum over samples of ``(1 − ‖x(l) − x̂‖)/‖x(l) − x̄‖``), so the standard definition is used.
    100 is a perfect fit, 0 no better than the mean; it can be negative."""
    p = np.asarray(position, dtype=float)
    sim = simulate_axis(A, B, (p[0], float(np.asarray(velocity)[0])), u)
    spread = np.linalg.norm(p - p.mean())
    if spread == 0.0:
        raise ValueError("the position does not change over the log: the fit is undefined")
    return float(100.0 * (1.0 - np.linalg.norm(p - sim[:, 0]) / spread))


def identify_axis(position, velocity, u) -> AxisModel:
    """Least squares of eq. 2.30 for one axis from samples at a fixed period (W20 eqs. 2.31-2.36).

    ``G`` = ``[p, v, u]`` at samples ``0..n−2`` (eq. 2.33), targets ``[p, v]`` at ``1..n−1`` (eq. 2.32); the solution
    ``W`` (3, 2) holds ``w1 = [a11, a12, b1]`` (eq. 2.34) and ``w2 = [a21, a22, b2]`` (eq. 2.36) as columns.
    ValueError when there are fewer than :data:`MIN_SAMPLES` samples, values are not finite, the input is constant
    (no excitation) or ``G`` is rank-deficient or ill-conditioned."""
    cols = {"position": position, "velocity": velocity, "input": u}
    arrays = {}
    for name, val in cols.items():
        arr = np.asarray(val, dtype=float)
        if arr.ndim != 1:
            raise ValueError(f"{name} must be a 1-D array, got shape {arr.shape}")
        arrays[name] = arr
    p, v, u = arrays["position"], arrays["velocity"], arrays["input"]
    if not p.shape == v.shape == u.shape:
        raise ValueError(f"position, velocity and input differ in length ({p.size}, {v.size}, {u.size})")
    if p.size < MIN_SAMPLES:
        raise ValueError(f"too few samples: {p.size}, at least {MIN_SAMPLES} are needed")
    for name, arr in arrays.items():
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            raise ValueError(f"{name} is not finite (NaN or inf) at sample {bad[0]}")
    if np.ptp(u[:-1]) <= 1e-12 * max(1.0, float(np.max(np.abs(u[:-1])))):
        raise ValueError(f"the input is constant ({u[0]:g}): no excitation, A and B cannot be identified; "
                         "fly setpoint steps on this axis")
    G = np.column_stack((p[:-1], v[:-1], u[:-1]))  # eq. 2.33
    L = np.column_stack((p[1:], v[1:]))  # eq. 2.32, both rows of eq. 2.30 at once
    scale = np.linalg.norm(G, axis=0)
    if np.any(scale == 0.0):
        zero = [n for n, s in zip(("position", "velocity", "input"), scale, strict=True) if s == 0.0]
        raise ValueError(f"the regressor matrix is rank-deficient: {', '.join(zero)} identically zero")
    sv = np.linalg.svd(G / scale, compute_uv=False)
    cond = sv[0] / sv[-1] if sv[-1] > 0 else math.inf
    if cond > MAX_CONDITION:
        raise ValueError(f"the regressor matrix [p, v, u] is rank-deficient (condition number {cond:.3g}): "
                         "position, velocity and input are linearly dependent, not enough excitation")
    W, *_ = np.linalg.lstsq(G, L, rcond=None)
    A, b = W[:2].T, W[2]
    return AxisModel(A=A, B=b, fit=fit_percent(A, b, p, v, u))


def _columns(log: Mapping) -> dict[str, np.ndarray]:
    missing = [c for c in COLUMNS if c not in log]
    if missing:
        raise ValueError(f"the log misses the column(s) {', '.join(missing)} (needs {','.join(COLUMNS)})")
    out = {}
    for c in COLUMNS:
        try:
            arr = np.asarray(log[c], dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"column {c} holds values that are not numbers") from None
        if arr.ndim != 1:
            raise ValueError(f"column {c} must be 1-D, got shape {arr.shape}")
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            raise ValueError(f"column {c} is not finite (NaN, inf or empty) at row {bad[0] + 1}")
        out[c] = arr
    lengths = {c: a.size for c, a in out.items()}
    if len(set(lengths.values())) != 1:
        raise ValueError(f"the log's columns differ in length: {lengths}")
    return out


def sample_period(t) -> float:
    """The fixed sample period of the time stamps ``t``; ValueError when they do not increase or are not uniform
    (each interval within :data:`TIME_TOLERANCE` of the mean, relative, plus the stamps' float resolution)."""
    t = np.asarray(t, dtype=float)
    if t.size < 2:
        raise ValueError(f"too few samples: {t.size}, at least {MIN_SAMPLES} are needed")
    dt = np.diff(t)
    bad = np.flatnonzero(dt <= 0)
    if bad.size:
        raise ValueError(f"time stamps must increase: t = {t[bad[0] + 1]:g} s at row {bad[0] + 2} follows "
                         f"t = {t[bad[0]]:g} s")
    T = (t[-1] - t[0]) / (t.size - 1)
    tol = TIME_TOLERANCE * T + 4 * np.finfo(float).eps * float(np.max(np.abs(t)))
    off = np.flatnonzero(np.abs(dt - T) > tol)
    if off.size:
        i = off[0]
        raise ValueError(f"sample times are not uniform: interval {dt[i]:.9g} s at row {i + 2} differs from the "
                         f"mean period {T:.9g} s (identification needs a fixed period)")
    return float(T)


def identify(log: Mapping) -> Identified:
    """Identify the 4-state model of eq. 5.32 from a log (columns ``t, x, y, vx, vy, ux, uy``; a mapping of column
    name to 1-D array or a ``pandas.DataFrame``): uniform sample times are checked, x and y are identified separately
    (:func:`identify_axis`) and assembled with no coupling, ``A = [[a11, 0, a12, 0], [0, a11', 0, a12'], [a21, 0,
    a22, 0], [0, a21', 0, a22']]``, ``B = [[b1, 0], [0, b1'], [b2, 0], [0, b2']]``. ValueError names the cause
    (missing columns, too few samples, non-finite values, time stamps, no excitation, and the axis)."""
    cols = _columns(log)
    n = cols["t"].size
    if n < MIN_SAMPLES:
        raise ValueError(f"too few samples: {n}, at least {MIN_SAMPLES} are needed")
    T = sample_period(cols["t"])
    axes = {}
    for axis, (p, v, u) in AXES.items():
        try:
            axes[axis] = identify_axis(cols[p], cols[v], cols[u])
        except ValueError as exc:
            raise ValueError(f"axis {axis} ({p}, {v}, {u}): {exc}") from None
    A, B = np.zeros((4, 4)), np.zeros((4, 2))
    for i, axis in enumerate(AXES):  # state [x, y, vx, vy]: position i, velocity 2 + i
        idx = [i, 2 + i]
        A[np.ix_(idx, idx)] = axes[axis].A
        B[idx, i] = axes[axis].B[:, 0]
    return Identified(A=_frozen(A), B=_frozen(B), T=T, x=axes["x"], y=axes["y"], n_samples=n)


DEFAULT_STEPS = ((1.0, 0.0), (0.0, 0.0), (0.0, 1.0), (0.0, 0.0), (1.0, 1.0), (0.0, 0.0))
"""Setpoints flown by :func:`step_response_log` from hover at the origin: x to 1 m and back, y to 1 m and back, then
both together and back. With the default :class:`~swarmtrack.control.position.PositionGains` the largest commanded
acceleration is ``kp·√2 = 2.0`` m/s², under the 3 m/s² clip, so the loop stays linear."""


def step_response_log(steps: Sequence[tuple[float, float]] = DEFAULT_STEPS, T: float = 0.2, hold: float = 8.0,
                      dt: float = 0.01, gains=None, params=None, rng: np.random.Generator | None = None,
                      position_noise: float = 0.0, velocity_noise: float = 0.0) -> dict[str, np.ndarray]:
    """A log (:data:`COLUMNS`) of the simulator's own quadrotor flying setpoint ``steps`` under its position
    controller, as W20 Sec. 2.5.1.2 prescribes ("step inputs in x and y").

    The quadrotor (:func:`swarmtrack.vehicles.quadrotor.step`, ``params`` default ``QuadrotorParams()``) starts
    hovering at the origin and is integrated every ``dt`` s; the position controller
    (:func:`swarmtrack.control.position.position_control`, ``gains`` default ``PositionGains()``) runs at the same
    rate (100 Hz by default). Each setpoint is held ``hold`` s (the default loop settles in about 4 s). A sample is
    taken every ``T`` s; its ``ux, uy`` are the setpoint held from it to the next sample (the last sample carries
    the final setpoint). With ``rng``, the navigation solution the controller flies on and the log records gets
    white Gaussian noise of std ``position_noise`` m and ``velocity_noise`` m/s, drawn at every controller step.
    """
    from swarmtrack.control.position import PositionGains, position_control
    from swarmtrack.vehicles.quadrotor import QuadrotorParams, hover_state, step

    gains = PositionGains() if gains is None else gains
    params = QuadrotorParams() if params is None else params
    sub = round(T / dt)
    per_step = round(hold / T)
    if sub < 1 or not math.isclose(sub * dt, T, rel_tol=1e-9):
        raise ValueError(f"the sample period T = {T} s must be a whole number of physics steps dt = {dt} s")
    if per_step < 1 or not math.isclose(per_step * T, hold, rel_tol=1e-9):
        raise ValueError(f"hold = {hold} s must be a whole number of sample periods T = {T} s")
    if (position_noise > 0 or velocity_noise > 0) and rng is None:
        raise ValueError("navigation noise needs a random generator (rng)")
    noise = np.array([position_noise, position_noise, velocity_noise, velocity_noise]) if rng is not None else None
    state = hover_state([[0.0, 0.0]])

    def navigation() -> np.ndarray:
        nav = np.array(state[:, :4])
        if noise is not None:
            nav += rng.normal(size=(1, 4)) * noise
        return nav

    rows = []
    k = 0
    for setpoint in steps:
        sp = np.asarray(setpoint, dtype=float).reshape(1, 2)
        for _ in range(per_step):
            nav = navigation()
            rows.append((k * T, *nav[0], *sp[0]))
            k += 1
            for j in range(sub):
                if j:
                    nav = navigation()
                state = step(state, position_control(sp, nav, gains), params, dt)
    rows.append((k * T, *navigation()[0], *np.asarray(steps[-1], dtype=float)))
    table = np.array(rows)
    return {c: table[:, i].copy() for i, c in enumerate(COLUMNS)}


def log_csv_text(log: Mapping) -> str:
    """The CSV text of a log: header ``t,x,y,vx,vy,ux,uy``, one row per sample, floats written exactly (repr)."""
    cols = _columns(log)
    lines = [",".join(COLUMNS)]
    lines += [",".join(repr(float(v)) for v in row) for row in zip(*(cols[c] for c in COLUMNS), strict=True)]
    return "\n".join(lines) + "\n"


def write_log_csv(path, log: Mapping) -> None:
    """Write a log as CSV (:func:`log_csv_text`) to ``path`` (replacing it: callers check for existing files)."""
    Path(path).write_text(log_csv_text(log))


def read_log_csv(path) -> dict[str, np.ndarray]:
    """Read a log CSV (header with at least ``t,x,y,vx,vy,ux,uy``; other columns are ignored; blank lines are
    skipped). Numbers are parsed by Python's ``float``, so a file written by :func:`write_log_csv` reads back exactly
    (pandas' ``read_csv`` does not round-trip every float, and its ``float_precision`` option is deprecated).
    ValueError names the cause: a file that cannot be read, missing columns (named), a row of the wrong length,
    a value that is not a number (column and row)."""
    path = Path(path)
    try:
        with path.open(newline="", encoding="utf-8") as f:
            rows = [row for row in csv.reader(f) if any(cell.strip() for cell in row)]
    except FileNotFoundError:
        raise ValueError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise ValueError(f"{path}: is a folder, not a CSV file") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a UTF-8 text file") from None
    except (OSError, csv.Error) as exc:
        raise ValueError(f"{path}: not a readable CSV file ({exc})") from None
    if not rows:
        raise ValueError(f"{path}: empty file (expected the header {','.join(COLUMNS)} and one row per sample)")
    header = [cell.strip() for cell in rows[0]]
    missing = [c for c in COLUMNS if c not in header]
    if missing:
        raise ValueError(f"{path}: missing column(s) {', '.join(missing)} (the header must hold {','.join(COLUMNS)})")
    index = {c: header.index(c) for c in COLUMNS}
    values = np.empty((len(rows) - 1, len(COLUMNS)))
    for r, row in enumerate(rows[1:], start=1):
        if len(row) != len(header):
            raise ValueError(f"{path}: row {r} has {len(row)} values, the header {len(header)}")
        for j, c in enumerate(COLUMNS):
            try:
                values[r - 1, j] = float(row[index[c]])
            except ValueError:
                raise ValueError(f"{path}: column {c} holds {row[index[c]]!r} at row {r}, not a number") from None
    return {c: values[:, j].copy() for j, c in enumerate(COLUMNS)}


def _yaml_float(value: float) -> str:
    """A float YAML 1.1 (PyYAML) reads back as the same float: ``repr``, with ``.0`` added to a bare-exponent
    mantissa (PyYAML reads ``1e-05`` as a string)."""
    text = repr(float(value))
    if "e" in text and "." not in text.split("e")[0]:
        mantissa, exponent = text.split("e")
        text = f"{mantissa}.0e{exponent}"
    return text


def round_significant(array, digits: int = 6) -> np.ndarray:
    """``array`` rounded to ``digits`` significant digits (each entry as ``f"{v:.{digits}g}"`` reads)."""
    arr = np.asarray(array, dtype=float)
    return np.array([float(f"{v:.{digits}g}") for v in arr.ravel()]).reshape(arr.shape)


def rounded_model(identified: Identified, digits: int = 6) -> tuple[np.ndarray, np.ndarray]:
    """``(A, B)`` rounded to ``digits`` significant digits: what :func:`model_yaml` writes and the CLI prints.
    ValueError (:func:`check_model`) if rounding made ``A`` unstable."""
    A, B = round_significant(identified.A, digits), round_significant(identified.B, digits)
    try:
        return check_model(A, B)
    except ValueError as exc:
        raise ValueError(f"the identified model rounded to {digits} digits: {exc}") from None


def _matrix_flow(M: np.ndarray) -> str:
    return "[" + ", ".join("[" + ", ".join(_yaml_float(v) for v in row) + "]" for row in M) + "]"


def model_yaml(identified: Identified, source: str = "a log", digits: int = 6) -> str:
    """A YAML block a scenario can use as ``controller.model`` (keys ``T``, ``A``, ``B`` under ``model:``), with a
    comment naming the source and the fits; ``A`` and ``B`` rounded to ``digits`` significant digits
    (:func:`rounded_model`, checked to be still stable). ``yaml.safe_load`` reads back exactly the rounded numbers."""
    A, B = rounded_model(identified, digits)
    fits = identified.fits
    source = " ".join(str(source).split())  # one comment line
    return (f"# identified by swarmtrack identify from {source} (T = {identified.T:.6g} s); "
            f"fit x {fits['x']:.1f} %, y {fits['y']:.1f} %\n"
            "model:\n"
            f"  T: {_yaml_float(float(f'{identified.T:.{digits}g}'))}\n"
            f"  A: {_matrix_flow(A)}\n"
            f"  B: {_matrix_flow(B)}\n")


# --- What the identified model says of the MPC's limits (issue 42; control/mpc.py plans with them) --------------

def unit_step_accelerations(A: np.ndarray, B: np.ndarray, T: float, steps: int = 50) -> np.ndarray:
    """(2,) per axis: the largest mean acceleration over one period, ``max_l |v(l+1) − v(l)| / T``, of the model's
    response from rest at the origin to a unit relative input held ``steps`` periods (m/s² per m of input)."""
    out = np.zeros(2)
    for axis in range(2):
        x, u = np.zeros(4), np.zeros(2)
        u[axis] = 1.0
        for _ in range(steps):
            nxt = A @ x + B @ u
            out[axis] = max(out[axis], abs(nxt[2 + axis] - x[2 + axis]) / T)
            x = nxt
    return out


def vehicle_bound(A: np.ndarray, B: np.ndarray, T: float, accel: float) -> float:
    """The input bound (m, per axis, relative setpoint) the vehicle can fly: ``b = a / max(g_x, g_y)`` with ``a`` its
    per-axis acceleration limit (m/s²) and ``g`` the model's :func:`unit_step_accelerations`.

    Derivation: the MPC's input is the position controller's setpoint relative to the UAV (W20 Sec. 5.3.2), the model
    ``x(l+1) = A x(l) + B s(l)`` (W20 eq. 5.32) is linear, so a relative input ``u`` from rest gives the velocity
    changes ``u·Δv_l`` of the unit response; the largest, ``g·T·u``, must stay within what the vehicle's limit gives
    in one period, ``a·T``. For the 5° quadrotor (``a = g·tan 5° = 0.858 m/s²``) and the model identified on it
    (its largest change is the first period's, ``B_v = 0.1649``: ``g = B_v/T = 0.824 s⁻²``), ``b = 1.04 m``; W20's
    ±2 m (Tables 5.9, 5.10) plans 1.65 m/s² from rest, and its position loop asks ``kp·2 = 2.88 m/s²``."""
    return float(accel / unit_step_accelerations(A, B, T).max())


def error_tube(A: np.ndarray, error: tuple[float, float], h: int) -> np.ndarray:
    """(h,) the radius in position of the identified model's error tube at l = 1..h: Mayne, Seron & Raković (2005,
    Automatica 41(2), the set ``F_l = ⊕_{i<l} A_K^i W`` of the flown state's deviation from the nominal one) with
    ``A_K = A`` (the model is already the closed loop of the UAV's position controller, the MPC adds no feedback) and
    ``W`` the one-step error box ``|w_p| ≤ error[0]`` m, ``|w_v| ≤ error[1]`` m/s on each axis. The box's reach along
    each axis, ``Σ_{i<l} |A^i| w`` (its support function), is combined over the two axes in norm: it bounds the
    deviation along any unit direction."""
    w = np.array([error[0], error[0], error[1], error[1]], dtype=float)
    power, reach, out = np.eye(4), np.zeros(4), np.zeros(h)
    for l in range(h):
        reach = reach + np.abs(power) @ w
        out[l] = np.hypot(reach[0], reach[1])
        power = np.asarray(A, dtype=float) @ power
    return out


def navigation_margin(A: np.ndarray, position_std: float, velocity_std: float, sigmas: float = 3.0) -> float:
    """m: how far a plan's first predicted position moves along any direction when the UAV's navigation solution is
    off by its noise, ``sigmas`` standard deviations of ``n·A_p δx`` (``A_p`` the model's position rows; the errors of
    the estimated position and velocity independent, the same on both axes); the estimation-error part of a robust
    output-feedback tube (Mayne, Raković, Findeisen & Allgöwer 2006, Automatica 42(7))."""
    A = np.asarray(A, dtype=float)
    return float(sigmas * max(np.hypot(A[i, i] * position_std, A[i, 2 + i] * velocity_std) for i in range(2)))
