"""Bad multi-model and camera settings are refused with the field named (exit 2 through the CLI)."""

import pytest

from swarmtrack.scenarios import load_scenario


@pytest.mark.parametrize("override, words", [
    ("estimator.models=cv,ca", ["estimator.models", "2 model(s) for 3 UAVs"]),
    ("estimator.models=cv,xx,ct", ["estimator.models", "'cv', 'ca' or 'ct'"]),
    ("estimator.fusion=vote", ["estimator.fusion", "'ttest'"]),
    ("estimator.window=1", ["estimator.window"]),
    ("estimator.markov=[[0.99,0.01,0.009],[0.001,0.99,0.009],[0.005,0.005,0.99]]",
     ["estimator.markov", "row 1 sums to 1.009"]),
    ("estimator.markov=[[1.1,-0.1,0],[0,1,0],[0,0,1]]", ["estimator.markov", "negative"]),
    ("estimator.markov=[[1,0],[0,1]]", ["estimator.markov", "2 x 2", "3 UAVs"]),
    ("sensor.occluders=[{region: [0, 0, 1, 1], uavs: [4]}]", ["sensor.occluders[0].uavs", "UAV 4"]),
    ("sensor.occluders=[{uavs: [1]}]", ["sensor.occluders", "region, a window or both"]),
    ("sensor.sigma_range=0.1", ["sensor.sigma_range"]),
])
def test_bad_multimodel_settings_exit_2_naming_the_field(override, words, refused):
    refused("w20-evasive", override, words)


def test_the_thesis_markov_matrix_as_corrected_is_accepted():
    s = load_scenario("w20-evasive", [])
    assert s.estimator.markov[0] == [0.99, 0.001, 0.009]  # Table 4.3's first row, corrected to sum to 1


def test_a_model_list_may_be_given_as_text():
    s = load_scenario("w20-switching", ["estimator.models=ct,ct,ct"])
    assert s.estimator.models == ["ct", "ct", "ct"]
