"""Many targets in clutter (issue 40): the LMB swarm's tracking quality and a UAV's tracker time per step on the
bouncing-box benchmark (``mtt-box-easy``, ``mtt-box-hard``: 10 targets in a 200 m box, 4 hovering UAVs with
position sensors), each goal with MET / NOT MET, on one core.

1. GOSPA (``metrics.json`` section ``gospa``, mean over the judged steps) of the fused swarm on both boxes over seeds
   1..S, mean ± std over seeds, beside the centralised LMB filter on the same detections (``estimator.share=centre``:
   same seed, same world, same detections). Goals (:mod:`swarmtrack.analysis.papers.mtt`): easy ≤ ``GOAL["easy"]``,
   hard ≤ ``GOAL["hard"]``, the fused swarm within ``WITHIN_CENTRALISED`` of the centralised filter (relative, on
   the means), and no divergence (no run raised, no ``tracks_not_finite`` warning, fused and centralised runs).
2. A UAV's estimation time per step on ``mtt-box-hard`` (seed 1, this process, compiled kernels: the study's
   ``timed``, which times the estimator's share, fuse, publish and combine and divides by UAVs and steps); goal ≤
   ``MS_PER_UAV_STEP`` ms. Beside it, measured in the same run: the numpy reference path (``kernels=numpy``) and
   Stone Soup's GM-PHD over every sensor and JPDA on one, on the same detections (the study's ``references``; their
   ms are the whole tracker's per step; skipped with a note without Stone Soup). Each time is the best of 3
   repetitions (the GOSPA runs before it have warmed numba's cache). With them, the fused swarm's bytes per UAV per
   step (``tracking.bytes_per_uav_step``, mean over the seeds of part 1).
3. Issue 40's anchors (``ANCHORS``: their own scenes of the same benchmark, not these detections) with their source,
   beside this run's comparable figures.

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/bench_mtt.py [--seeds 10] [--json] [--quick]`` (about 1.5 min on 2
cores; ``--quick``: seeds 1-2, about 1.2 min, most of it the 3 repetitions of Stone Soup's trackers). ``--json``
prints one JSON object instead of the text: every figure, the goals, their MET flags and the load average (non-finite
numbers as null). Progress goes to stderr. The load average is printed at the start and at the end: other work
slows every time.
"""

from __future__ import annotations

import os

# One core: numba serial kernels, no threaded BLAS (for swarmtrack and Stone Soup alike). Other settings are kept.
os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import importlib.util  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import swarmtrack  # noqa: E402
from swarmtrack.analysis.metrics import summary  # noqa: E402
from swarmtrack.analysis.papers.mtt import ANCHORS, GOAL, MS_PER_UAV_STEP, WITHIN_CENTRALISED  # noqa: E402
from swarmtrack.analysis.statistics import stats  # noqa: E402
from swarmtrack.capabilities.multi_target.study import references, timed  # noqa: E402
from swarmtrack.scenarios import load_scenario  # noqa: E402

CASES = ("easy", "hard")
SEEDS = 10
QUICK_SEEDS = 2
REPEATS = 3  # each time: the best of 3
CENTRE = ("estimator.share=centre",)
TIMED = "mtt-box-hard"
ANCHORS_SOURCE = ("issue 40's table (swarmtrack.analysis.papers.mtt.ANCHORS): its own scenes of the same benchmark "
                  "(not these detections), 3 seeds, GOSPA c = 10 m, p = 1, α = 2 over steps 20-99, one core on a "
                  "busy machine; the LMB rows from multisensor-lmb-filters-rs (Python binding), the others from "
                  "Stone Soup 1.9.1; ms per step are the whole tracker's")


def _loadavg() -> list[float]:
    return [float(v) for v in Path("/proc/loadavg").read_text().split()[:3]]


def _verdict(met: bool) -> str:
    return "MET" if met else "NOT MET"


def _json_safe(value):
    """``value`` with every non-finite float as None (strict JSON)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_json_safe(v) for v in value]
    return value


def one_run(name: str, overrides: tuple[str, ...], seed: int) -> dict:
    """One simulated run: its GOSPA, bytes per UAV per step and whether it diverged (raised, or reported a track that
    is not finite)."""
    try:
        s = summary(swarmtrack.simulate(swarmtrack.load_scenario(name, list(overrides), seed=seed)))
    except Exception as exc:  # a run that raised is a divergence, counted, not fatal
        return {"seed": seed, "raised": f"{type(exc).__name__}: {exc}", "not_finite": False, "gospa": math.nan,
                "bytes_per_uav_step": math.nan}
    return {"seed": seed, "raised": None,
            "not_finite": any(w.get("kind") == "tracks_not_finite" for w in s["warnings"]),
            "gospa": float(s["gospa"]["gospa"]), "bytes_per_uav_step": float(s["tracking"]["bytes_per_uav_step"])}


def _mean_std(runs: list[dict], key: str) -> tuple[float, float]:
    values = [r[key] for r in runs if r["raised"] is None]
    return stats(values) if values else (math.nan, math.nan)


def gospa_part(seeds: int, say) -> dict:
    """Part 1: the fused swarm and the centralised filter on both boxes over seeds 1..``seeds``."""
    out: dict = {}
    for case in CASES:
        name = f"mtt-box-{case}"
        fused = [one_run(name, (), seed) for seed in range(1, seeds + 1)]
        centre = [one_run(name, CENTRE, seed) for seed in range(1, seeds + 1)]
        f, c = _mean_std(fused, "gospa"), _mean_std(centre, "gospa")
        gap = f[0] / c[0] - 1.0
        out[case] = {"fused": {"mean": f[0], "std": f[1], "per_seed": [r["gospa"] for r in fused]},
                     "centralised": {"mean": c[0], "std": c[1], "per_seed": [r["gospa"] for r in centre]},
                     "gap_to_centralised": gap,
                     "bytes_per_uav_step": _mean_std(fused, "bytes_per_uav_step")[0],
                     "diverged": [{"run": f"{label} seed {r['seed']}", "raised": r["raised"],
                                   "tracks_not_finite": r["not_finite"]}
                                  for label, runs in ((name, fused), (f"{name}-centre", centre)) for r in runs
                                  if r["raised"] is not None or r["not_finite"]]}
        say(f"  {name}: fused swarm {f[0]:.2f} ± {f[1]:.2f}, centralised LMB {c[0]:.2f} ± {c[1]:.2f} "
            f"(fused {gap:+.1%}); bytes per UAV per step {out[case]['bytes_per_uav_step']:.0f}")
    return out


def _best_timed(overrides: tuple[str, ...]):
    """The best of :data:`REPEATS` timed runs of the hard box, seed 1: (the first run's recording and scenario, the
    best seconds per UAV per step, every repetition's)."""
    first, times = None, []
    for _ in range(REPEATS):
        scenario = load_scenario(TIMED, list(overrides), seed=1)
        rec, seconds = timed(scenario)
        first = first or (rec, scenario)
        times.append(seconds)
    return first, min(times), times


def time_part(say) -> dict:
    """Part 2: a UAV's time per step (compiled and numpy) and Stone Soup's trackers on the same detections."""
    (rec, scenario), best, reps = _best_timed(())
    _, best_numpy, reps_numpy = _best_timed(("kernels=numpy",))
    out: dict = {"ms_per_uav_step": 1e3 * best, "ms_per_uav_step_repetitions": [1e3 * s for s in reps],
                 "ms_per_uav_step_numpy": 1e3 * best_numpy,
                 "ms_per_uav_step_numpy_repetitions": [1e3 * s for s in reps_numpy],
                 "speedup_over_numpy": best_numpy / best, "stonesoup": None, "stonesoup_note": None}
    say(f"  compiled {1e3 * best:.2f} ms, numpy reference {1e3 * best_numpy:.2f} ms "
        f"({best_numpy / best:.1f}x)")
    if importlib.util.find_spec("stonesoup") is None:
        out["stonesoup_note"] = "Stone Soup is not installed (the extra 'stonesoup'): no live references"
        return out
    got: dict[str, dict] = {}
    for _ in range(REPEATS):
        for ref in references(rec, scenario):
            entry = got.setdefault(ref.name, {"gospa": ref.gospa, "ms_per_step_repetitions": []})
            entry["ms_per_step_repetitions"].append(1e3 * ref.seconds_per_step)
    for entry in got.values():
        entry["ms_per_step"] = min(entry["ms_per_step_repetitions"])
    out["stonesoup"] = got
    say("  " + "; ".join(f"{k} {v['ms_per_step']:.1f} ms" for k, v in got.items()))
    return out


def _goals(gospa: dict, speed: dict) -> dict:
    """Every goal's MET flag."""
    diverged = [d for case in CASES for d in gospa[case]["diverged"]]
    met = {f"{case}_gospa": bool(gospa[case]["fused"]["mean"] <= GOAL[case]) for case in CASES}
    met |= {f"{case}_within_centralised": bool(gospa[case]["gap_to_centralised"] <= WITHIN_CENTRALISED)
            for case in CASES}
    met["no_divergence"] = not diverged
    met["ms_per_uav_step"] = bool(speed["ms_per_uav_step"] <= MS_PER_UAV_STEP)
    return met


def _anchor_rows(gospa: dict, speed: dict) -> list[tuple[str, str, str, str, str, str]]:
    """The anchors, then this run's comparable figures (fused and centralised means; seed 1's references)."""
    rows = [(name, "issue 40", f"{a:.2f}", f"{b:g}", f"{c:.2f}", f"{d:g}") for name, (a, b, c, d) in ANCHORS.items()]
    e, h = gospa["easy"], gospa["hard"]
    rows.append(("fused swarm (each UAV's LMB, tracks fused)", "this run", f"{e['fused']['mean']:.2f}", "-",
                 f"{h['fused']['mean']:.2f}", f"{speed['ms_per_uav_step']:.2f} per UAV"))
    rows.append(("centralised LMB, all 4 sensors", "this run", f"{e['centralised']['mean']:.2f}", "-",
                 f"{h['centralised']['mean']:.2f}", "-"))
    for name, ref in (speed["stonesoup"] or {}).items():
        rows.append((name, "this run, seed 1", "-", "-", f"{ref['gospa']:.2f}", f"{ref['ms_per_step']:.1f}"))
    return rows


def report(out: dict) -> None:
    """The text report of :func:`main`'s figures."""
    g, s, met = out["gospa"], out["time"], out["met"]
    print(f"\n1. GOSPA (mean ± std over seeds 1-{out['seeds']}; the centralised LMB on the same detections):")
    for case in CASES:
        c = g[case]
        print(f"  mtt-box-{case}: fused swarm {c['fused']['mean']:.2f} ± {c['fused']['std']:.2f}, centralised "
              f"{c['centralised']['mean']:.2f} ± {c['centralised']['std']:.2f}; goal ≤ {GOAL[case]:g}: "
              f"{_verdict(met[f'{case}_gospa'])}; fused {c['gap_to_centralised']:+.1%} from the centralised, goal "
              f"within {WITHIN_CENTRALISED:.0%}: {_verdict(met[f'{case}_within_centralised'])}")
    diverged = [d for case in CASES for d in g[case]["diverged"]]
    print(f"  no divergence ({4 * out['seeds']} runs: none raised, every reported track finite): "
          f"{_verdict(met['no_divergence'])}" + "".join(f"\n    {d}" for d in diverged))
    print(f"\n2. A UAV's estimation time per step, {TIMED} seed 1, one process (best of {REPEATS}):")
    print(f"  compiled kernels {s['ms_per_uav_step']:.2f} ms; goal ≤ {MS_PER_UAV_STEP:g} ms: "
          f"{_verdict(met['ms_per_uav_step'])}")
    print(f"  beside it, this run: numpy reference (kernels=numpy) {s['ms_per_uav_step_numpy']:.2f} ms "
          f"({s['speedup_over_numpy']:.1f}x slower)")
    if s["stonesoup"] is None:
        print(f"  {s['stonesoup_note']}")
    for name, ref in (s["stonesoup"] or {}).items():
        print(f"  {name} on the same detections: {ref['ms_per_step']:.1f} ms per step (the whole tracker), "
              f"GOSPA {ref['gospa']:.2f}")
    print(f"  bytes per UAV per step (fused swarm, mean over seeds): easy {g['easy']['bytes_per_uav_step']:.0f}, "
          f"hard {g['hard']['bytes_per_uav_step']:.0f}")
    print("\n3. Issue 40's anchors beside this run:")
    print(f"  source: {ANCHORS_SOURCE}.")
    head = ("tracker", "figures", "easy GOSPA", "easy ms/step", "hard GOSPA", "hard ms/step")
    rows = [head, *_anchor_rows(g, s)]
    widths = [max(len(r[i]) for r in rows) for i in range(len(head))]
    for i, row in enumerate(rows):
        print("  " + "  ".join(f"{v:<{w}}" if j < 2 else f"{v:>{w}}" for j, (v, w) in enumerate(zip(row, widths,
                                                                                                   strict=True))))
        if i == 0:
            print("  " + "  ".join("-" * w for w in widths))
    print(f"\nload average {' '.join(f'{v:.2f}' for v in out['loadavg']['start'])} at the start, "
          f"{' '.join(f'{v:.2f}' for v in out['loadavg']['end'])} at the end; {out['runtime_s']:.0f} s")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=SEEDS, help=f"seeds 1..S of part 1 (default {SEEDS})")
    parser.add_argument("--json", action="store_true", help="print one JSON object with every figure instead")
    parser.add_argument("--quick", action="store_true", help=f"seeds 1-{QUICK_SEEDS} only (smoke test)")
    args = parser.parse_args(argv)
    seeds = QUICK_SEEDS if args.quick else args.seeds
    start, load = time.perf_counter(), _loadavg()

    def say(line: str) -> None:  # progress, on stderr (stdout: the report or the JSON object)
        print(line, file=sys.stderr, flush=True)

    say(f"Issue 40, many targets in clutter (one core, NUMBA_NUM_THREADS={os.environ['NUMBA_NUM_THREADS']}); "
        f"load average {' '.join(f'{v:.2f}' for v in load)}")
    say(f"GOSPA runs, seeds 1-{seeds}:")
    gospa = gospa_part(seeds, say)
    say(f"Timing {TIMED}, seed 1, best of {REPEATS}:")
    speed = time_part(say)
    out = {"seeds": seeds, "quick": args.quick, "repeats": REPEATS, "gospa": gospa, "time": speed,
           "goals": {"gospa": dict(GOAL), "within_centralised": WITHIN_CENTRALISED, "ms_per_uav_step": MS_PER_UAV_STEP,
                     "no_divergence": 0},
           "met": _goals(gospa, speed), "diverged_runs": sum(len(gospa[case]["diverged"]) for case in CASES),
           "anchors": {name: dict(zip(("easy_gospa", "easy_ms_per_step", "hard_gospa", "hard_ms_per_step"), v,
                                      strict=True)) for name, v in ANCHORS.items()},
           "anchors_source": ANCHORS_SOURCE,
           "loadavg": {"start": load, "end": _loadavg()}, "runtime_s": time.perf_counter() - start}
    if args.json:
        print(json.dumps(_json_safe(out), indent=2))
        return
    report(out)


if __name__ == "__main__":
    main()
