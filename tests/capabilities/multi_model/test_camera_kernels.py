"""The camera compiled (camera_kernels) senses what its numpy reference (sensors/camera.py) senses, frame by frame:
the ideal camera alone, with occluders and in a batch of worlds, and the camera with the error budget (the servos'
lag, the offsets, the marker noise's growth with numpy's fast powers and a general one), the servos' angles too."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from swarmtrack.capabilities.multi_model.sensor import CompiledCamera, ImperfectCamera
from swarmtrack.scenarios import load_scenario
from swarmtrack.sim.batch import build_batch
from swarmtrack.sim.build import build
from swarmtrack.sim.sensors import CameraSensor


def _reference(sensor):
    """The same camera with its numpy frames (its own, fresh state)."""
    if isinstance(sensor, ImperfectCamera):
        return dataclasses.replace(sensor, compiled=False, state={})
    assert type(sensor) is CompiledCamera
    return CameraSensor(**{f.name: getattr(sensor, f.name) for f in dataclasses.fields(CameraSensor)})


def _close(a, b) -> None:
    """Bit for bit where numpy sums as this project's machines do; 1e-12 of the reference's scale on any other."""
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape and a.dtype == b.dtype
    if b.dtype.kind != "f" or not b.size:
        np.testing.assert_array_equal(a, b)
        return
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * np.abs(b).max())


@pytest.mark.parametrize(("name", "overrides", "seeds"), [
    ("w20-switching-ideal", [], (1,)),
    ("w20-occlusion-ideal", ["sensor.occluders=[{window: [0.0, 0.5], uavs: [2]}]"], (1,)),
    ("w20-switching-ideal", [], (1, 2, 3)),  # a batch of worlds
    ("w20-switching", [], (1,)),
    ("w20-switching", ["sensor.noise_distance_power=2", "sensor.noise_angle_power=0.5"], (2, 3)),
    ("w20-switching", ["sensor.noise_distance_power=1.3", "sensor.noise_angle_power=0"], (4,)),
    ("w20-switching", ["sensor.servo_speed=null"], (1, 2)),  # the servos reach the command at once
])
def test_the_compiled_camera_senses_as_the_numpy_one(name, overrides, seeds):
    scenarios = [load_scenario(name, ["duration=1", *overrides], seed=s) for s in seeds]
    worlds = [build_batch(scenarios)[0].world if len(seeds) > 1 else build(scenarios[0]).world for _ in range(2)]
    fast, ref = worlds
    assert type(fast.sensor) in (CompiledCamera, ImperfectCamera) and getattr(fast.sensor, "compiled", True)
    ref.sensor = _reference(ref.sensor)
    rng = np.random.default_rng(9)
    n = len(fast.truth("uavs"))
    for k in range(20):
        aim = None if k == 0 else fast.truth("targets")[:, :2].repeat(n // len(seeds), 0)[:n] + \
            rng.normal(0, 0.3, (n, 2))
        if k == 3:
            aim[0] = np.nan  # no estimate yet: home
        (det_f, src_f), (det_r, src_r) = fast.sense(aim), ref.sense(aim)
        _close(src_f, src_r)
        for field in ("owner", "z", "sensor_pos", "label", "frame"):
            _close(getattr(det_f, field), getattr(det_r, field))
        assert (det_f.n_uavs, det_f.taken) == (det_r.n_uavs, det_r.taken)
        if "servo" in getattr(ref.sensor, "state", {}):  # the servos' angles
            _close(fast.sensor.state["servo"], ref.sensor.state["servo"])
        for world in worlds:
            world.advance({"uavs": np.zeros((n, 2))}, 3)
    assert len(det_f.owner)  # the cameras saw the target
