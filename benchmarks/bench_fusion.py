"""Cost of one W20 Ch. 4 fusion step per filter (``swarmtrack.estimation.fusion``), on one core.

A fusion problem is one receiver fusing M = 3 candidates with the common block d = 4 (``[x, y, vx, vy]``),
every candidate valid; B such problems are fused by one batched call. Cases, each at B = 3, 100 and 10,000:

* ``ttest``: ``window_score`` of a 10-entry residual window per candidate, then ``ttest_select``;
* ``imm_thesis``: the thesis' IMM without mixing, ``imm_predict`` → ``imm_update`` → ``moment_combine``;
* ``imm_mixing``: the standard IMM's ``imm_mix`` → ``imm_update`` → ``moment_combine``;
* ``ml``: ``ml_fuse`` (own candidate first, then the two others).

The kernel inputs are the same every call (the cost does not depend on the values). The figure is the cost of
ONE fusion step per filter: µs per filter-step = wall time / (B × calls), and filter-steps/s its inverse
(``time.perf_counter``, each case timed for ≥ 1 s after a warm-up).

Then a full batched IMM-with-mixing filter step at B = 10,000 filters, carried from step to step: ``imm_mix``,
three linear 4-state Kalman filters (CV with three process noises) predicted and updated with a position
measurement (batched numpy in this script: F P Fᵀ + Q, the gain by an unrolled Cholesky solve of the 2 × 2
innovation covariance), ``log_gaussian``, ``imm_update``, ``moment_combine``. Beside it, in the same run,
FilterPy's ``IMMEstimator`` with three ``KalmanFilter``s of the same models (one ``predict()`` + ``update(z)``
per filter-step) and the ratio; the issue's goal is ≥ 100x per filter-step. Without FilterPy the reference is
reported missing.

Run: ``.venv/bin/python benchmarks/bench_fusion.py [--json] [--quick]`` (about 20 s; ``--quick`` times each
case for 0.2 s). ``--json`` prints one flat JSON object ``{name: value}`` instead of the table: for every case
``<case>_b<B>_us_per_filter_step`` and ``<case>_b<B>_filter_steps_per_s``, then ``imm_full_step_b10000_...``,
``filterpy_imm_us_per_filter_step`` and ``imm_full_step_speedup_over_filterpy`` (null without FilterPy).
"""

from __future__ import annotations

import os

# One core: no threaded BLAS. Other environment settings are left as they are.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from swarmtrack.estimation.fusion import (  # noqa: E402
    imm_mix,
    imm_predict,
    imm_update,
    log_gaussian,
    ml_fuse,
    moment_combine,
    ttest_select,
    window_score,
)

M = 3
D = 4
WINDOW = 10
SIZES = (3, 100, 10_000)
FULL_B = 10_000
MIN_SECONDS = 1.0

DT = 0.1
F_CV = np.array([[1, 0, DT, 0], [0, 1, 0, DT], [0, 0, 1, 0], [0, 0, 0, 1]], dtype=float)
H_POS = np.eye(2, D)
R_POS = np.diag([0.5, 0.5])
Q_SCALES = (0.01, 1.0, 25.0)
RHO = np.array([[0.90, 0.05, 0.05], [0.10, 0.80, 0.10], [0.05, 0.15, 0.80]])

GOAL_SPEEDUP = 100.0  # the issue's goal for the full step over FilterPy, per filter-step
FILTERPY_ISSUE_US = 490.0  # the issue's FilterPy figure, µs per filter-step


def _q(scale):
    g = np.array([[DT**2 / 2, 0], [0, DT**2 / 2], [DT, 0], [0, DT]])
    return scale * g @ g.T


def _time(step, min_seconds):
    """Seconds per call of ``step``, timed for at least ``min_seconds`` after a warm-up."""
    for _ in range(3):
        step()
    calls = 0
    t0 = time.perf_counter()
    elapsed = 0.0
    while elapsed < min_seconds:
        for _ in range(10):
            step()
        calls += 10
        elapsed = time.perf_counter() - t0
    return elapsed / calls


def _inputs(B, rng):
    A = rng.standard_normal((B, M, D, D))
    return {
        "x": rng.standard_normal((B, M, D)),
        "P": A @ np.swapaxes(A, -1, -2) + np.eye(D),
        "mu": rng.dirichlet(np.ones(M), size=B),
        "loglik": rng.uniform(-6.0, 0.0, (B, M)),
        "windows": rng.chisquare(2, (B, M, WINDOW)),
        "valid": np.ones((B, M), dtype=bool),
        "first": np.zeros(B, dtype=int),
    }


def kernel_cases(B, rng):
    a = _inputs(B, rng)
    x, P, mu, loglik, valid = a["x"], a["P"], a["mu"], a["loglik"], a["valid"]

    def ttest():
        ttest_select(window_score(a["windows"]), valid)

    def imm_thesis():
        mu_post = imm_update(imm_predict(mu, RHO), loglik, valid)
        moment_combine(mu_post, x, P)

    def imm_mixing():
        _, _, mu_pred = imm_mix(mu, RHO, x, P, valid)
        moment_combine(imm_update(mu_pred, loglik, valid), x, P)

    def ml():
        ml_fuse(x, P, valid, a["first"])

    return [("ttest", "T-test", ttest), ("imm_thesis", "thesis IMM (no mixing)", imm_thesis),
            ("imm_mixing", "IMM with mixing", imm_mixing), ("ml", "max-likelihood", ml)]


def _cholesky_solve_parts(S, rhs):
    """For SPD ``S`` (..., m, m) with small m: ``L⁻¹ rhs`` (rhs (..., m, k)) with ``S = L Lᵀ``, the Cholesky
    factor unrolled over its entries and vectorised over the batch."""
    m = S.shape[-1]
    L = [[None] * m for _ in range(m)]
    out = [None] * m
    for j in range(m):
        L[j][j] = np.sqrt(S[..., j, j] - sum(L[j][k] ** 2 for k in range(j)))
        for i in range(j + 1, m):
            L[i][j] = (S[..., i, j] - sum(L[i][k] * L[j][k] for k in range(j))) / L[j][j]
        out[j] = (rhs[..., j, :] - sum(L[j][k][..., None] * out[k] for k in range(j))) / L[j][j][..., None]
    return out


def full_imm(B, rng):
    """The batched IMM-with-mixing filter bank: returns ``step`` (one filter-step of all B filters)."""
    Q = np.stack([_q(s) for s in Q_SCALES])
    truth = rng.uniform(-50.0, 50.0, (B, 2))
    zs = [truth + rng.normal(0.0, np.sqrt(R_POS[0, 0]), (B, 2)) for _ in range(8)]
    state = {"mu": np.full((B, M), 1.0 / M), "x": np.zeros((B, M, D)), "P": np.tile(np.eye(D) * 100.0, (B, M, 1, 1)),
             "k": 0}
    state["x"][..., :2] = zs[0][:, None, :]
    valid = np.ones((B, M), dtype=bool)
    Ft, Ht = F_CV.T.copy(), H_POS.T.copy()

    def step():
        z = zs[state["k"] % len(zs)]
        state["k"] += 1
        x0, P0, mu_pred = imm_mix(state["mu"], RHO, state["x"], state["P"], valid)
        # predict (one 2-D product for the whole bank: the three models share F here)
        xp = (x0.reshape(-1, D) @ Ft).reshape(x0.shape)
        Y = (P0.reshape(-1, D) @ Ft).reshape(P0.shape)  # P Fᵀ
        Pp = (np.swapaxes(Y, -1, -2).reshape(-1, D) @ Ft).reshape(P0.shape) + Q  # F (P Fᵀ) = (P Fᵀ)ᵀ Fᵀ, P sym.
        # update: S = H P Hᵀ + R, Kν and K S Kᵀ from the whitened G = L⁻¹ H P and y = L⁻¹ ν (S = L Lᵀ)
        HP = np.swapaxes((Pp.reshape(-1, D) @ Ht).reshape(P0.shape[:-1] + (2,)), -1, -2)  # (B, M, 2, D)
        S = (HP.reshape(-1, D) @ Ht).reshape(P0.shape[:-2] + (2, 2)) + R_POS
        nu = z[:, None, :] - (xp.reshape(-1, D) @ Ht).reshape(xp.shape[:-1] + (2,))
        G = _cholesky_solve_parts(S, np.concatenate([HP, nu[..., None]], axis=-1))
        xu = xp + sum(g[..., :D] * g[..., D:] for g in G)
        Pu = Pp - sum(g[..., :D, None] * g[..., None, :D] for g in G)
        mu = imm_update(mu_pred, log_gaussian(nu, S), valid)
        moment_combine(mu, xu, Pu)
        state.update(mu=mu, x=xu, P=Pu)

    return step, state


def filterpy_imm(rng):
    """FilterPy's IMMEstimator with the same three models: returns ``step`` (one filter-step) or None."""
    try:
        from filterpy.kalman import IMMEstimator, KalmanFilter
    except ImportError:
        return None
    truth = rng.uniform(-50.0, 50.0, 2)
    zs = [truth + rng.normal(0.0, np.sqrt(R_POS[0, 0]), 2) for _ in range(8)]
    filters = []
    for s in Q_SCALES:
        kf = KalmanFilter(dim_x=D, dim_z=2)
        kf.x[:2, 0] = zs[0]
        kf.P *= 100.0
        kf.F, kf.H, kf.R, kf.Q = F_CV.copy(), H_POS.copy(), R_POS.copy(), _q(s)
        filters.append(kf)
    imm = IMMEstimator(filters, np.full(M, 1.0 / M), RHO.copy())
    k = [0]

    def step():
        imm.predict()
        imm.update(zs[k[0] % len(zs)])
        k[0] += 1

    return step


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", action="store_true", help="print one flat JSON object {name: value} instead")
    parser.add_argument("--quick", action="store_true", help="time each case for 0.2 s instead of 1 s (smoke test)")
    args = parser.parse_args(argv)
    min_seconds = 0.2 if args.quick else MIN_SECONDS
    rng = np.random.default_rng(0)

    results = {}
    rows = []
    for B in SIZES:
        for key, label, step in kernel_cases(B, rng):
            us = 1e6 * _time(step, min_seconds) / B
            results[f"{key}_b{B}_us_per_filter_step"] = us
            results[f"{key}_b{B}_filter_steps_per_s"] = 1e6 / us
            rows.append(f"{label:<28} {B:>7d} {us:>14.3f} {1e6 / us:>16.3e} {us * B:>12.1f}")

    step, state = full_imm(FULL_B, rng)
    us_full = 1e6 * _time(step, min_seconds) / FULL_B
    if not np.isfinite(state["P"]).all():
        raise RuntimeError("the batched IMM diverged")
    results[f"imm_full_step_b{FULL_B}_us_per_filter_step"] = us_full
    results[f"imm_full_step_b{FULL_B}_filter_steps_per_s"] = 1e6 / us_full
    ref = filterpy_imm(rng)
    us_ref = 1e6 * _time(ref, min_seconds) if ref is not None else None
    speedup = us_ref / us_full if us_ref is not None else None
    results["filterpy_imm_us_per_filter_step"] = us_ref
    results["imm_full_step_speedup_over_filterpy"] = speedup

    if args.json:
        print(json.dumps({k: (None if v is None else round(v, 4 if v < 100 else 1)) for k, v in results.items()}))
        return
    print(f"Fusion of M = {M} candidates (d = {D}) per filter, one core "
          f"(OPENBLAS_NUM_THREADS={os.environ['OPENBLAS_NUM_THREADS']})")
    header = f"{'case':<28} {'B':>7} {'µs/filter-step':>14} {'filter-steps/s':>16} {'µs/call':>12}"
    print(header)
    print("-" * len(header))
    print("\n".join(rows))
    print(f"\nFull batched IMM-with-mixing filter step (mixing, 3 linear 4-state Kalman filters, likelihood, "
          f"probabilities, combination), B = {FULL_B:,}:")
    print(f"  swarmtrack, batched numpy      {us_full:10.2f} µs per filter-step ({1e6 / us_full:.3e} filter-steps/s)")
    if us_ref is None:
        print("  FilterPy IMMEstimator          reference missing (filterpy is not importable; pip install filterpy)")
        return
    verdict = "MET" if speedup >= GOAL_SPEEDUP else "NOT MET"
    print(f"  FilterPy IMMEstimator          {us_ref:10.2f} µs per filter-step (issue: ~{FILTERPY_ISSUE_US:.0f} µs)")
    print(f"  speed-up per filter-step       {speedup:10.1f}x  (goal ≥ {GOAL_SPEEDUP:.0f}x: {verdict})")


if __name__ == "__main__":
    main()
