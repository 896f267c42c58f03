"""The compiled prediction, IMM likelihood and the multi-model step's sums and solve (numba) equal their numpy
references, on random inputs and over a short run of the simulator.

They repeat numpy's operations in numpy's order (:mod:`swarmtrack.estimation.predict_kernels`): bit for bit where
numpy's BLAS sums small products in order with fused multiply-adds, as this project's development machine's OpenBLAS
does (the fingerprints of ``benchmarks/fingerprint.py`` are identical there); a BLAS that sums otherwise differs in
the last bits. So the tests hold them to 1e-12 relative (a short run, where differences can grow, to 1e-9), and
bit for bit only where both sides are the kernel (one UAV's rows against the whole swarm's)."""

from __future__ import annotations

import numpy as np
import pytest

import swarmtrack
from swarmtrack.estimation import imm, multimodel
from swarmtrack.estimation import multimodel_kernels as mk
from swarmtrack.estimation import predict_kernels as pk
from swarmtrack.estimation.information import symmetrize
from swarmtrack.estimation.kalman import ekf_predict
from swarmtrack.estimation.measurements import CameraFrameMeasurement, RangeBearingMeasurement
from swarmtrack.models import make_model
from swarmtrack.network.rows import Rows


def _close(a, b, rtol: float = 1e-12) -> None:
    """Equal to ``rtol`` of the reference's largest finite magnitude (NaN where the reference has NaN)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    finite = np.isfinite(b)
    scale = np.abs(b[finite]).max() if finite.any() else 1.0
    np.testing.assert_allclose(a, b, rtol=rtol, atol=rtol * scale, equal_nan=True)


def _spd(rng, n, d):
    A = rng.normal(size=(n, d, d))
    return A @ np.swapaxes(A, -1, -2) + np.eye(d)


@pytest.mark.parametrize("name", ["cv", "ca", "ct", "fs"])
def test_predict_bank_equals_ekf_predict(name):
    rng = np.random.default_rng(1)
    model = make_model(name, 1 / 30)
    kind, params, F = pk.model_params(model)
    Q = np.ascontiguousarray(model.Q)
    for n in (1, 2, 3):
        for trial in range(20):
            x = rng.normal(size=(n, model.dim)) * 3.0
            if name == "ct" and trial % 2:
                x[:, 4] *= 1e-3  # the turn terms' series branch
            P = _spd(rng, n, model.dim)
            x_ref, P_ref = ekf_predict(model, x, P, Rows.all(n))
            x_k, F_k, P_k = pk.predict_bank(kind, params, F, x, P, Q, n)
            _close(x_k, x_ref)
            _close(P_k, P_ref)
            _close(F_k, model.jacobian(x))
            F2 = model.F[:2] if model.linear else model.jacobian(x)[..., :2, :]
            _close(pk.position_block(F_k, P, Q), symmetrize(F2 @ P @ np.swapaxes(F2, -1, -2) + model.Q[:2, :2]))


def test_subset_rows_predict_as_the_whole_swarm():
    """One filter of a bank of three (a UAV's own process) is predicted as the whole bank's row."""
    rng = np.random.default_rng(2)
    model = make_model("ca", 1 / 30)
    kind, params, F = pk.model_params(model)
    x, P = rng.normal(size=(3, 6)), _spd(rng, 3, 6)
    whole = pk.predict_bank(kind, params, F, x, P, np.ascontiguousarray(model.Q), 3)
    one = pk.predict_bank(kind, params, F, x[1:2], P[1:2], np.ascontiguousarray(model.Q), 3)
    np.testing.assert_array_equal(one[0], whole[0][1:2])
    _close(one[0], ekf_predict(model, x[1:2], P[1:2], Rows.of([1], 3))[0])


def test_position_loglik_equals_reference():
    rng = np.random.default_rng(3)
    n = 50
    I = _spd(rng, n, 2) * 10.0
    I[3] = 0.0  # no measurement: NaN
    i = rng.normal(size=(n, 2)) * 5.0
    x_pos, P_pos = rng.normal(size=(n, 2)), _spd(rng, n, 2) * 0.1
    _close(pk.position_loglik(I, i, x_pos, P_pos), imm._position_loglik(I, i, x_pos, P_pos))


def _sums(n_terms, H, Rinv, nu, ld):
    """The step kernel's sums of ``n_terms`` measurements of one receiver, ``[I, b, s, Σ log det R, count]``."""
    S = np.zeros(9)
    for e in range(n_terms):
        mk._add_term(S, nu[e, 0], nu[e, 1], H[e], Rinv[e], ld[e])
    return S


def _flat(statistic) -> np.ndarray:
    I, b, s, logdet_r, count = statistic
    return np.concatenate([I[0].ravel(), b[0], s, logdet_r, count])


def test_the_step_sums_equal_the_reference():
    """Σ Hᵀ R⁻¹ H, Σ Hᵀ R⁻¹ ν, Σ νᵀ R⁻¹ ν, Σ log det R and the count of a receiver's measurements (W20 eqs.
    4.3-4.4) as ``multimodel._statistic`` sums them: own measurement first, then the neighbours'."""
    rng = np.random.default_rng(4)
    for e in (1, 3, 6):
        H = rng.normal(size=(e, 2, 2))
        Rinv = np.zeros((e, 2, 2))
        Rinv[:, 0, 0], Rinv[:, 1, 1] = rng.uniform(1, 1e3, size=e), rng.uniform(1, 1e3, size=e)
        nu, ld = rng.normal(size=(e, 2)), rng.normal(size=e)
        parts = [(np.zeros(1, dtype=int), (nu[:1], H[:1], Rinv[:1], ld[:1])),
                 (np.zeros(e - 1, dtype=int), (nu[1:], H[1:], Rinv[1:], ld[1:]))]
        _close(_sums(e, H, Rinv, nu, ld), _flat(multimodel._statistic(1, parts)))


@pytest.mark.parametrize("sensor", ["camera", "range-bearing"])
def test_the_step_measurements_equal_their_terms(sensor):
    """The step kernel's camera and range-bearing measurements, linearised at the receiver's prediction, summed as
    the measurement models' ``terms`` (measurements.py) summed by the reference."""
    rng = np.random.default_rng(5)
    if sensor == "camera":
        model = CameraFrameMeasurement(0.0316)
        Rinv, logdet = model.noise()
        meas = (mk.CAMERA, Rinv, logdet, 0.0)
    else:
        model = RangeBearingMeasurement(0.05, 0.02)
        w = np.array([1.0 / 0.05**2, 1.0 / 0.02**2])
        meas = (mk.RANGE_BEARING, np.diag(w), float(-np.log(w).sum()), model.min_range)
    for _ in range(50):
        n = 4
        x_pos = rng.normal(size=(1, 2))
        if sensor == "camera":
            got = {"z": rng.normal(size=(n, 2)), "frame": rng.normal(size=(n, 2, 3))}
            aux = got["frame"]
        else:
            got = {"z": np.column_stack([rng.uniform(0.1, 3.0, n), rng.uniform(-np.pi, np.pi, n)]),
                   "sensor_pos": rng.normal(size=(n, 2))}
            got["sensor_pos"][0] = x_pos[0] + 0.01  # within min_range: the floored range
            aux = got["sensor_pos"][:, None, :]
        rows = np.arange(n)
        ref = multimodel._statistic(1, [(np.zeros(n, dtype=int), model.terms(np.repeat(x_pos, n, 0), got, rows))])
        S, H = np.zeros(9), np.empty((2, 2))
        for e in range(n):
            mk._add_measurement(S, meas, got["z"][e], aux[e], x_pos[0, 0], x_pos[0, 1], H)
        _close(S, _flat(ref))


def test_the_step_position_solve_equals_lapack():
    """The 2 x 2 solve with LAPACK's pivoting, both pivot orders, and the symmetrised inverse."""
    rng = np.random.default_rng(6)
    I = _spd(rng, 200, 2)
    I[:100] = I[:100][:, ::-1, ::-1] * np.array([[1.0, -1.0], [-1.0, 1.0]])  # large pivots in both rows
    b = rng.normal(size=(200, 2)) * 3.0
    nu_ref, R_ref = multimodel._position_solve(I, b)
    S, B, Y = np.zeros(9), np.empty((2, 3)), np.empty((2, 3))
    for k in range(200):
        S[:4], S[4:6] = I[k].ravel(), b[k]
        mk._solve(S, B, Y)
        _close(Y[:, 0], nu_ref[k])
        _close(0.5 * (Y[:, 1:] + Y[:, 1:].T), R_ref[k])


def _probes(name, seconds=2.0):
    rec = swarmtrack.simulate(swarmtrack.load_scenario(name, [f"duration={seconds}"], seed=3))
    chunks = list(rec.chunks())
    return {p: np.concatenate([c.probes[p] for c in chunks]) for p in rec.meta["probes"] if p != "solve_time"}


@pytest.mark.parametrize("name", ["w20-switching", "l24-imm"])
def test_short_run_equals_numpy_reference(name, monkeypatch):
    """A 5 s run with the new kernels records what it records with their numpy references (the other compiled
    paths, chosen by the same ``kernels``, left as they are)."""
    made, of = [], multimodel.CompiledStep.of.__func__
    monkeypatch.setattr(multimodel.CompiledStep, "of",
                        classmethod(lambda cls, est: made.append(of(cls, est)) or made[-1]))
    fast = _probes(name, 5.0)  # W20 shares from step 100 (3.3 s)
    assert name != "w20-switching" or (made and None not in made)  # the fast run's step is the compiled one
    monkeypatch.setattr(multimodel.CompiledStep, "of", classmethod(lambda cls, est: None))
    monkeypatch.setattr(imm, "has_kernel", lambda model: False)
    monkeypatch.setattr(imm, "position_loglik", imm._position_loglik)
    slow = _probes(name, 5.0)
    assert fast.keys() == slow.keys()
    for p in fast:
        _close(fast[p], slow[p], rtol=1e-9)
