import numpy as np
import pytest

from swarmtrack.autopilot.frames import enu_to_ned, ned_to_enu, wrap, yaw_enu_to_ned, yaw_ned_to_enu


def test_east_north_up_is_north_east_down_swapped_and_negated():
    assert np.array_equal(enu_to_ned([1.0, 0.0, 0.0]), [0.0, 1.0, 0.0])  # east is NED's y
    assert np.array_equal(enu_to_ned([0.0, 1.0, 0.0]), [1.0, 0.0, 0.0])  # north is NED's x
    assert np.array_equal(enu_to_ned([0.0, 0.0, 2.0]), [0.0, 0.0, -2.0])  # up is minus down
    assert np.array_equal(enu_to_ned([3.0, 4.0]), [4.0, 3.0])  # planar


def test_the_maps_are_their_own_inverses_on_batches():
    v = np.random.default_rng(0).normal(size=(50, 3))
    assert np.array_equal(ned_to_enu(enu_to_ned(v)), v)
    psi = np.random.default_rng(1).uniform(-np.pi, np.pi, 100)
    assert np.allclose(yaw_ned_to_enu(yaw_enu_to_ned(psi)), psi, atol=1e-12)


@pytest.mark.parametrize("enu, ned", [(0.0, np.pi / 2), (np.pi / 2, 0.0), (np.pi, -np.pi / 2), (-np.pi / 2, np.pi)])
def test_headings_east_north_west_south(enu, ned):
    # facing east (ENU 0) is NED yaw 90° (from north, clockwise); facing north is 0; west is −90°; south is 180°
    assert np.isclose(yaw_enu_to_ned(enu), ned)


def test_a_heading_keeps_pointing_where_the_velocity_points():
    v_enu = np.array([1.0, 2.0, 0.0])
    v_ned = enu_to_ned(v_enu)
    assert np.isclose(yaw_enu_to_ned(np.arctan2(v_enu[1], v_enu[0])), np.arctan2(v_ned[1], v_ned[0]))


def test_wrap_is_in_minus_pi_to_pi():
    a = wrap(np.array([-np.pi, np.pi, 3 * np.pi, -3 * np.pi + 0.1, 0.2]))
    assert np.all((a > -np.pi) & (a <= np.pi)) and np.isclose(a[-1], 0.2)
