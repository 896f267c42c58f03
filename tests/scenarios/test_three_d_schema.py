"""Bad 3-D settings are refused with the field named (exit 2, nothing written): a 3-D sensor with a planar estimator
or the reverse, an elevation noise that is not positive, an estimator or a gate built for the plane only."""

import pytest
from click.testing import CliRunner

from swarmtrack.cli import main
from swarmtrack.scenarios import load_scenario

THREE_D = ["sensor.kind=range_bearing_elevation", "estimator.model=ct3d"]


@pytest.mark.parametrize("scenario, overrides, words", [
    ("l24-ct", ["sensor.kind=range_bearing_elevation"], ["estimator.model ct", "needs 3-D models"]),
    ("l24-ct", ["estimator.model=cv3d"], ["estimator.model cv3d", "needs planar models"]),
    ("l24-imm", ["sensor.kind=range_bearing_elevation", "estimator.models=cv3d,ct"], ["estimator.models ct"]),
    ("l24-ct", [*THREE_D, "sensor.sigma_elevation=0"], ["sensor.sigma_elevation", "greater than 0"]),
    ("l24-ct", [*THREE_D, "sensor.sigma_elevation=-0.02"], ["sensor.sigma_elevation"]),
    ("l24-ct", [*THREE_D, "estimator.gating=chi2"], ["estimator.gating", "planar"]),
    ("l24-ct", [*THREE_D, "sensor.occluders=[{region: [0, 0, 1, 1]}]"], ["sensor.occluders", "planar regions"]),
    ("w20-mpc-single", ["sensor.kind=range_bearing_elevation"], ["range_bearing_elevation", "multimodel"]),
    ("l24-3d-ct", ["target.altitude=-1"], ["target", "altitude", "greater than or equal to 0"]),
    ("l24-3d-ct", ["target.profile=l24", "target.altitude=0", "sensor.kind=range_bearing",
                   "sensor.sigma_elevation=0.02", "estimator.model=ct"], ["sensor.sigma_elevation"]),
    ("l24-ct", ["swarm.altitude=5"], ["swarm.altitude is 5 m", "planar"]),
    ("l24-ct", ["target.profile=l24-3d"], ["targets.members[0].profile", "planar"]),
    ("l24-ct", ["target.altitude=2"], ["targets.members[0].altitude", "planar"]),
    ("l24-ct", ["swarm.altitude=-3"], ["swarm.altitude"]),
])
def test_bad_3d_settings_exit_2_naming_the_field(scenario, overrides, words, tmp_path):
    args = ["validate", scenario]
    for o in overrides:
        args += ["--set", o]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 2, result.output
    for w in words:
        assert w in result.output, result.output
    assert "Traceback" not in result.output


def test_a_3d_sensor_with_3d_models_is_accepted():
    s = load_scenario("l24-ct", THREE_D)
    assert s.sensor.sigma_elevation == s.sensor.sigma_bearing == 0.02
    imm = load_scenario("l24-imm", ["sensor.kind=range_bearing_elevation", "estimator.models=cv3d,ct3d,fs3d"])
    assert imm.estimator.models == ["cv3d", "ct3d", "fs3d"] and imm.sensor.three_d


def test_a_custom_phase_climbs_and_a_descent_below_the_ground_is_refused():
    phases = ("target.phases=[{name: up, duration: 10, c: [0.5, 0], climb: {c: 0.2}}, "
              "{name: down, duration: 10, climb: {c: -0.25}}]")
    s = load_scenario("l24-ct", [*THREE_D, "target.profile=custom", "target.altitude=1.0", phases])
    profile = s.targets.members[0].velocity_profile()
    assert profile.height(10.0, 1.0) == pytest.approx(3.0) and profile.height(20.0, 1.0) == pytest.approx(0.5)
    with pytest.raises(Exception, match=r"below the ground: z = -0\.30 m at t = 20\.00 s"):
        load_scenario("l24-ct", [*THREE_D, "target.profile=custom", "target.altitude=0.2", phases])
