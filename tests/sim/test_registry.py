"""A new capability adds modules and a registry entry, not a branch in the engine: a sensor, an estimator and a
controller defined only in this test (outside the package), with their own recorded probe, metric and figure, run
through the unchanged step loop, ``swarmtrack run``, the metrics, the figures, ``sweep`` and ``summarize`` with no
edit anywhere else."""

import json
from typing import Literal

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

import swarmtrack
from swarmtrack import registry
from swarmtrack.analysis.metrics import rmse_table, summary
from swarmtrack.cli import main
from swarmtrack.estimation.base import Probe, TargetView
from swarmtrack.scenarios import schema
from swarmtrack.scenarios.loader import ScenarioError, load_raw, validate
from swarmtrack.sensors import range_bearing
from swarmtrack.sensors.range_bearing import to_position
from swarmtrack.sim.engine import simulate
from swarmtrack.sim.sensors import Scene, Sensor


class CentroidSpec(schema.EstimatorSpec):
    kind: Literal["test-centroid"] = "test-centroid"
    target: int = 1

    def followed_target(self) -> int:
        return self.target


class SilentSpec(schema.EstimatorSpec):
    """An estimator that follows no single target and records nothing of capability 1's."""

    kind: Literal["test-silent"] = "test-silent"


class SilentEstimator:
    probes = (Probe("heard", ()),)

    def __init__(self, n: int):
        self.n = n

    def share(self, t, nav, own):
        return {}

    def fuse(self, t, own, inbox):
        pass

    def view(self):
        return TargetView(np.zeros((self.n, 4)))

    def sample(self):
        return {"heard": np.zeros(self.n)}


class CentroidEstimator:
    """Each UAV's estimate: the mean of the positions its own and its neighbours' detections imply."""

    probes = (Probe("estimate", (4,)), Probe("covariance", (4, 4)), Probe("heard", ()))

    def __init__(self, n: int, label: int):
        self.n, self.label = n, label
        self.x = np.zeros((n, 4))
        self.heard = np.zeros(n)

    def share(self, t, nav, own):
        z, pos, seen = own.of_label(self.label)
        implied = np.where(seen[:, None], to_position(z, pos), 0.0)
        return {"sum": implied, "count": seen.astype(float)}

    def fuse(self, t, own, inbox):
        total = inbox.payloads["sum"] + inbox.sum("sum")
        count = inbox.payloads["count"] + inbox.sum("count")
        self.x[:, :2] = total / np.maximum(count, 1)[:, None]
        self.heard = count

    def view(self):
        return TargetView(self.x.copy())

    def sample(self):
        return {"estimate": self.x, "covariance": np.broadcast_to(np.eye(4), (self.n, 4, 4)), "heard": self.heard}


class HoldSpec(schema.ControllerSpec):
    kind: Literal["test-hold"] = "test-hold"
    gain: float = 2.0


class HoldController:
    """Brake to a stop wherever the UAV is (ignores beacons and the target)."""

    probes = ()

    def __init__(self, gain: float):
        self.gain = gain

    def broadcast(self, t, nav):
        return {}

    def command(self, t, nav, view, inbox, dt):
        return -self.gain * nav[:, 2:4]

    def sample(self):
        return {}


@pytest.fixture
def registered():
    registry.register("estimator", CentroidSpec,
                      lambda spec, ctx: CentroidEstimator(ctx.n_uavs, ctx.label_of("targets", spec.target - 1)))
    registry.register("estimator", SilentSpec, lambda spec, ctx: SilentEstimator(ctx.n_uavs))
    registry.register("controller", HoldSpec, lambda spec, ctx: HoldController(spec.gain))
    yield
    registry.unregister("estimator", "test-centroid")
    registry.unregister("estimator", "test-silent")
    registry.unregister("controller", "test-hold")


def _scenario(estimator: dict, controller: dict):
    data = load_raw("l24-cv")
    data.update(estimator=estimator, controller=controller, duration=5.0,
                target={"profile": "hover", "start": [1.0, 2.0], "wind_std": 0.0})
    data["sensor"]["latency"] = 0.0
    data["network"]["topology"] = "full"
    return validate(data)


def test_a_registered_estimator_and_controller_run_through_the_unchanged_engine(registered):
    rec = simulate(_scenario({"kind": "test-centroid"}, {"kind": "test-hold", "gain": 3.0}))
    assert rec.meta["probes"] == {"estimate": [4], "covariance": [4, 4], "heard": []}
    heard = np.concatenate([c.probes["heard"] for c in rec.chunks()])
    assert (heard == 3).all()  # full topology: each UAV fused its own and two neighbours' detections
    assert rmse_table(rec)["total"]["x"] < 0.1  # three range-bearing fixes of a hovering target, averaged
    speed = np.linalg.norm(rec.uav[-1, :, 2:4], axis=1)
    assert speed.max() < 0.05  # the hold controller commanded the UAVs, not flocking


def test_an_unregistered_kind_is_a_clear_error_naming_the_known_ones():
    known = "centralized, gnn, imm, information, jpda, lmb, multimodel"
    with pytest.raises(ScenarioError, match=rf"estimator: unknown kind 'test-centroid'; known: {known}"):
        _scenario({"kind": "test-centroid"}, {"kind": "flocking"})


def test_a_registered_kind_validates_its_own_fields(registered):
    with pytest.raises(ScenarioError, match=r"controller.gain: Input should be a valid number"):
        _scenario({"kind": "test-centroid"}, {"kind": "test-hold", "gain": "fast"})


def test_an_estimator_that_follows_no_target_runs_and_reports_what_applies(registered):
    rec = simulate(_scenario({"kind": "test-silent"}, {"kind": "test-hold"}))
    assert rec.tracked is None
    metrics = summary(rec)
    assert "rmse" not in metrics and "target_distance" not in metrics and "inter_agent_distance" in metrics
    with pytest.raises(ScenarioError, match="follow: truth needs an estimator that follows one target"):
        _scenario({"kind": "test-silent"}, {"kind": "flocking", "follow": "truth"})


def test_a_kind_is_registered_once(registered):
    with pytest.raises(ValueError, match="already registered"):
        registry.register("estimator", CentroidSpec, lambda spec, ctx: None)


@pytest.mark.parametrize("role", registry.ROLES)
@pytest.mark.parametrize("kind", [[1, 2], {"a": 1}, 3, None, True, "no-such-kind"])
def test_a_kind_that_is_not_a_registered_name_is_refused_for_every_role(role, kind):
    data = load_raw("l24-ct")
    data[role] = {**data.get(role, {}), "kind": kind}
    with pytest.raises(ScenarioError, match=rf"{role}: unknown kind .*; known: "):
        validate(data)
    with pytest.raises(registry.UnknownKind, match=f"unknown {role} kind"):
        registry.get(role, kind)


class ExactSpec(schema.SensorSpec):
    """Range and bearing without noise, within ``reach`` m."""

    kind: Literal["test-exact"] = "test-exact"
    reach: float = 50.0


class ExactSensor(Sensor):
    name = "test-exact"

    def __init__(self, reach: float):
        self.reach = reach

    def sense(self, scene: Scene):
        # the noise is drawn from the objects' streams and scaled by zero: the draws are the sensor's own choice
        return range_bearing.sense(scene.objects, scene.uavs, scene.uavs, 0.0, 0.0, scene.normal(), self.reach,
                                   taken=scene.taken)


class HeardMean:
    """The estimator's own metric: how many detections each UAV fused per step, on average."""

    def __init__(self, rec):
        self.total, self.steps = 0.0, 0

    def add(self, chunk, keep, err):
        self.total += float(chunk.probes["heard"].mean(axis=1).sum())
        self.steps += len(chunk.t)

    def result(self):
        return {"mean": self.total / max(self.steps, 1)}


def draw_heard(rec, path):
    """The estimator's own figure: detections fused per step."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    heard = np.concatenate([c.probes["heard"] for c in rec.chunks()])
    ax.plot(rec.t, heard.mean(axis=1))
    fig.savefig(path)
    plt.close(fig)
    return path


@pytest.fixture
def outside_kinds():
    kinds = [registry.register("sensor", ExactSpec, lambda s, scenario: ExactSensor(s.reach)),
             registry.register("estimator", CentroidSpec,
                               lambda s, ctx: CentroidEstimator(ctx.n_uavs, ctx.label_of("targets", s.target - 1)),
                               metrics=[registry.Metric("heard", HeardMean, headline=("heard_mean",))],
                               figures=[registry.Figure("heard.png", draw_heard)]),
             registry.register("controller", HoldSpec, lambda s, ctx: HoldController(s.gain))]
    yield
    for kind in kinds:
        registry.unregister(kind.role, kind.name)


def _scenario_file(tmp_path):
    data = {"name": "outside", "duration": 4.0, "target": {"profile": "hover", "start": [1.0, 2.0], "wind_std": 0.0},
            "network": {"topology": "full"}, "sensor": {"kind": "test-exact", "reach": 40.0},
            "estimator": {"kind": "test-centroid"}, "controller": {"kind": "test-hold", "gain": 3.0}}
    path = tmp_path / "outside.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.slow
def test_outside_kinds_run_through_run_metrics_figures_sweep_and_summarize(outside_kinds, tmp_path):
    scenario = _scenario_file(tmp_path)
    cli = CliRunner()
    res = cli.invoke(main, ["run", str(scenario), "--out", str(tmp_path / "run"), "--seed", "3"])
    assert res.exit_code == 0, res.output
    metrics = json.loads((tmp_path / "run" / "metrics.json").read_text())
    assert metrics["heard"]["mean"] == pytest.approx(3.0)  # full topology, exact sensor: every UAV hears all three
    assert (tmp_path / "run" / "heard.png").stat().st_size > 0
    rec = swarmtrack.load_run(tmp_path / "run")
    err = np.abs(rec.estimate[-1, :, :2] - rec.target[-1, :2])
    assert err.max() < 1e-9  # noiseless fixes of a hovering target
    assert np.linalg.norm(rec.uav[-1, :, 2:4], axis=1).max() < 0.05  # the hold controller, not flocking, flew them
    assert swarmtrack.summarize(rec)["heard"] == metrics["heard"]

    res = cli.invoke(main, ["sweep", str(scenario), "--grid", "controller.gain=1,3", "--runs", "2", "--workers", "1",
                            "--out", str(tmp_path / "sweep")])
    assert res.exit_code == 0, res.output
    from swarmtrack.analysis.sweep import load_results

    rows = load_results(tmp_path / "sweep")
    assert len(rows) == 4 and (rows["status"] == "ok").all()
    res = cli.invoke(main, ["summarize", str(tmp_path / "sweep")])
    assert res.exit_code == 0, res.output
    assert "heard_mean" in res.output and "3 ± 0" in res.output  # the toy metric tabulated per setting


def test_without_the_registration_the_same_file_is_refused_naming_the_kind(tmp_path):
    res = CliRunner().invoke(main, ["validate", str(_scenario_file(tmp_path))])
    assert res.exit_code == 2
    assert "sensor: unknown kind 'test-exact'" in res.output


class BlindSpec(schema.SensorSpec):
    """A sensor that, its settings say, sees the decoys only."""

    kind: Literal["test-blind"] = "test-blind"
    sensed = ("decoys",)


class MisdeclaredSpec(schema.SensorSpec):
    """A sensor whose settings keep the default groups while its truth side senses the targets only."""

    kind: Literal["test-misdeclared"] = "test-misdeclared"


class TargetsOnlySensor(ExactSensor):
    sensed = ("targets",)


@pytest.fixture
def odd_sensors():
    kinds = [registry.register("sensor", BlindSpec, lambda s, scenario: ExactSensor(50.0)),
             registry.register("sensor", MisdeclaredSpec, lambda s, scenario: TargetsOnlySensor(50.0))]
    yield
    for kind in kinds:
        registry.unregister(kind.role, kind.name)


def _with(sensor: str) -> dict:
    """l24-cv with ``sensor`` and the centroid estimator, which reads any sensor's detections of its target."""
    data = load_raw("l24-cv")
    data["sensor"], data["estimator"] = {"kind": sensor}, {"kind": "test-centroid"}
    return data


def test_an_estimator_following_a_target_its_sensor_does_not_see_is_refused_at_validation(registered, odd_sensors):
    # the builders take the target's label from what the sensor's settings declare it sees
    data = _with("test-blind")
    with pytest.raises(ScenarioError, match="follows estimator.target, which sensor.kind test-blind does not see"):
        validate(data)


def test_a_sensor_whose_truth_side_senses_other_groups_than_its_settings_declare_is_refused_by_name(
        registered, odd_sensors):
    # the world labels what its sensor senses, the UAVs' builders what the settings declare: they must agree
    data = _with("test-misdeclared")
    with pytest.raises(TypeError, match=r"test-misdeclared: its truth side senses \('targets',\), its settings"):
        simulate(validate(data))
