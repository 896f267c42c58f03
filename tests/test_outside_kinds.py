"""A sensor, an estimator and a controller registered from outside the package (this module), with a metric and a
figure of their own, run through ``swarmtrack run``, the metrics, the figures, ``sweep`` and ``summarize`` with no
edit anywhere else: one registration per kind is all a new capability needs."""

import json
from typing import Literal

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

import swarmtrack
from swarmtrack import registry
from swarmtrack.cli import main
from swarmtrack.sensors import range_bearing
from swarmtrack.sim.sensors import Scene, Sensor


class ExactSpec(swarmtrack.SensorSpec):
    """Range and bearing without noise, within ``reach`` m."""

    kind: Literal["outside-exact"] = "outside-exact"
    reach: float = 50.0


class ExactSensor(Sensor):
    name = "outside-exact"

    def __init__(self, reach: float):
        self.reach = reach

    def sense(self, scene: Scene):
        # the noise is drawn from the objects' streams and scaled by zero: the draws are the sensor's own choice
        return range_bearing.sense(scene.objects, scene.uavs, scene.uavs, 0.0, 0.0, scene.normal(), self.reach,
                                   taken=scene.taken)


class CentroidSpec(swarmtrack.EstimatorSpec):
    kind: Literal["outside-centroid"] = "outside-centroid"
    target: int = 1

    def followed_target(self) -> int:
        return self.target


class CentroidEstimator:
    """Each UAV's estimate: the mean of the positions its own and its neighbours' detections imply."""

    probes = (swarmtrack.Probe("estimate", (4,)), swarmtrack.Probe("covariance", (4, 4)),
              swarmtrack.Probe("heard", ()))

    def __init__(self, n: int, label: int):
        self.n, self.label = n, label
        self.x = np.zeros((n, 4))
        self.heard = np.zeros(n)

    def share(self, t, nav, own):
        z, pos, seen = own.of_label(self.label)
        implied = np.where(seen[:, None], range_bearing.to_position(z, pos), 0.0)
        return {"sum": implied, "count": seen.astype(float)}

    def fuse(self, t, own, inbox):
        total = inbox.payloads["sum"] + inbox.sum("sum")
        count = inbox.payloads["count"] + inbox.sum("count")
        self.x[:, :2] = total / np.maximum(count, 1)[:, None]
        self.heard = count

    def view(self):
        return swarmtrack.TargetView(self.x.copy())

    def sample(self):
        return {"estimate": self.x, "covariance": np.broadcast_to(np.eye(4), (self.n, 4, 4)), "heard": self.heard}


class BrakeSpec(swarmtrack.ControllerSpec):
    kind: Literal["outside-brake"] = "outside-brake"
    gain: float = 2.0


class Brake:
    probes = ()

    def __init__(self, gain: float):
        self.gain = gain

    def broadcast(self, t, nav):
        return {}

    def command(self, t, nav, view, inbox, dt):
        return -self.gain * nav[:, 2:4]

    def sample(self):
        return {}


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
             registry.register("controller", BrakeSpec, lambda s, ctx: Brake(s.gain))]
    yield
    for kind in kinds:
        registry.unregister(kind.role, kind.name)


def _scenario_file(tmp_path):
    data = {"name": "outside", "duration": 4.0, "target": {"profile": "hover", "start": [1.0, 2.0], "wind_std": 0.0},
            "network": {"topology": "full"}, "sensor": {"kind": "outside-exact", "reach": 40.0},
            "estimator": {"kind": "outside-centroid"}, "controller": {"kind": "outside-brake", "gain": 3.0}}
    path = tmp_path / "outside.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


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
    assert np.linalg.norm(rec.uav[-1, :, 2:4], axis=1).max() < 0.05  # the brake, not flocking, flew the UAVs
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
    assert "sensor: unknown kind 'outside-exact'" in res.output
