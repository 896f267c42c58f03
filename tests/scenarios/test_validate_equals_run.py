"""Validate = run (issue 35): what ``swarmtrack validate`` accepts, ``swarmtrack run`` runs (2 s, no traceback); what
validate refuses, run refuses with the same message (exit 2, nothing written).

Every registered kind of every role is swapped into one representative of every built-in scenario family, with
``--set duration=2``: the sensor, estimator and controller sections replaced by a kind with its defaults
(``--set 'sensor={kind: camera}'``), the swarm's vehicle and the targets' and decoys' vehicles (``--set
swarm.vehicle=fixed_wing``). A family is the built-in scenarios that use the same kinds (sensor, estimator, controller,
swarm and target vehicles, decoys or none); its representative is the first by name (:func:`families`, computed from
the built-in files: 9 families today, ib21-baseline, ib21-compute-1, l23-flocking-integral, l24-3d-ct, l24-3d-imm,
l24-imm, w20-evasive, w20-mpc-collision, w20-mpc-indoor).

Fast tier: every single swap is validated with the loader's functions (what both commands call first); each distinct
refusal goes through both commands; every accepted swap is built (the builders construct every component and raise on
an incompatibility), and stepped for two estimation steps (sense, fuse, command, advance) when its kinds are new
together (no built-in scenario runs them); and in each family one such swap goes through ``run`` for the whole 2 s.
Slow tier: the pairs of kinds that meet as well (sensor x estimator, estimator x controller, controller x swarm
vehicle, target vehicle x controller), every combination through both commands, and figures once per estimator and
controller.
"""

from __future__ import annotations

import copy
from functools import cache

import pytest
from click.testing import CliRunner

from swarmtrack import registry
from swarmtrack.cli import main
from swarmtrack.scenarios.loader import ScenarioError, apply_override, builtin_names, load_raw, validate

DURATION = "duration=2"
#: Combinations that validate accepts and run still fails on, outside the validation's reach: each with what it fails
#: with. A fixed one fails the slow test until it is removed here.
KNOWN_DEFECTS: dict = {}


def _kind(role: str, name: str) -> str:
    return f"{role}={{kind: {name}}}"


def _vehicles(use: str) -> list[str]:
    return [n for n, v in registry.kinds(registry.VEHICLE).items() if getattr(v, use)]


def singles() -> list[tuple[str, ...]]:
    """Every registered kind of every role, one at a time."""
    out = [(_kind(role, name),) for role in registry.ROLES for name in registry.kinds(role)]
    out += [(f"swarm.vehicle={v}",) for v in _vehicles("uav")]
    return out + [(f"{group}.vehicle={v}",) for group in ("targets", "decoys") for v in _vehicles("group")]


def pairs() -> list[tuple[str, str]]:
    """The kinds that meet, two at a time: sensor x estimator, estimator x controller, controller x swarm vehicle,
    target vehicle x controller."""
    kinds = {role: list(registry.kinds(role)) for role in registry.ROLES}
    out = [(_kind("sensor", s), _kind("estimator", e)) for s in kinds["sensor"] for e in kinds["estimator"]]
    out += [(_kind("estimator", e), _kind("controller", c)) for e in kinds["estimator"] for c in kinds["controller"]]
    out += [(_kind("controller", c), f"swarm.vehicle={v}") for c in kinds["controller"] for v in _vehicles("uav")]
    return out + [(f"targets.vehicle={v}", _kind("controller", c)) for v in _vehicles("group")
                  for c in kinds["controller"]]


def signature(scn) -> tuple:
    """The kinds a scenario uses: what makes a family."""
    return (scn.sensor.kind, scn.estimator.kind, scn.controller.kind, scn.swarm.vehicle, scn.targets.vehicle,
            scn.decoys.size() > 0)


@cache
def _raw(name: str) -> dict:
    return load_raw(name)


@cache
def families() -> dict[str, tuple]:
    """The first built-in scenario (by name) of each family → the family's kinds (:func:`signature`)."""
    first: dict[tuple, str] = {}
    for name in builtin_names():
        first.setdefault(signature(validate(copy.deepcopy(_raw(name)), name)), name)
    return {name: sig for sig, name in first.items()}


def overrides(family: str, swap: tuple[str, ...]) -> list[str]:
    """The ``--set`` values of a swap in a family (``target.vehicle`` where its file uses the one-target shorthand)."""
    target = "target." if "target" in _raw(family) else "targets."
    return [o.replace("targets.", target, 1) if o.startswith("targets.") else o for o in swap] + [DURATION]


def outcome(family: str, swap: tuple[str, ...]):
    """What validation says of a swap: the scenario, or the refusal's message. The loader's own functions, as
    ``validate`` and ``run`` call them (``load_scenario``), on the family's file parsed once."""
    data = copy.deepcopy(_raw(family))
    try:
        for o in overrides(family, swap):
            apply_override(data, o)
        return validate(data, family)
    except ScenarioError as exc:
        return str(exc)


def _set(family: str, swap: tuple[str, ...]) -> list[str]:
    return [x for o in overrides(family, swap) for x in ("--set", o)]


def both_refuse(family: str, swap: tuple[str, ...], out) -> str | None:
    """None if ``validate`` and ``run`` both refuse the swap with the same one message, exit 2 and nothing written;
    else what went wrong."""
    runner = CliRunner()
    v = runner.invoke(main, ["validate", family, *_set(family, swap)])
    r = runner.invoke(main, ["run", family, *_set(family, swap), "--out", str(out)])
    if v.exit_code != 2 or r.exit_code != 2 or r.output != v.output or "Traceback" in r.output or out.exists():
        return f"validate exit {v.exit_code}: {v.output!r}; run exit {r.exit_code}: {r.output!r}"
    return None


def runs(family: str, swap: tuple[str, ...], out, plots: bool = False) -> str | None:
    """None if ``validate`` accepts the swap (exit 0) and ``run`` runs it (exit 0, no traceback); else what happened
    (``run``'s exception's type first)."""
    runner = CliRunner()
    v = runner.invoke(main, ["validate", family, *_set(family, swap)])
    r = runner.invoke(main, ["run", family, *_set(family, swap), "--out", str(out), *([] if plots else ["--no-plots"])])
    if v.exit_code == 0 and r.exit_code == 0 and "Traceback" not in r.output:
        return None
    return f"{type(r.exception).__name__}: {r.exception}; validate exit {v.exit_code}, run exit {r.exit_code}"


def test_validate_and_run_agree_on_every_kind_swapped_into_every_family(tmp_path):
    from swarmtrack.sim.build import build
    from swarmtrack.sim.engine import simulate

    # every capability's scenarios are among the families (planar and 3-D, W20 Ch. 4 and 5, IB21)
    assert {"l24-imm", "l24-3d-ct", "w20-evasive", "w20-mpc-indoor", "ib21-baseline"} <= set(families())
    accepted, refused, problems = [], {}, []
    for family in families():
        for swap in singles():
            result = outcome(family, swap)
            if isinstance(result, str):
                refused.setdefault(result.split("\n", 1)[-1], (family, swap))
            else:
                accepted.append((family, swap, result))
    assert len(accepted) >= 60 and len(refused) >= 10  # 108 accepted, 90 refused with 32 messages today
    for k, (family, swap) in enumerate(refused.values()):
        if (wrong := both_refuse(family, swap, tmp_path / f"refused{k}")) is not None:
            problems.append(f"{family} {swap}: {wrong}")
    steps = {}
    for family, swap, scn in accepted:
        novel = signature(scn) not in families().values()  # kinds no built-in scenario runs together
        two_steps = 2 * round(scn.rates.physics / scn.rates.estimation) / scn.rates.physics
        try:  # stepped where the kinds are new together, built (every component) where only settings are
            simulate(scn.model_copy(update={"duration": two_steps})) if novel else build(scn)
        except Exception as exc:  # noqa: BLE001 - any exception is a disagreement
            problems.append(f"{family} {swap}: validate accepts, run fails: {type(exc).__name__}: {exc}")
        if novel:
            steps.setdefault(family, swap)
    assert len(steps) >= 8
    for family, swap in steps.items():
        if (wrong := runs(family, swap, tmp_path / f"{family}-run")) is not None:
            problems.append(f"{family} {swap} (2 s): {wrong}")
    assert not problems, "validate and run disagree:\n" + "\n".join(problems)


SHARDS = 4


def _combinations() -> list[tuple[str, tuple[str, ...]]]:
    return [(family, swap) for family in families() for swap in (*singles(), *pairs())]


@pytest.mark.slow
@pytest.mark.parametrize("shard", range(SHARDS))
def test_validate_and_run_agree_on_every_kind_and_pair_through_both_commands(shard, tmp_path):
    """Every combination (singles and pairs in every family, a quarter per shard) through both commands: refused by
    both with the same message, or accepted by validate and run for 2 s (run --no-plots)."""
    problems, known = [], []
    for k, (family, swap) in enumerate(_combinations()[shard::SHARDS]):
        out = tmp_path / f"c{k}"
        if isinstance(outcome(family, swap), str):
            wrong = both_refuse(family, swap, out)
        else:
            wrong = runs(family, swap, out)
        expected = KNOWN_DEFECTS.get((family, swap))
        if expected is not None:
            known.append((family, swap))
            if wrong is None or not wrong.startswith(expected):
                problems.append(f"{family} {swap}: KNOWN_DEFECTS says it fails with {expected}, now: {wrong} "
                                "(fixed? remove it from KNOWN_DEFECTS)")
        elif wrong is not None:
            problems.append(f"{family} {swap}: {wrong}")
    assert not problems, "validate and run disagree:\n" + "\n".join(problems)


@pytest.mark.slow
@pytest.mark.parametrize("shard", range(2))
def test_accepted_runs_draw_their_figures_once_per_estimator_and_controller(shard, tmp_path):
    """A run's figures come from its estimator's and controller's kinds: one accepted combination of each estimator
    and controller pair runs with its figures (kinds that register the same figures and record the same probes, as
    issue 40's three multi-target trackers do, are one estimator here)."""
    first: dict[tuple, tuple] = {}
    for family, swap in _combinations():
        if (family, swap) in KNOWN_DEFECTS:
            continue
        scn = outcome(family, swap)
        if not isinstance(scn, str):
            drawn = registry.get("estimator", scn.estimator.kind).figures
            first.setdefault((drawn if isinstance(drawn, str) else scn.estimator.kind, scn.controller.kind),
                             (family, swap))
    assert len(first) >= 8
    problems = [f"{family} {swap}: {wrong}" for k, (family, swap) in enumerate(sorted(first.values())[shard::2])
                if (wrong := runs(family, swap, tmp_path / f"p{k}", plots=True)) is not None]
    assert not problems, "validate accepts, run with figures fails:\n" + "\n".join(problems)
