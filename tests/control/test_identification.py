"""System identification of the position-controlled UAV (W20 eqs. 2.30-2.36, 5.32; control.identification)."""

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from swarmtrack.cli import main
from swarmtrack.control.identification import (
    COLUMNS,
    MIN_SAMPLES,
    NAMED_MODELS,
    W20_PELICAN,
    W20_SIMULATOR,
    AxisModel,
    Identified,
    check_model,
    error_tube,
    fit_percent,
    identify,
    identify_axis,
    model_yaml,
    navigation_margin,
    read_log_csv,
    round_significant,
    rounded_model,
    spectral_radius,
    step_response_log,
    vehicle_bound,
    write_log_csv,
)
from swarmtrack.scenarios import load_scenario

# A stable second-order axis each (complex poles, |λ| ≈ 0.85 and 0.89), different so the assembly is checked too.
TRUE = {"x": (np.array([[0.98, 0.17], [-0.21, 0.69]]), np.array([0.02, 0.21])),
        "y": (np.array([[0.95, 0.15], [-0.30, 0.80]]), np.array([0.05, 0.30]))}


def synthetic_log(n: int = 200, T: float = 0.2, seed: int = 3) -> dict[str, np.ndarray]:
    """Noise-free data from TRUE driven by a seeded random setpoint sequence (held 1-5 samples each)."""
    rng = np.random.default_rng(seed)
    log = {"t": np.arange(n) * T}
    for axis, (A, b) in TRUE.items():
        u = np.repeat(rng.uniform(-2, 2, n), rng.integers(1, 6, n))[:n]
        s = np.zeros((n, 2))
        s[0] = rng.normal(size=2)
        for k in range(n - 1):
            s[k + 1] = A @ s[k] + b * u[k]
        log[axis], log["v" + axis], log["u" + axis] = s[:, 0], s[:, 1], u
    return log


@pytest.fixture(scope="module")
def quad_log():
    return step_response_log()


def test_known_model_is_recovered_to_1e_6_with_a_100_percent_fit():
    result = identify(synthetic_log())
    for axis, (A, b) in TRUE.items():
        m = getattr(result, axis)
        np.testing.assert_allclose(m.A, A, atol=1e-6)
        np.testing.assert_allclose(m.B[:, 0], b, atol=1e-6)
        assert m.fit > 100 - 1e-6
    (ax, bx), (ay, by) = TRUE["x"], TRUE["y"]
    A = [[ax[0, 0], 0, ax[0, 1], 0], [0, ay[0, 0], 0, ay[0, 1]], [ax[1, 0], 0, ax[1, 1], 0], [0, ay[1, 0], 0, ay[1, 1]]]
    B = [[bx[0], 0], [0, by[0]], [bx[1], 0], [0, by[1]]]
    np.testing.assert_allclose(result.A, A, atol=1e-6)  # the eq. 5.32 layout, state [x, y, vx, vy]
    np.testing.assert_allclose(result.B, B, atol=1e-6)
    assert result.T == pytest.approx(0.2) and result.n_samples == 200


def test_fit_is_the_free_run_compare_fit_on_position():
    log = synthetic_log()
    A, b = TRUE["x"]
    assert fit_percent(A, b, log["x"], log["vx"], log["ux"]) == pytest.approx(100.0)
    # a model with half the input gain does worse; one that stays at the first state scores 100·(1 − ‖p − p0‖/‖p − p̄‖)
    assert fit_percent(A, 0.5 * b, log["x"], log["vx"], log["ux"]) < 90.0
    p = log["x"]
    expected = 100 * (1 - np.linalg.norm(p - p[0]) / np.linalg.norm(p - p.mean()))
    assert fit_percent(np.eye(2), np.zeros(2), p, np.zeros_like(p), log["ux"]) == pytest.approx(expected)


def test_simulator_quadrotor_under_its_position_controller_fits_above_90_percent(quad_log):
    result = identify(quad_log)
    assert result.fits["x"] >= 90.0 and result.fits["y"] >= 90.0, result.fits  # measured 96.0 and 96.0
    assert spectral_radius(result.A) < 1.0
    # a setpoint-tracking vehicle: a unit setpoint step settles near 1 m with zero velocity
    steady = np.linalg.solve(np.eye(4) - result.A, result.B)
    np.testing.assert_allclose(steady, [[1, 0], [0, 1], [0, 0], [0, 0]], atol=0.03)


def test_the_named_project_model_is_a_fresh_identification_of_the_quadrotor(quad_log):
    """``swarmtrack-quadrotor`` (what the MPC scenarios fly) is what the tool identifies today, to its 6 digits."""
    result = identify(quad_log)
    model = NAMED_MODELS["swarmtrack-quadrotor"]
    np.testing.assert_allclose(model.A, result.A, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(model.B, result.B, rtol=1e-5, atol=1e-7)
    assert model.T == result.T


def test_step_response_log_samples_every_T_with_the_setpoint_held_over_the_next_period(quad_log):
    assert set(quad_log) == set(COLUMNS)
    np.testing.assert_allclose(np.diff(quad_log["t"]), 0.2)
    assert quad_log["ux"][0] == 1.0 and quad_log["uy"][0] == 0.0  # the first step acts from t = 0
    assert quad_log["x"][0] == 0.0 and quad_log["vx"][0] == 0.0  # from hover at the origin
    assert np.ptp(quad_log["ux"]) == 1.0 and np.ptp(quad_log["uy"]) == 1.0


def test_step_response_log_noise_is_seeded_and_still_identifiable():
    a = step_response_log(steps=((1, 0), (0, 1), (0, 0)), hold=6.0, rng=np.random.default_rng(7),
                          position_noise=0.02, velocity_noise=0.05)
    b = step_response_log(steps=((1, 0), (0, 1), (0, 0)), hold=6.0, rng=np.random.default_rng(7),
                          position_noise=0.02, velocity_noise=0.05)
    assert all(np.array_equal(a[c], b[c]) for c in COLUMNS)
    assert min(identify(a).fits.values()) > 80.0
    with pytest.raises(ValueError, match="needs a random generator"):
        step_response_log(position_noise=0.1)


def test_named_models_are_exactly_the_printed_numbers_and_stable():
    assert W20_SIMULATOR.A.tolist() == [[0.920, 0, 0.084, 0], [0, 0.920, 0, 0.084], [-0.228, 0, 0.905, 0],
                                        [0, -0.228, 0, 0.905]]
    assert W20_SIMULATOR.B.tolist() == [[0.0006019, 0], [0, 0.0006019], [0.02375, 0], [0, 0.02375]]
    assert W20_PELICAN.A.tolist() == [[0.945, 0, 0.052, 0], [0, 0.943, 0, 0.052], [-0.151, 0, 0.799, 0],
                                      [0, -0.152, 0, 0.853]]
    assert W20_PELICAN.B.tolist() == [[0.00268, 0], [0, 0.00235], [0.123, 0], [0, 0.111]]
    assert {k: NAMED_MODELS[k] for k in ("w20-simulator", "w20-pelican")} == {"w20-simulator": W20_SIMULATOR,
                                                                             "w20-pelican": W20_PELICAN}
    assert spectral_radius(W20_SIMULATOR.A) == pytest.approx(0.9229, abs=1e-4)
    assert spectral_radius(W20_PELICAN.A) == pytest.approx(0.9013, abs=1e-4)


def test_named_models_do_not_settle_at_the_setpoint_as_their_docstrings_say():
    sim = np.linalg.solve(np.eye(4) - W20_SIMULATOR.A, W20_SIMULATOR.B)
    pel = np.linalg.solve(np.eye(4) - W20_PELICAN.A, W20_PELICAN.B)
    np.testing.assert_allclose(np.diag(sim[:2]), 0.0767, atol=5e-5)
    np.testing.assert_allclose(np.diag(sim[2:]), 0.0659, atol=5e-5)
    np.testing.assert_allclose(np.diag(pel[:2]), [0.367, 0.376], atol=5e-4)
    np.testing.assert_allclose(np.diag(pel[2:]), [0.336, 0.367], atol=5e-4)
    assert W20_SIMULATOR.B[0, 0] / (1 - W20_SIMULATOR.A[0, 0]) == pytest.approx(0.0075, abs=5e-5)


def test_check_model_refuses_an_unstable_A_and_wrong_shapes():
    A, B = W20_SIMULATOR.A.copy(), W20_SIMULATOR.B
    check_model(A, B)
    A[0, 0] = 1.2  # x axis eigenvalues 1.104 and 1.001
    with pytest.raises(ValueError, match=r"unstable: spectral radius 1\.10353 ≥ 1"):
        check_model(A, B)
    with pytest.raises(ValueError, match=r"A must be 4x4.*\(2, 2\)"):
        check_model(np.eye(2) * 0.5, B)
    with pytest.raises(ValueError, match=r"B must be 4x2.*\(4,\)"):
        check_model(W20_SIMULATOR.A, np.zeros(4))
    with pytest.raises(ValueError, match="finite"):
        check_model(np.full((4, 4), np.nan), B)


def test_too_few_samples_is_refused():
    log = {c: v[:MIN_SAMPLES - 1] for c, v in synthetic_log().items()}
    with pytest.raises(ValueError, match=f"too few samples: {MIN_SAMPLES - 1}, at least {MIN_SAMPLES}"):
        identify(log)
    with pytest.raises(ValueError, match="too few samples"):
        identify_axis([0.0, 1.0], [0.0, 0.0], [1.0, 1.0])


def test_constant_input_is_refused_naming_the_axis():
    log = synthetic_log()
    log["uy"] = np.full_like(log["uy"], 0.5)
    with pytest.raises(ValueError, match=r"axis y \(y, vy, uy\): the input is constant \(0.5\): no excitation"):
        identify(log)


def test_dependent_regressors_are_refused_as_rank_deficient():
    n = 50
    u = np.where(np.arange(n) % 10 < 5, 1.0, 0.0)
    with pytest.raises(ValueError, match="rank-deficient"):  # p and v identical to u: rank 1
        identify_axis(u, u, u)
    with pytest.raises(ValueError, match="rank-deficient: velocity identically zero"):
        identify_axis(np.linspace(0, 1, n), np.zeros(n), u)


@pytest.mark.parametrize("change, message", [
    (lambda t: t * np.where(np.arange(t.size) > 50, 1.01, 1.0), "sample times are not uniform"),
    (lambda t: np.where(np.arange(t.size) == 20, t[19], t), "time stamps must increase"),
    (lambda t: t[::-1], "time stamps must increase"),
])
def test_bad_time_stamps_are_refused(change, message):
    log = synthetic_log()
    log["t"] = change(log["t"])
    with pytest.raises(ValueError, match=message):
        identify(log)


def test_large_absolute_time_stamps_at_a_fixed_period_are_accepted():
    log = synthetic_log()
    log["t"] = 1.7e9 + log["t"]  # Unix time: the float resolution (2.4e-7 s) is beyond 1e-6 of 0.2 s
    assert identify(log).T == pytest.approx(0.2, rel=1e-5)


def test_non_finite_values_and_missing_columns_are_refused():
    log = synthetic_log()
    log["vx"] = log["vx"].copy()
    log["vx"][7] = np.nan
    with pytest.raises(ValueError, match="column vx is not finite .* at row 8"):
        identify(log)
    with pytest.raises(ValueError, match="misses the column.*ux, uy"):
        identify({c: v for c, v in synthetic_log().items() if c not in ("ux", "uy")})


def test_csv_round_trip_is_exact_and_a_dataframe_identifies_the_same(tmp_path, quad_log):
    import pandas as pd

    path = tmp_path / "log.csv"
    write_log_csv(path, quad_log)
    assert path.read_text().splitlines()[0] == "t,x,y,vx,vy,ux,uy"
    back = read_log_csv(path)
    assert list(back) == list(COLUMNS) and all(np.array_equal(back[c], quad_log[c]) for c in COLUMNS)
    assert np.array_equal(identify(pd.DataFrame(quad_log)).A, identify(quad_log).A)


def test_csv_with_missing_columns_or_text_is_refused_naming_them(tmp_path):
    path = tmp_path / "log.csv"
    path.write_text("t,x,vx,ux\n0,0,0,1\n")
    with pytest.raises(ValueError, match=r"missing column\(s\) y, vy, uy"):
        read_log_csv(path)
    path.write_text("t,x,y,vx,vy,ux,uy\n0,0,0,0,0,one,0\n")
    with pytest.raises(ValueError, match="column ux holds 'one' at row 1, not a number"):
        read_log_csv(path)
    path.write_text("t,x,y,vx,vy,ux,uy\n0,0,0,0,0,1\n")
    with pytest.raises(ValueError, match="row 1 has 6 values, the header 7"):
        read_log_csv(path)
    with pytest.raises(ValueError, match="no such file"):
        read_log_csv(tmp_path / "absent.csv")


def test_model_yaml_loads_back_exactly_the_rounded_stable_model(quad_log):
    result = identify(quad_log)
    text = model_yaml(result, "log.csv")
    assert text.startswith("# identified by swarmtrack identify from log.csv (T = 0.2 s); fit x 96.0 %, y 96.0 %")
    model = yaml.safe_load(text)["model"]
    assert set(model) == {"T", "A", "B"} and model["T"] == 0.2
    A, B = rounded_model(result)
    assert model["A"] == A.tolist() and model["B"] == B.tolist()
    np.testing.assert_allclose(A, result.A, rtol=5e-6)
    # the rounded model fits as the printed (unrounded) numbers say
    assert fit_percent(A[np.ix_([0, 2], [0, 2])], B[[0, 2], 0], quad_log["x"], quad_log["vx"],
                       quad_log["ux"]) == pytest.approx(result.fits["x"], abs=0.01)


def test_model_yaml_writes_tiny_entries_as_floats_not_strings():
    A, B = W20_SIMULATOR.A, W20_SIMULATOR.B * 1e-3  # 6.019e-07: PyYAML reads a bare "6.019e-07" as a string
    axis = AxisModel(A=np.eye(2) * 0.5, B=np.zeros(2), fit=99.0)
    text = model_yaml(Identified(A=A, B=B, T=0.2, x=axis, y=axis, n_samples=100))
    assert yaml.safe_load(text)["model"]["B"][0][0] == 6.019e-07
    assert round_significant([1.23456789e-7, -987654321.0]).tolist() == [1.23457e-7, -987654000.0]


# ---------------------------------------------------------------------------------------------------- the CLI


def _bad(args, tmp_path, message):
    before = sorted(tmp_path.iterdir())
    res = CliRunner().invoke(main, ["identify", *args])
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output and isinstance(res.exception, SystemExit)
    assert message in res.output and len(res.output.strip().splitlines()) == 1, res.output
    assert sorted(tmp_path.iterdir()) == before  # nothing written, no temporary left behind
    return res.output


def test_cli_identifies_a_log_and_prints_the_fits(tmp_path, quad_log):
    path = tmp_path / "log.csv"
    write_log_csv(path, quad_log)
    res = CliRunner().invoke(main, ["identify", str(path)])
    assert res.exit_code == 0, res.output
    assert "fit on position (free run, %): x 95.99, y 96.00" in res.output
    assert yaml.safe_load(res.stdout)["model"]["T"] == 0.2  # without --out, stdout is the YAML alone


def test_cli_bad_log_exits_2_with_the_cause_and_writes_nothing(tmp_path):
    log = synthetic_log()
    log["ux"] = np.zeros_like(log["ux"])
    write_log_csv(tmp_path / "flat.csv", log)
    out = str(tmp_path / "m.yaml")
    _bad([str(tmp_path / "flat.csv"), "--out", out], tmp_path, "axis x (x, vx, ux): the input is constant")
    write_log_csv(tmp_path / "short.csv", {c: v[:5] for c, v in log.items()})
    _bad([str(tmp_path / "short.csv"), "--out", out], tmp_path, "too few samples: 5")
    (tmp_path / "cols.csv").write_text("t,x\n0,1\n")
    _bad([str(tmp_path / "cols.csv"), "--out", out], tmp_path, "missing column(s) y, vx, vy, ux, uy")
    (tmp_path / "bin.csv").write_bytes(b"\x00\xff\xfe\x00garbage")
    _bad([str(tmp_path / "bin.csv"), "--out", out], tmp_path, "bin.csv")
    _bad([str(tmp_path / "absent.csv")], tmp_path, "absent.csv: no such file")
    _bad([], tmp_path, "give a LOG file to identify, or --simulator")
    _bad([str(tmp_path / "flat.csv"), "--simulator"], tmp_path, "either a LOG file or --simulator (not both)")


@pytest.mark.slow
def test_cli_simulator_writes_yaml_with_a_4x4_A_and_4x2_B(tmp_path):
    out, saved = tmp_path / "model.yaml", tmp_path / "sim.csv"
    res = CliRunner().invoke(main, ["identify", "--simulator", "--out", str(out), "--save-log", str(saved)])
    assert res.exit_code == 0, res.output
    model = yaml.safe_load(out.read_text())["model"]
    assert set(model) == {"T", "A", "B"} and model["T"] == 0.2
    assert np.shape(model["A"]) == (4, 4) and np.shape(model["B"]) == (4, 2)
    check_model(model["A"], model["B"])
    assert identify(read_log_csv(saved)).fits == pytest.approx(identify(step_response_log()).fits)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.yaml", "sim.csv"]  # no temporary left


def test_cli_refuses_to_overwrite_an_existing_out_without_overwrite(tmp_path):
    out = tmp_path / "model.yaml"
    out.write_text("mine\n")
    _bad(["--simulator", "--out", str(out)], tmp_path, "the file exists; add --overwrite")
    assert out.read_text() == "mine\n"
    res = CliRunner().invoke(main, ["identify", "--simulator", "--out", str(out), "--overwrite"])
    assert res.exit_code == 0, res.output
    assert "model" in yaml.safe_load(out.read_text())


def test_cli_refuses_an_out_in_a_missing_folder_and_creates_none(tmp_path):
    _bad(["--simulator", "--out", str(tmp_path / "no" / "m.yaml")], tmp_path, "no folder")


# --- Issue 42: what the identified model says of the MPC's limits ---------------------------------------------------

#: The model identified on the 5° quadrotor (the simulated W20 scenarios' controller.model) and that vehicle's
#: per-axis acceleration, g·tan 5°
_, LIMITED_A, LIMITED_B = load_scenario("w20-mpc-collision").controller.uav_model()
FIVE_DEGREES = 9.81 * np.tan(np.radians(5.0))


def test_the_vehicle_bound_is_the_largest_input_whose_planned_accelerations_the_vehicle_gives():
    b = vehicle_bound(LIMITED_A, LIMITED_B, 0.2, FIVE_DEGREES)
    assert b == pytest.approx(FIVE_DEGREES * 0.2 / 0.164852, rel=1e-12)  # the first period's change is the largest
    assert b == pytest.approx(1.0412, abs=1e-4)
    for scale, within in ((1.0, True), (1.01, False)):  # the model's step response from rest, held 10 s
        x, dv = np.zeros(4), []
        for _ in range(50):
            nxt = LIMITED_A @ x + LIMITED_B @ np.array([scale * b, -scale * b])
            dv.append(np.abs(nxt[2:] - x[2:]).max() / 0.2)
            x = nxt
        assert bool(max(dv) <= FIVE_DEGREES * (1 + 1e-12)) is within


def test_the_error_tube_bounds_every_deviation_the_one_step_error_box_can_make():
    """Mayne et al. 2005's F_l = ⊕ A^i W along any direction: random errors within the box stay inside, a vertex
    sequence reaches the bound on one axis."""
    w = (0.02, 0.2)
    tube = error_tube(LIMITED_A, w, 5)
    assert tube[0] == pytest.approx(np.hypot(0.02, 0.02)) and np.all(np.diff(tube) > 0)
    rng = np.random.default_rng(3)
    box = np.array([w[0], w[0], w[1], w[1]])
    for _ in range(200):
        e = np.zeros(4)
        for l in range(5):
            e = LIMITED_A @ e + rng.uniform(-1, 1, 4) * box
            assert np.hypot(e[0], e[1]) <= tube[l] + 1e-12
    for l in range(5):  # the worst sequence on each axis: each error at the vertex A^i's position row favours
        e = np.zeros(4)
        for i in range(l + 1):
            e = LIMITED_A @ e + np.sign(np.linalg.matrix_power(LIMITED_A, l - i)[:2].sum(axis=0)) * box
        assert np.hypot(e[0], e[1]) == pytest.approx(tube[l], rel=1e-12)


def test_the_navigation_margin_is_three_sigma_of_the_first_predicted_position():
    nav = navigation_margin(LIMITED_A, 0.02, 0.02)
    assert nav == pytest.approx(3 * np.hypot(0.983093 * 0.02, 0.175215 * 0.02), rel=1e-12)
    assert navigation_margin(LIMITED_A, 0.0, 0.0) == 0.0
