"""Bad delay, liar, gating and late-data settings are refused with the field and the cause named (exit 2)."""

import pytest


@pytest.mark.parametrize("scenario, override, words", [
    ("robust-5", "network.delay=-0.1", ["network.delay", "greater than or equal to 0"]),
    ("robust-5", "network.delay_max=-1", ["network.delay_max"]),
    ("robust-5", "network={topology: full, delay: 0.5, delay_max: 0.2}", ["delay_max", "smaller than delay"]),
    ("robust-5", "network.delay_max=1000", ["network.delay_max", "not shorter than the run"]),
    ("w20-switching", "network.delay=0.1", ["network.delay", "'multimodel' estimator does not read time stamps"]),
    ("ib21-fleet-6", "network.delay_max=0.5", ["network.delay", "estimator.delayed_data: refilter"]),
    ("ib21-fleet-6", "estimator.delayed_data=as_current", ["estimator.delayed_data", "refused", "refilter"]),
    ("robust-5", "network.liar={uav: 6}", ["network.liar.uav", "UAV 6", "1..5"]),
    ("robust-5", "network.liar={uav: 0}", ["network.liar.uav"]),
    ("robust-5", "network.liar={uav: 2, mode: loud}", ["network.liar.mode"]),
    ("w20-switching", "network.liar={uav: 1}", ["network.liar", "estimator.kind information"]),
    ("robust-5", "estimator.gating=maybe", ["estimator.gating"]),
    ("robust-5", "estimator.gate_probability=1.5", ["estimator.gate_probability"]),
    ("robust-5", "sensor.latency=0.12", ["sensor.latency", "whole number of estimation periods", "as_current"]),
    ("robust-5", "network.delay=1000", ["network.delay (1000 s)", "not shorter than the run"]),
    ("robust-5", "network.liar={uav: 2, start: 1000}", ["network.liar.start", "before the end of the run"]),
    ("robust-5", "network={topology: none, liar: {uav: 2}}", ["network.liar", "topology is none"]),
])
def test_bad_network_settings_exit_2_naming_the_field(refused, scenario, override, words):
    refused(scenario, override, words)


def _validate(*overrides):
    from click.testing import CliRunner

    from swarmtrack.cli import main

    return CliRunner().invoke(main, ["validate", "robust-5", *[a for o in overrides for a in ("--set", o)]])


def test_shared_raw_measurements_cannot_be_delayed_and_a_lone_uav_waits_for_nothing():
    res = _validate("network.delay=0.1", "estimator={kind: information, share: measurements, delayed_data: as_current}")
    assert res.exit_code == 2 and "network.delay needs estimator.share information" in res.output, res.output
    from swarmtrack.capabilities.tracking_swarm.settings import refiltered_steps
    from swarmtrack.scenarios import load_scenario

    alone = load_scenario("robust-5", ["network={topology: none, delay: 0.1}"])  # valid: nobody to wait for
    assert refiltered_steps(alone) == 0
    assert refiltered_steps(load_scenario("robust-5", ["network.delay=0.1"])) == 2
    assert refiltered_steps(load_scenario("robust-5", ["network.delay=0.100000025"])) == 3  # as the channel waits


def test_combinations_that_are_not_built_are_refused(refused):
    refused("l24-cv", "estimator={kind: information, share: measurements, delayed_data: refilter}",
            ["delayed_data refilter", "share information"])
    refused("l24-cv", "estimator={kind: information, gating: ci, delayed_data: refilter}",
            ["gating ci", "late data"])
    refused("l24-cv", "estimator={kind: centralized, gating: chi2}", ["estimator.gating", "neighbours"])


def test_the_set_membership_estimator_replays_over_the_delay_bound_rounded_up_to_sharing_periods():
    from swarmtrack.estimation.setmembership import ReplayingSetMembershipEstimator, SetMembershipEstimator
    from swarmtrack.scenarios import load_scenario
    from swarmtrack.sim.build import build

    def window(*overrides):
        scn = load_scenario("ib21-fleet-2", ["duration=5", *overrides])
        return scn.estimator.replayed_periods(scn)

    on = "estimator.delayed_data=refilter"
    assert window(on, "network.delay=0.5") == 1 and window(on, "network.delay_max=1.0") == 2  # T^c = 0.5 s
    assert window(on, "network.delay=0.01") == 1 and window(on, "network.delay_max=0.51") == 2  # rounded up
    assert window(on, "network.delay=0.500000025") == 2  # as the channel waits (delay_steps: 11 steps of 0.05 s)
    assert window(on) == 0 and window(on, "network={topology: none, delay: 0.5}") == 0
    late = build(load_scenario("ib21-fleet-2", ["duration=5", on, "network.delay_max=1.0"])).stack.estimator
    assert type(late) is ReplayingSetMembershipEstimator and late.window == 2
    plain = build(load_scenario("ib21-fleet-2", ["duration=5", on])).stack.estimator
    assert type(plain) is SetMembershipEstimator  # no delay: the plain estimator, nothing kept
