"""W20 Ch. 4's truth side: the gimballed camera the world senses with, ideal or with its error budget (never
onboard)."""

from __future__ import annotations

import numpy as np

from swarmtrack.capabilities.multi_model.sensor import Budget, CompiledCamera, ImperfectCamera
from swarmtrack.capabilities.multi_model.settings import CameraSpec
from swarmtrack.scenarios.schema import Scenario
from swarmtrack.sim.build import occluders
from swarmtrack.sim.sensors import CameraSensor


def camera(s: CameraSpec, scenario: Scenario) -> CameraSensor:
    """The ideal camera, or with any of the error budget's sources on, :class:`ImperfectCamera` (issue 27); their
    frames compiled unless ``kernels: numpy`` (:class:`CompiledCamera`, ``ImperfectCamera.compiled``)."""
    tan_half = (0.5 * s.footprint[0] / s.footprint_range, 0.5 * s.footprint[1] / s.footprint_range)
    compiled = scenario.kernels != "numpy"
    if s.ideal():
        return (CompiledCamera if compiled else CameraSensor)(s.sigma, s.height, tan_half, tuple(s.home),
                                                              occluders(s), s.latency)
    budget = Budget(s.footprint_range, s.noise_distance_power, s.noise_angle_power, np.radians(s.servo_deadband),
                    np.inf if s.servo_speed is None else np.radians(s.servo_speed), np.radians(s.servo_zero_std),
                    s.mount_offset_std)
    return ImperfectCamera(s.sigma, s.height, tan_half, tuple(s.home), occluders(s), s.latency, budget=budget,
                           compiled=compiled)
