"""The constant-acceleration term of a profile phase and the ground robot's CV/CA/CT segments (W20 Ch. 4)."""

import math

import numpy as np
import pytest

from swarmtrack.vehicles import Phase, Segment, VelocityProfile, evasive_segments, ground_robot_profile


def _midpoint_positions(prof: VelocityProfile, t: np.ndarray, start) -> np.ndarray:
    """Fine numerical integral of the velocity (midpoint rule) on the grid ``t``."""
    dt = np.diff(t)
    v_mid = prof.velocity(t[:-1] + 0.5 * dt)
    return np.asarray(start) + np.concatenate([np.zeros((1, 2)), np.cumsum(v_mid * dt[:, None], axis=0)])


# ---------------------------------------------------------------------- constant-acceleration term
def _accel_profile() -> VelocityProfile:
    return VelocityProfile(
        (
            Phase("cv", 3.0, c=(0.2, -0.1)),
            Phase("ca", 4.0, c=(0.2, -0.1), accel=(0.05, -0.02)),
            Phase("mixed", 5.0, c=(0.1, 0.3), amplitude=(0.2, 0.1), omega=(0.5, 0.0), phi=(0.3, 1.0),
                  accel=(-0.03, 0.01)),
        )
    )


def test_accel_phase_velocity_and_acceleration_are_the_exact_formulas():
    prof = _accel_profile()
    tau = np.linspace(0.0, 3.9, 40)
    np.testing.assert_allclose(prof.velocity(3.0 + tau), [0.2, -0.1] + np.outer(tau, [0.05, -0.02]), atol=1e-12)
    np.testing.assert_allclose(prof.acceleration(3.0 + tau), np.tile([0.05, -0.02], (40, 1)), atol=1e-15)
    v = prof.velocity(7.0 + tau)
    np.testing.assert_allclose(v[:, 0], 0.1 - 0.03 * tau + 0.2 * np.sin(0.5 * tau + 0.3), atol=1e-12)
    np.testing.assert_allclose(v[:, 1], 0.3 + 0.01 * tau + 0.1 * np.sin(1.0), atol=1e-12)
    a = prof.acceleration(7.0 + tau)
    np.testing.assert_allclose(a[:, 0], -0.03 + 0.2 * 0.5 * np.cos(0.5 * tau + 0.3), atol=1e-12)
    np.testing.assert_allclose(a[:, 1], 0.01, atol=1e-15)


def test_accel_phase_position_is_the_exact_integral_of_velocity():
    prof = _accel_profile()
    start = (0.5, -0.25)
    t = np.linspace(0.0, 15.0, 150_001)  # past the end (12 s): the last phase, accel included, continues
    np.testing.assert_allclose(prof.position(t, start), _midpoint_positions(prof, t, start), atol=1e-9)
    # the CA phase in closed form: p = p(3) + c·τ + a·τ²/2
    p3 = np.array(start) + 3.0 * np.array([0.2, -0.1])
    np.testing.assert_allclose(prof.position(5.0, start), p3 + 2.0 * np.array([0.2, -0.1])
                               + 0.5 * 4.0 * np.array([0.05, -0.02]), atol=1e-12)


def test_accel_acceleration_is_the_derivative_of_velocity_and_velocity_of_position():
    prof = _accel_profile()
    t = np.array([1.0, 4.0, 6.5, 8.0, 11.0, 14.0])
    h = 1e-5
    np.testing.assert_allclose(prof.acceleration(t), (prof.velocity(t + h) - prof.velocity(t - h)) / (2 * h),
                               atol=1e-8)
    np.testing.assert_allclose(prof.velocity(t), (prof.position(t + h) - prof.position(t - h)) / (2 * h),
                               atol=1e-8)


def test_accel_keeps_growing_beyond_the_end_of_the_profile():
    prof = VelocityProfile((Phase("ca", 2.0, c=(0.1, 0.0), accel=(0.05, 0.0)),))
    np.testing.assert_allclose(prof.velocity(10.0), [0.1 + 0.05 * 10.0, 0.0])


def test_accel_defaults_to_zero_and_is_validated():
    assert Phase("p", 1.0).accel == (0.0, 0.0)
    assert Phase("p", 1.0, accel=[1, 2]).accel == (1.0, 2.0)
    with pytest.raises(ValueError):
        Phase("p", 1.0, accel=(1.0,))
    # the positional order of the older fields is unchanged
    ph = Phase("p", 1.0, (1.0, 2.0), (0.5, 0.5), (0.1, 0.2), (0.0, math.pi))
    assert ph.phi == (0.0, math.pi) and ph.accel == (0.0, 0.0)


# ---------------------------------------------------------------------- ground robot
SEGMENTS = [("cv", 2.0, 0.0), ("ca", 1.5, 0.08), ("ct", 3.0, 0.7), Segment("ca", 2.0, -0.1), ("ct", 1.0, -1.2),
            ("cv", 0.5, 0.0)]


def _speed_heading(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return np.linalg.norm(v, axis=-1), np.arctan2(v[..., 1], v[..., 0])


def _wrap(angle):
    return np.remainder(np.asarray(angle) + np.pi, 2 * np.pi) - np.pi


def test_ground_robot_phases_are_named_by_kind_and_last_the_segment_durations():
    prof = ground_robot_profile(SEGMENTS, heading=0.3, speed=0.2)
    assert prof.phase_names == ("cv", "ca", "ct", "ca", "ct", "cv")
    assert [p.duration for p in prof] == [2.0, 1.5, 3.0, 2.0, 1.0, 0.5]
    np.testing.assert_allclose(prof.velocity(0.0), 0.2 * np.array([math.cos(0.3), math.sin(0.3)]))


def test_ground_robot_velocity_is_continuous_at_every_boundary():
    prof = ground_robot_profile(SEGMENTS, heading=-2.0, speed=0.15)
    for b in prof.phase_starts[1:]:
        np.testing.assert_allclose(prof.velocity(b - 1e-9), prof.velocity(b), atol=1e-9)
        # and exactly: the previous phase evaluated at its full duration is the next one's start
        k = int(prof.phase_index(b))
        end = VelocityProfile((prof[k - 1],)).velocity(prof[k - 1].duration)
        np.testing.assert_allclose(end, prof.velocity(b), atol=1e-14)


def test_cv_segment_keeps_speed_and_heading():
    prof = ground_robot_profile([("cv", 2.0, 123.0)], heading=1.0, speed=0.25)  # the value is ignored
    speed, heading = _speed_heading(prof.velocity(np.linspace(0, 2, 21)))
    np.testing.assert_allclose(speed, 0.25)
    np.testing.assert_allclose(heading, 1.0)
    np.testing.assert_allclose(prof.acceleration(1.0), [0.0, 0.0])


def test_ct_segment_keeps_speed_and_rotates_heading_by_rate_times_duration():
    psi0, rate, duration = 2.5, 0.7, 3.0
    prof = ground_robot_profile([("ct", duration, rate), ("cv", 1.0, 0.0)], heading=psi0, speed=0.2)
    tau = np.linspace(0.0, duration, 31)
    speed, heading = _speed_heading(prof.velocity(tau))
    np.testing.assert_allclose(speed, 0.2, atol=1e-14)
    np.testing.assert_allclose(_wrap(heading - (psi0 + rate * tau)), 0.0, atol=1e-12)
    _, end_heading = _speed_heading(prof.velocity(duration))  # the next segment starts with the turned heading
    assert _wrap(end_heading - psi0) == pytest.approx(_wrap(rate * duration))
    # the turn's acceleration is centripetal: |a| = V·ω, perpendicular to v
    a, v = prof.acceleration(1.3), prof.velocity(1.3)
    assert np.linalg.norm(a) == pytest.approx(0.2 * rate) and abs(a @ v) < 1e-14


def test_ct_segment_with_zero_rate_is_a_straight_line():
    prof = ground_robot_profile([("ct", 2.0, 0.0)], heading=0.4, speed=0.3)
    np.testing.assert_allclose(prof.position(2.0), 0.6 * np.array([math.cos(0.4), math.sin(0.4)]), atol=1e-14)


def test_ca_segment_changes_speed_by_accel_times_duration_along_the_heading():
    prof = ground_robot_profile([("ca", 2.5, 0.04), ("cv", 1.0, 0.0)], heading=-0.8, speed=0.1)
    tau = np.linspace(0.0, 2.5, 26)
    speed, heading = _speed_heading(prof.velocity(tau))
    np.testing.assert_allclose(speed, 0.1 + 0.04 * tau, atol=1e-14)
    np.testing.assert_allclose(heading, -0.8, atol=1e-12)
    np.testing.assert_allclose(prof.acceleration(1.0), 0.04 * np.array([math.cos(-0.8), math.sin(-0.8)]))
    np.testing.assert_allclose(np.linalg.norm(prof.velocity(3.0)), 0.2)  # the next segment keeps the new speed
    np.testing.assert_allclose(np.linalg.norm(prof.position(2.5)), 0.1 * 2.5 + 0.5 * 0.04 * 2.5**2)


def test_ground_robot_position_is_the_integral_of_its_velocity():
    prof = ground_robot_profile(SEGMENTS, heading=0.5, speed=0.2)
    t = np.linspace(0.0, prof.total_duration, 100_001)
    np.testing.assert_allclose(prof.position(t, (0.3, -0.4)), _midpoint_positions(prof, t, (0.3, -0.4)), atol=1e-9)


def test_ca_segment_driving_the_speed_negative_is_refused_but_reaching_zero_is_allowed():
    with pytest.raises(ValueError, match="segment 1 .*negative"):
        ground_robot_profile([("cv", 1.0, 0.0), ("ca", 2.0, -0.11)], speed=0.2)
    prof = ground_robot_profile([("ca", 2.0, -0.1), ("ct", 1.0, 0.5), ("ca", 1.0, 0.1)], heading=1.0, speed=0.2)
    np.testing.assert_allclose(prof.velocity([2.0, 2.5]), 0.0, atol=1e-15)  # stopped, turning on the spot
    _, heading = _speed_heading(prof.velocity(3.5))
    assert heading == pytest.approx(1.5)
    ground_robot_profile([("ca", 3.0, -0.1)], speed=0.3)  # 0.3 − 0.1·3 rounds to −5.6e-17: still zero


@pytest.mark.parametrize(
    ("segments", "match"),
    [
        ([("cv", 1.0, 0.0), ("jump", 1.0, 0.0)], "segment 1: unknown kind 'jump'"),
        ([("cv", 0.0, 0.0)], r"segment 0 \(cv\): duration"),
        ([("ct", 1.0, 0.1), ("ct", -1.0, 0.1)], r"segment 1 \(ct\): duration"),
        ([("ct", 1.0)], "segment 0: expected"),
        ([("ca", 1.0, math.nan)], "segment 0 .*value"),
        ([], "at least one segment"),
    ],
)
def test_bad_segments_are_refused_naming_the_segment(segments, match):
    with pytest.raises(ValueError, match=match):
        ground_robot_profile(segments, speed=0.1)


def test_negative_start_speed_is_refused():
    with pytest.raises(ValueError):
        ground_robot_profile([("cv", 1.0, 0.0)], speed=-0.1)


# ---------------------------------------------------------------------- evasive segments
def _evasive(seed: int, duration: float = 120.0, **kw):
    heading, speed, start = kw.pop("heading", 0.0), kw.pop("speed", 0.2), kw.pop("start", (0.0, 0.0))
    segments = evasive_segments(np.random.default_rng(seed), duration, start=start, heading=heading, speed=speed,
                                **kw)
    return segments, ground_robot_profile(segments, heading, speed)


@pytest.mark.parametrize("seed", range(8))
def test_evasive_segments_cover_exactly_the_duration(seed):
    segments, prof = _evasive(seed, duration=47.3)
    assert prof.total_duration == pytest.approx(47.3, rel=1e-14, abs=0)
    assert all(s.kind in ("cv", "ca", "ct") for s in segments)
    assert all(0.5 <= s.duration <= 2.0 for s in segments[:-1]) and 0.0 < segments[-1].duration <= 2.0


@pytest.mark.slow
@pytest.mark.parametrize(
    ("seed", "kw"),
    [(s, {}) for s in range(10)]
    + [
        (10, {"start": (0.7, -0.6), "heading": 2.0, "speed": 0.1}),
        (11, {"half_width": 0.5, "speed_range": (0.05, 0.2), "speed": 0.1}),
        (12, {"segment_range": (0.2, 4.0), "accel_max": 0.5, "turn_rate_max": 2.0}),
    ],
)
def test_evasive_robot_stays_inside_the_square_and_within_the_speed_bounds(seed, kw):
    half_width = kw.get("half_width", 1.0)
    low, high = kw.get("speed_range", (0.1, 0.3))
    segments, prof = _evasive(seed, **kw)
    t = np.linspace(0.0, prof.total_duration, int(prof.total_duration / 0.002) + 1)
    assert np.abs(prof.position(t, kw.get("start", (0.0, 0.0)))).max() <= half_width
    speed = np.linalg.norm(prof.velocity(t), axis=-1)
    assert speed.min() >= low - 1e-12 and speed.max() <= high + 1e-12
    turns = np.array([s.value for s in segments if s.kind == "ct"])
    accels = np.array([s.value for s in segments if s.kind == "ca"])
    assert np.abs(turns).max() <= kw.get("turn_rate_max", 1.0) and np.abs(accels).max() <= kw.get("accel_max", 0.1)


def test_evasive_robot_manoeuvres_with_every_kind_and_reaches_the_edges():
    segments, prof = _evasive(0, duration=300.0)
    kinds = [s.kind for s in segments]
    assert {"cv", "ca", "ct"} <= set(kinds) and len(segments) > 100
    p = prof.position(np.linspace(0.0, 300.0, 30_001))
    assert np.abs(p).max() > 0.8  # it uses the room, not just the middle of it


def test_evasive_segments_are_reproducible_for_equal_seeds_and_differ_for_different_seeds():
    a, _ = _evasive(42, duration=60.0)
    b, _ = _evasive(42, duration=60.0)
    c, _ = _evasive(43, duration=60.0)
    assert a == b
    assert a != c


@pytest.mark.parametrize(
    "kw",
    [
        {"speed": 0.5},  # outside speed_range
        {"start": (1.2, 0.0)},  # outside the square
        {"start": (0.95, 0.0), "heading": 0.0},  # at the edge heading out: cannot turn back
        {"half_width": 0.3},  # the turning circle (radius 0.2 m) does not fit
        {"segment_range": (0.0, 1.0)},
        {"speed_range": (0.3, 0.1)},
        {"turn_rate_max": 0.0},
        {"accel_max": -0.1},
    ],
)
def test_evasive_segments_refuse_inconsistent_settings(kw):
    with pytest.raises(ValueError):
        evasive_segments(np.random.default_rng(0), 10.0, **kw)
