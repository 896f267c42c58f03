"""The compiled prediction, IMM likelihood and stacked statistic (numba) equal their numpy references, on random
inputs and over a short run of the simulator.

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
from swarmtrack.estimation import predict_kernels as pk
from swarmtrack.estimation.information import symmetrize
from swarmtrack.estimation.kalman import ekf_predict
from swarmtrack.estimation.measurements import CameraFrameMeasurement
from swarmtrack.estimation.multimodel_kernels import camera_statistic, position_solve, stacked_statistic
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


def test_stacked_statistic_equals_reference():
    rng = np.random.default_rng(4)
    n = 4
    parts = []
    for e in (1, 3, 5):  # own measurements, then the neighbours' (one einsum path per size)
        rows = rng.integers(0, n, size=e)
        H = rng.normal(size=(e, 2, 2))
        Rinv = np.zeros((e, 2, 2))
        Rinv[:, 0, 0], Rinv[:, 1, 1] = rng.uniform(1, 1e3, size=e), rng.uniform(1, 1e3, size=e)
        parts.append((rows, (rng.normal(size=(e, 2)), H, Rinv, rng.normal(size=e))))
    ref = multimodel._statistic(n, parts)
    got = stacked_statistic(n, np.concatenate([p[0] for p in parts]),
                            *(np.concatenate([p[1][k] for p in parts]) for k in range(4)))
    for a, b in zip(got, ref, strict=True):
        _close(a, b)


def test_camera_statistic_equals_the_terms_summed():
    """The camera's sums straight from the payloads equal its terms (measurements.py) summed by the reference."""
    rng = np.random.default_rng(5)
    n, camera = 4, CameraFrameMeasurement(0.0316)
    mine = {"z": rng.normal(size=(n, 2)), "frame": rng.normal(size=(n, 2, 3))}
    got = {"z": rng.normal(size=(n, 2)), "frame": rng.normal(size=(n, 2, 3))}
    x_pos, own = rng.normal(size=(n, 2)), np.array([0, 2, 3])
    recv, send = np.array([0, 0, 1, 3, 3]), np.array([1, 2, 0, 1, 2])
    ref = multimodel._statistic(n, [(own, camera.terms(x_pos[own], mine, own)),
                                    (recv, camera.terms(x_pos[recv], got, send))])
    fast = camera_statistic(n, x_pos, own, mine["z"], mine["frame"], recv, send, got["z"], got["frame"],
                            *camera.noise())
    for a, b in zip(fast, ref, strict=True):
        _close(a, b)


def test_position_solve_equals_lapack():
    """The 2 x 2 solve with LAPACK's pivoting, both pivot orders, and the symmetrised inverse."""
    rng = np.random.default_rng(6)
    I = _spd(rng, 200, 2)
    I[:100] = I[:100][:, ::-1, ::-1] * np.array([[1.0, -1.0], [-1.0, 1.0]])  # large pivots in both rows
    b = rng.normal(size=(200, 2)) * 3.0
    for a, r in zip(position_solve(I, b), multimodel._position_solve(I, b), strict=True):
        _close(a, r)


def _probes(name, seconds=2.0):
    rec = swarmtrack.simulate(swarmtrack.load_scenario(name, [f"duration={seconds}"], seed=3))
    chunks = list(rec.chunks())
    return {p: np.concatenate([c.probes[p] for c in chunks]) for p in rec.meta["probes"] if p != "solve_time"}


@pytest.mark.parametrize("name", ["w20-switching", "l24-imm"])
def test_short_run_equals_numpy_reference(name, monkeypatch):
    """A 5 s run with the new kernels records what it records with their numpy references (the other compiled
    paths, chosen by the same ``kernels``, left as they are)."""
    fast = _probes(name, 5.0)  # W20 shares from step 100 (3.3 s)
    monkeypatch.setattr(multimodel, "has_kernel", lambda model: False)
    monkeypatch.setattr(multimodel, "stacked_statistic", lambda n, rows, *terms: multimodel._statistic(
        n, [(rows, terms)]))
    monkeypatch.setattr(multimodel, "CameraFrameMeasurement", type(None))  # the camera's sums through its terms
    monkeypatch.setattr(multimodel, "position_solve", multimodel._position_solve)
    monkeypatch.setattr(imm, "has_kernel", lambda model: False)
    monkeypatch.setattr(imm, "position_loglik", imm._position_loglik)
    slow = _probes(name, 5.0)
    assert fast.keys() == slow.keys()
    for p in fast:
        _close(fast[p], slow[p], rtol=1e-9)
