"""What a multi-target scenario may say: an LMB filter reads unlabelled detections only, fuses them as current, and
spreads its clutter over a bounded field of view; a filter that follows one target by its label refuses a sensor
that gives none. Each refusal is one line naming the field."""

import pytest

from swarmtrack.scenarios.loader import ScenarioError, load_scenario


def test_the_box_scenarios_validate():
    for name in ("mtt-box-easy", "mtt-box-hard"):
        s = load_scenario(name)
        assert s.estimator.kind == "lmb" and s.sensor.kind == "position"


@pytest.mark.parametrize(("name", "override", "says"), [
    ("l24-ct", ["estimator={kind: lmb}", "sensor.latency=0"], "sensor.labelled is true"),
    ("l24-ct", ["estimator={kind: lmb}", "sensor.labelled=false"], "sensor.latency"),
    ("l24-ct", ["sensor.labelled=false"], "sensor.labelled is false"),
    ("mtt-box-easy", ["estimator.detection_probability=0"], "estimator.detection_probability"),
    ("mtt-box-easy", ["estimator.detection_probability=1.2"], "estimator.detection_probability"),
    ("mtt-box-easy", ["estimator.clutter_rate=-1"], "estimator.clutter_rate"),
    ("mtt-box-easy", ["sensor.clutter_rate=0", "sensor.half_width=null", "estimator.clutter_rate=2"],
     "estimator.clutter_rate is spread"),
    ("mtt-box-easy", ["sensor={kind: range_bearing, max_range: 150}"], "sensor.labelled is true"),
])
def test_bad_multi_target_settings_are_refused_naming_the_field(name, override, says):
    with pytest.raises(ScenarioError, match=says):
        load_scenario(name, override)
