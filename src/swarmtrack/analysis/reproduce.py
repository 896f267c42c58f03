"""``swarmtrack reproduce``: run a paper's experiments over several seeds, compare with the paper, check claims.

The papers themselves (published numbers, experiments, claims, figures) live in :mod:`swarmtrack.analysis.papers`;
this module only runs jobs, caches them, and writes the reports.

Run cache: each finished run is written at once (atomically) to ``<out>/runs/<scenario>-seed<k>-<key12>.json``,
where the key is a hash of the *resolved* scenario and the package version (:func:`run_key`), and reused on the
next call, so an interrupted reproduction loses no finished work while an edited scenario or a new version is
run again. An entry that is corrupt, from another cache format, version or key is run again with one warning
line, never reused. Runs are spread over processes.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from swarmtrack import outputs
from swarmtrack.analysis.papers import PAPERS, Claim
from swarmtrack.analysis.runs import batches, run_batch, run_key, run_one, worker_signals
from swarmtrack.analysis.sweep import close_client, dask_client
from swarmtrack.outputs import dump_json, package_version, version, write_together
from swarmtrack.scenarios import Scenario, load_scenario

__all__ = ["CACHE_FORMAT", "Claim", "cache_path", "figure_experiments", "package_version", "read_cached",
           "reproduce", "run_all", "run_key", "run_one"]

#: Version of the cache file layout; a file with another one is run again.
CACHE_FORMAT = 1

Job = tuple[str, int]  # (built-in scenario name, seed)


def cache_path(cache: Path, scenario: Scenario, key: str) -> Path:
    """``<cache>/<name>-seed<k>-<key12>.json``: the name for humans, the key for truth."""
    return cache / f"{scenario.name}-seed{scenario.seed}-{key[:12]}.json"


def read_cached(path: Path, key: str, version: str) -> tuple[dict | None, str]:
    """``(metrics, "")`` for a valid entry, else ``(None, "<stale|corrupt|foreign> (<reason>)")``."""
    try:
        entry = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        return None, f"corrupt ({type(exc).__name__}: {exc})"
    if not isinstance(entry, dict):
        return None, f"corrupt (a JSON {type(entry).__name__}, not an object)"
    if entry.get("format") != CACHE_FORMAT:
        return None, f"foreign (cache format {entry.get('format')!r}, expected {CACHE_FORMAT})"
    if entry.get("version") != version:
        return None, f"stale (written by swarmtrack {entry.get('version')}, this is {version})"
    if entry.get("key") != key:
        return None, f"foreign (key {str(entry.get('key'))[:12]} does not match {key[:12]})"
    if not isinstance(entry.get("metrics"), dict):
        return None, "corrupt (no metrics object)"
    return entry["metrics"], ""


def _superseded(cache: Path, scenario: Scenario, path: Path, version: str) -> tuple[Path, str]:
    """An older entry of the same scenario and seed (another key, or the unkeyed layout) and why it is not reused."""
    stem = f"{scenario.name}-seed{scenario.seed}"
    old = sorted(p for p in [*cache.glob(f"{stem}-*.json"), cache / f"{stem}.json"] if p.is_file() and p != path)
    if not old:
        return path, ""
    if old[-1].name == f"{stem}.json":
        return old[-1], "stale (written before runs were keyed by scenario and version)"
    try:
        was = json.loads(old[-1].read_text()).get("version")
    except (OSError, UnicodeDecodeError, ValueError, AttributeError):
        was = None
    why = f"written by swarmtrack {was}, this is {version}" if was and was != version else "the scenario changed"
    return old[-1], f"stale ({why})"


def warn_stderr(message: str) -> None:
    """The default warning sink: one line on stderr."""
    print(message, file=sys.stderr, flush=True)


def _run_indexed(item: tuple[list[int], list[Scenario]]) -> list[tuple[int, dict]]:
    """A batch of jobs (their indices and scenarios) to their ``(index, metrics)``."""
    return list(zip(item[0], run_batch(item[1]), strict=True))


def run_all(jobs: list[Job], cache: Path, workers: int | None, on_done: Callable[[], None] | None = None,
            warn: Callable[[str], None] = warn_stderr, overrides: Sequence[str] = (),
            cluster: str | None = None, resolve: Callable | None = None) -> dict[Job, dict]:
    """Metrics of every ``(scenario name, seed)`` job, from the cache where valid, else run (in parallel).

    Every job is resolved (:func:`load_scenario`, with ``overrides``) before anything runs, so a broken scenario
    fails early. Each finished run is cached at once; an interruption (Ctrl-C, SIGTERM) terminates the worker
    processes at once, so it loses only the runs in progress. ``cluster``: run on Dask instead (as
    :func:`swarmtrack.analysis.sweep.sweep`), the scheduler reached before any run.
    """
    resolve = resolve or (lambda name, extra: (name, list(extra)))  # a paper's variants: Paper.resolve
    resolved = {job: load_scenario(*resolve(job[0], overrides), seed=job[1]) for job in jobs}
    client = None
    if cluster is not None:  # reached before anything is written
        client = dask_client(cluster, workers)
    try:
        return _run_all(resolved, cache, workers, on_done, warn, client)
    finally:
        if client is not None:
            close_client(client)


def _run_all(resolved: dict, cache: Path, workers: int | None, on_done, warn, client) -> dict[Job, dict]:
    cache.mkdir(parents=True, exist_ok=True)
    version, written_by = package_version(), outputs.version()
    results: dict[Job, dict] = {}
    todo: list[tuple[Job, Scenario, str, Path]] = []
    for job, scenario in resolved.items():
        key = run_key(scenario, version)
        path = cache_path(cache, scenario, key)
        found, metrics = path, None
        if path.is_file():
            metrics, why = read_cached(path, key, version)
        else:
            found, why = _superseded(cache, scenario, path, version)
        if metrics is not None:
            results[job] = metrics
            if on_done:
                on_done()
            continue
        if why:
            warn(f"warning: cached run {found} is {' '.join(why.split())}; running it again")
        todo.append((job, scenario, key, path))

    def keep(job: Job, scenario: Scenario, key: str, path: Path, metrics: dict) -> None:
        results[job] = metrics
        entry = {"format": CACHE_FORMAT, "version": version, "written_by": written_by, "key": key,
                 "scenario": scenario.name, "seed": scenario.seed, "metrics": metrics}
        tmp = path.with_suffix(".tmp")
        tmp.write_text(outputs.dump_json(entry))
        tmp.replace(path)
        if on_done:
            on_done()

    n_workers = 1 if workers == 1 else (workers or os.cpu_count() or 1)
    tasks = [(ks, [todo[k][1] for k in ks]) for ks in batches([item[1] for item in todo], n_workers)]
    if client is not None:
        from distributed import as_completed

        for future in as_completed(client.map(_run_indexed, tasks, pure=False)):
            for k, metrics in future.result():
                keep(*todo[k], metrics)
    elif n_workers == 1 or len(tasks) <= 1:
        for task in tasks:
            for k, metrics in _run_indexed(task):
                keep(*todo[k], metrics)
    else:
        # a multiprocessing pool (not concurrent.futures): terminate() stops running workers at once, where an
        # executor lets them finish their runs (30-40 s after Ctrl-C) and throws the results away
        with multiprocessing.Pool(n_workers, worker_signals) as pool:
            for done in pool.imap_unordered(_run_indexed, tasks):
                for k, metrics in done:
                    keep(*todo[k], metrics)
    return results


def figure_experiments(paper: str, figure: str | None = None) -> tuple[str, ...]:
    """The experiments a reproduction of ``paper`` runs: all of them, or those of one of its figure groups
    (:attr:`Paper.figure_groups`). ValueError naming the choices for a figure the paper does not declare."""
    spec = PAPERS[paper]
    if figure is None:
        return spec.experiments
    if not spec.figure_groups:
        raise ValueError(f"--figure: {paper} draws no figures from its runs by group; run it without --figure")
    if figure not in spec.figure_groups:
        raise ValueError(f"--figure {figure}: {paper} has figures {', '.join(spec.figure_groups)}")
    return spec.figure_groups[figure]


def reproduce(paper: str, out: Path, runs: int = 10, workers: int | None = None, quiet: bool = False,
              figures: bool = True, overrides: Sequence[str] = (), cluster: str | None = None,
              figure: str | None = None) -> dict:
    """Run, compare, check claims; writes ``reproduction.json`` and ``reproduction.md`` into ``out``, together
    or not at all. ``overrides`` (``dotted.key=value``) apply to every experiment's scenario. ``figure``: only the
    experiments and figures of that figure group (:func:`figure_experiments`) and the claims on them, reported in
    ``reproduction-fig<figure>.json`` and ``.md``."""
    from rich.console import Console
    from rich.progress import Progress

    spec = PAPERS[paper]
    experiments = figure_experiments(paper, figure)
    jobs = [(name, seed) for name in experiments for seed in range(1, runs + 1)]
    console = Console(quiet=quiet)
    with Progress(console=console, transient=True, disable=quiet) as progress:
        task = progress.add_task(f"reproduce {paper}", total=len(jobs))
        results = run_all(jobs, out / "runs", workers, on_done=lambda: progress.advance(task), overrides=overrides,
                          cluster=cluster, resolve=spec.resolve)
    by_scenario = {name: [results[(name, s)] for s in range(1, runs + 1)] for name in experiments}
    diverged = {name: sum("diverged" in r for r in rs) for name, rs in by_scenario.items()}
    claims, table_md, numbers = spec.analyse(by_scenario)
    if spec.study is not None and figure is None:
        more, study_md, numbers["study"] = spec.study(by_scenario, overrides, runs)
        claims, table_md = [*claims, *more], table_md + study_md
    report = {"paper": paper, "runs": runs, "figure": figure, "overrides": list(overrides), "written_by": version(),
              "diverged": diverged, "numbers": numbers, "claims": [c.as_dict() for c in claims]}
    only = "" if figure is None else f", Fig. {figure}'s experiments only"
    lines = [f"# Reproduction of {paper.upper()} ({runs} seeds per experiment{only})", "", table_md, "", "## Claims",
             ""]
    lines += [f"- **{'holds' if c.holds else 'does NOT hold'}** `{c.id}`: {c.text}. Paper: {_fmt(c.paper)}; "
              f"project: {_fmt(c.project)}." for c in claims]
    if any(diverged.values()):
        lines += ["", f"Diverged runs (left out of the statistics): {diverged}"]
    if overrides:
        lines += ["", "Overrides: " + ", ".join(f"`{o}`" for o in overrides)]
    if figures:
        if spec.figure_groups:  # drawn from the runs
            drawn = spec.figures(out, overrides, by_scenario, figure)
            what = f"Figures (mean, \u00b11 std over {runs} seeds): "
        else:
            drawn, what = spec.figures(out, overrides), "Figures (seed 1): "
        if drawn:
            lines += ["", what + ", ".join(p.name for p in drawn)]
    stem = "reproduction" if figure is None else f"reproduction-fig{figure}"  # a part never replaces the whole
    write_together({out / f"{stem}.json": dump_json(report), out / f"{stem}.md": "\n".join(lines) + "\n"})
    console.print("\n".join(lines))
    return report


def _fmt(v) -> str:
    if isinstance(v, dict):
        return ", ".join(f"{k} {_fmt(x)}" for k, x in v.items())
    if isinstance(v, float):
        return f"{v:.3f}"
    return str(v)
