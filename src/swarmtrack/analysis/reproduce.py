"""``swarmtrack reproduce``: run a paper's experiments over several seeds, compare with the paper, check claims.

Each finished run is written at once to ``<out>/runs/<scenario>-seed<k>.json`` and reused on the next call,
so an interrupted reproduction loses no finished work. Runs are spread over processes.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from swarmtrack.analysis.metrics import COMPONENTS, summary
from swarmtrack.analysis.papers import L23_SPREAD, L24_RMSE
from swarmtrack.analysis.report import markdown_table
from swarmtrack.scenarios.loader import load_scenario

EXPERIMENTS = {
    "l24": ("l24-cv", "l24-ct", "l24-fs"),
    "l23": ("l23-no-fusion", "l23-full-fusion", "l23-flocking-standard", "l23-flocking-integral",
            "l23-flocking-tailored"),
}


def run_one(scenario: str, seed: int) -> dict:
    """One seeded run's metrics, or the divergence message."""
    from swarmtrack.estimation.information import FilterDivergence
    from swarmtrack.sim.engine import simulate

    try:
        return summary(simulate(load_scenario(scenario, seed=seed)))
    except FilterDivergence as exc:
        return {"diverged": str(exc)}


def run_all(jobs: list[tuple[str, int]], cache: Path, workers: int | None,
            on_done: Callable[[], None] | None = None) -> dict[tuple[str, int], dict]:
    cache.mkdir(parents=True, exist_ok=True)
    results, todo = {}, []
    for scenario, seed in jobs:
        path = cache / f"{scenario}-seed{seed}.json"
        if path.is_file():
            results[(scenario, seed)] = json.loads(path.read_text())
            if on_done:
                on_done()
        else:
            todo.append((scenario, seed))

    def keep(job, metrics):
        results[job] = metrics
        path = cache / f"{job[0]}-seed{job[1]}.json"
        tmp = path.with_suffix(".tmp")
        tmp.write_text(json.dumps(metrics))
        tmp.replace(path)
        if on_done:
            on_done()

    if workers == 1 or len(todo) <= 1:
        for job in todo:
            keep(job, run_one(*job))
    else:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            futures = {pool.submit(run_one, *job): job for job in todo}
            for fut in as_completed(futures):
                keep(futures[fut], fut.result())
    return results


@dataclass
class Claim:
    id: str
    text: str
    paper: object
    project: object
    holds: bool

    def as_dict(self) -> dict:
        return {"id": self.id, "text": self.text, "paper": self.paper, "project": self.project,
                "holds": bool(self.holds)}


def _stats(values: list[float]) -> tuple[float, float]:
    a = np.asarray(values, dtype=float)
    return float(a.mean()), float(a.std())


def _ok(runs: list[dict]) -> list[dict]:
    return [r for r in runs if "diverged" not in r]


def analyse_l24(by_scenario: dict[str, list[dict]]) -> tuple[list[Claim], str, dict]:
    models = ("cv", "ct", "fs")
    table: dict = {}
    for m in models:
        runs = _ok(by_scenario[f"l24-{m}"])
        table[m] = {ph: {c: _stats([r["rmse"][ph][c] for r in runs]) for c in COMPONENTS}
                    for ph in L24_RMSE[m]}
    mean = {m: {ph: {c: table[m][ph][c][0] for c in COMPONENTS} for ph in table[m]} for m in models}

    P = {m: {ph: dict(zip(COMPONENTS, row, strict=True)) for ph, row in L24_RMSE[m].items()} for m in models}

    def vel(src, m, ph):
        return (src[m][ph]["vx"] + src[m][ph]["vy"]) / 2

    def pos(src, m, ph):
        return (src[m][ph]["x"] + src[m][ph]["y"]) / 2

    claims = []
    lin = {m: vel(mean, m, "linear") for m in models}
    claims.append(Claim("l24-cv-best-linear-velocity", "CV has the lowest linear-phase velocity RMSE",
                        {m: vel(P, m, "linear") for m in models}, lin, min(lin, key=lin.get) == "cv"))
    ratio = vel(mean, "ct", "circular") / vel(mean, "cv", "circular")
    claims.append(Claim("l24-ct-circular-velocity", "CT's circular-phase velocity RMSE is at most half of CV's",
                        vel(P, "ct", "circular") / vel(P, "cv", "circular"), ratio, ratio <= 0.5))
    sin_y = {m: mean[m]["sinusoidal"]["y"] for m in models}
    claims.append(Claim("l24-fs-best-sinusoidal-y", "FS has the lowest sinusoidal-phase y RMSE",
                        {m: P[m]["sinusoidal"]["y"] for m in models}, sin_y, min(sin_y, key=sin_y.get) == "fs"))
    tot = {m: pos(mean, m, "total") for m in models}
    claims.append(Claim("l24-fs-best-total-position", "FS has the lowest total position RMSE",
                        {m: pos(P, m, "total") for m in models}, tot, min(tot, key=tot.get) == "fs"))
    factor = {m: tot[m] / pos(P, m, "total") for m in models}
    claims.append(Claim("l24-total-position-within-3x",
                        "Total position RMSEs are within a factor 3 of the paper's (project: ratio to the paper)",
                        {m: pos(P, m, "total") for m in models}, factor,
                        all(1 / 3 <= f <= 3 for f in factor.values())))

    rows = []
    for m in models:
        for ph in P[m]:
            cells = [f"{100 * P[m][ph][c]:.2f} / {100 * table[m][ph][c][0]:.2f} ± {100 * table[m][ph][c][1]:.2f}"
                     for c in COMPONENTS]
            rows.append([m.upper(), ph] + cells)
    md = markdown_table(["model", "phase"] + [f"{c} paper / project (cm, cm/s)" for c in COMPONENTS], rows)
    return claims, md, {"rmse": table}


def analyse_l23(by_scenario: dict[str, list[dict]]) -> tuple[list[Claim], str, dict]:
    spread = {k: {c: _stats([r["spread"][c] for r in _ok(by_scenario[f"l23-{k}"])]) for c in COMPONENTS}
              for k in ("no-fusion", "full-fusion")}
    ratio = {c: spread["full-fusion"][c][0] / spread["no-fusion"][c][0] for c in COMPONENTS}
    paper_ratio = {c: L23_SPREAD["full-fusion"][k] / L23_SPREAD["no-fusion"][k] for k, c in enumerate(COMPONENTS)}
    claims = [Claim("l23-fusion-halves-spread",
                    "With full fusion every component's estimate spread is at most 0.7x that without",
                    paper_ratio, ratio, all(r <= 0.7 for r in ratio.values()))]
    flock = {v: {k: _stats([r["inter_agent_distance"][k] for r in _ok(by_scenario[f"l23-flocking-{v}"])])
                 for k in ("offset", "overshoot")} for v in ("standard", "integral", "tailored")}
    chains = {v: sum(r["inter_agent_distance"]["open_pairs"] > 0 for r in _ok(by_scenario[f"l23-flocking-{v}"]))
              for v in flock}
    off = {v: flock[v]["offset"][0] for v in flock}
    claims.append(Claim("l23-standard-offset-removed",
                        "Standard flocking keeps a steady-state spacing offset (> 0.1 m) that the integral and "
                        "tailored variants remove (< 0.05 m)", "Fig. 1a-c (qualitative)", off,
                        off["standard"] > 0.1 and off["integral"] < 0.05 and off["tailored"] < 0.05))
    over = {v: flock[v]["overshoot"][0] for v in flock}
    claims.append(Claim("l23-tailored-smoother", "Tailored flocking overshoots less than integral action",
                        "Fig. 1b-c (qualitative)", over, over["tailored"] < over["integral"]))
    rows = [[k, *[f"{L23_SPREAD[k][i]:.4f} / {spread[k][c][0]:.4f} ± {spread[k][c][1]:.4f}"
                  for i, c in enumerate(COMPONENTS)]] for k in ("no-fusion", "full-fusion")]
    md = markdown_table(["fusion"] + [f"{c} paper / project (m, m/s)" for c in COMPONENTS], rows)
    md += "\n\n" + markdown_table(
        ["flocking", "spacing offset (m)", "overshoot (m)", "runs ending as an open chain"],
        [[v, f"{flock[v]['offset'][0]:.3f} ± {flock[v]['offset'][1]:.3f}",
          f"{flock[v]['overshoot'][0]:.3f} ± {flock[v]['overshoot'][1]:.3f}", str(chains[v])] for v in flock])
    return claims, md, {"spread": spread, "flocking": flock, "open_chains": chains}


ANALYSES = {"l24": analyse_l24, "l23": analyse_l23}


def paper_figures(paper: str, out: Path) -> list[Path]:
    """The papers' figures, from the first seed: L24 Figs. 2-7 per model, L23 Fig. 1."""
    from swarmtrack.analysis import plots
    from swarmtrack.sim.engine import simulate

    if paper == "l23":
        recs = {v: simulate(load_scenario(f"l23-flocking-{v}", seed=1)) for v in ("standard", "integral", "tailored")}
        return [plots.plot_flocking_comparison(recs, out / "l23_fig1_flocking.png")]
    paths = []
    for name in EXPERIMENTS[paper]:
        rec = simulate(load_scenario(name, seed=1))
        paths += [plots.plot_estimates(rec, out / f"{name}_estimates.png"),
                  plots.plot_trajectories(rec, out / f"{name}_trajectories.png"),
                  plots.plot_target_distances(rec, out / f"{name}_target_distances.png"),
                  plots.plot_inter_agent_distances(rec, out / f"{name}_inter_agent_distances.png")]
    return paths


def reproduce(paper: str, out: Path, runs: int = 10, workers: int | None = None, quiet: bool = False,
              figures: bool = True) -> dict:
    """Run, compare, check claims; writes ``reproduction.json`` and ``reproduction.md`` into ``out``."""
    from rich.console import Console
    from rich.progress import Progress

    for name in EXPERIMENTS[paper]:
        load_scenario(name)  # fail early on a broken built-in
    jobs = [(name, seed) for name in EXPERIMENTS[paper] for seed in range(1, runs + 1)]
    console = Console(quiet=quiet)
    with Progress(console=console, transient=True, disable=quiet) as progress:
        task = progress.add_task(f"reproduce {paper}", total=len(jobs))
        results = run_all(jobs, out / "runs", workers, on_done=lambda: progress.advance(task))
    by_scenario = {name: [results[(name, s)] for s in range(1, runs + 1)] for name in EXPERIMENTS[paper]}
    diverged = {name: sum("diverged" in r for r in rs) for name, rs in by_scenario.items()}
    claims, table_md, numbers = ANALYSES[paper](by_scenario)
    report = {"paper": paper, "runs": runs, "diverged": diverged, "numbers": numbers,
              "claims": [c.as_dict() for c in claims]}
    (out / "reproduction.json").write_text(json.dumps(report, indent=2))
    lines = [f"# Reproduction of {paper.upper()} ({runs} seeds per experiment)", "", table_md, "", "## Claims", ""]
    lines += [f"- **{'holds' if c.holds else 'does NOT hold'}** `{c.id}`: {c.text}. Paper: {_fmt(c.paper)}; "
              f"project: {_fmt(c.project)}." for c in claims]
    if any(diverged.values()):
        lines += ["", f"Diverged runs (left out of the statistics): {diverged}"]
    if figures:
        lines += ["", "Figures (seed 1): " + ", ".join(p.name for p in paper_figures(paper, out))]
    (out / "reproduction.md").write_text("\n".join(lines) + "\n")
    console.print("\n".join(lines))
    return report


def _fmt(v) -> str:
    if isinstance(v, dict):
        return ", ".join(f"{k} {_fmt(x)}" for k, x in v.items())
    if isinstance(v, float):
        return f"{v:.3f}"
    return str(v)
