"""``swarmtrack sweep``: one scenario over the cross product of grid values × seeds, in parallel, into a result store.

The store is a folder: ``sweep.json`` (what was asked, the store format) and ``results/``, one Parquet file per
finished run, written the moment the run finishes (to a temporary name, then renamed), so an interrupted sweep
loses only the runs in progress and ``resume`` runs only what is missing. A run's file is named by the key of what
determines its result (the resolved scenario and the version, :func:`~swarmtrack.analysis.runs.run_key`), so a
run is never stored twice. A row holds the grid values, the seed, the status (``ok``, ``diverged``, ``failed``), the
error, the wall time, the version, the run's scalar metrics and (an ``ok`` run) its time series as list columns
``series.t``, ``series.position_error`` … with their bin width ``series.bin_s``
(:func:`swarmtrack.analysis.metrics.series`); ``load_results(DIR)`` reads them as one table, and refuses a store of
another format or with rows that lack what this version needs.
"""

from __future__ import annotations

import itertools
import json
import multiprocessing
import os
import time
from collections.abc import Callable, Sequence
from pathlib import Path

from swarmtrack import outputs, registry
from swarmtrack.analysis.metrics import SERIES as SERIES_SECTION
from swarmtrack.analysis.metrics import summary
from swarmtrack.analysis.report import markdown_table
from swarmtrack.analysis.runs import batches, run_key, run_one, worker_signals
from swarmtrack.analysis.statistics import binned_band, mean_std_ci
from swarmtrack.outputs import package_version
from swarmtrack.scenarios import Scenario, load_scenario
from swarmtrack.scenarios.loader import ScenarioError
from swarmtrack.sim import batch

#: Layout of the store; a store of another format is refused. 2: rows carry the run's time series.
STORE_FORMAT = 2
#: Columns every stored row has, and those an ``ok`` row has besides (its time series' bins).
ROW_COLUMNS = ("seed", "status", "error", "wall_s", "version", "key")
OK_ROW_COLUMNS = ("series.bin_s", "series.t")
#: The time series every run has, with their axis labels (the kinds' own: their series sections' ``labels``).
GENERIC_SERIES: dict[str, str] = {}


def series_labels() -> dict[str, str]:
    """The time series ``summarize`` draws, with their axis labels: the registered series sections' quantities."""
    out = dict(GENERIC_SERIES)
    for role in registry.ROLES:  # every kind's: each registers its own part of the series section
        for kind in registry.kinds(role).values():
            for metric in kind.metrics:
                if metric.section == SERIES_SECTION:
                    out.update(getattr(registry.resolve(metric.make), "labels", {}))
    return out


def parse_grid(specs: Sequence[str]) -> dict[str, list[str]]:
    """``["key=v1,v2", ...]`` as ``{key: [v1, v2]}``; commas inside brackets or braces belong to one value
    (``estimator.models=[cv,ca,ct],[ct,ct,ct]``)."""
    grid: dict[str, list[str]] = {}
    for spec in specs:
        key, sep, values = spec.partition("=")
        key = key.strip()
        if not sep or not key or not values.strip():
            raise ScenarioError(f"--grid {spec!r}: expected key=value1,value2,...")
        if key in grid:
            raise ScenarioError(f"--grid {key}: given twice")
        grid[key] = _split_top_level(values)
    return grid


def _split_top_level(text: str) -> list[str]:
    parts, depth, start = [], 0, 0
    for k, ch in enumerate(text):
        depth += ch in "[{"
        depth -= ch in "]}"
        if ch == "," and depth == 0:
            parts.append(text[start:k].strip())
            start = k + 1
    parts.append(text[start:].strip())
    if any(not p for p in parts):
        raise ScenarioError(f"--grid value list {text!r} has an empty value")
    return parts


def settings(grid: dict[str, list[str]]) -> list[dict[str, str]]:
    """The cross product of the grid's values, in the order given (the last key varies fastest)."""
    return [dict(zip(grid, values, strict=True)) for values in itertools.product(*grid.values())]


def scalars(metrics: dict) -> dict[str, float | None]:
    """The scalar metrics of one run's summary, flattened: what every run has (``target_distance_mean``,
    ``spacing_offset``, ``warnings``) and each registered section's (:meth:`swarmtrack.registry.Metric.flatten`:
    ``rmse_total_x``, ``nees``, ``phi_bar_final``, ...)."""
    out: dict[str, float | None] = {}
    for metric in registry.all_metrics():
        if metric.section in metrics and metric.section != SERIES_SECTION:
            out.update(metric.flatten(metrics[metric.section]))
    out["target_distance_mean"] = metrics.get("target_distance", {}).get("mean")
    out["spacing_offset"] = metrics.get("inter_agent_distance", {}).get("offset")
    out["warnings"] = float(len(metrics.get("warnings", [])))
    return {k: (None if v is None else float(v)) for k, v in out.items()}


def series_columns(metrics: dict) -> dict[str, float | list]:
    """One run's time series (``metrics["series"]``) as row cells: ``series.bin_s`` and a list per quantity."""
    return {f"series.{k}": v for k, v in metrics["series"].items()}


def _row(metrics: dict) -> dict:
    """A finished run's status, error, metrics and time series."""
    if "diverged" in metrics:
        return {"status": "diverged", "error": metrics["diverged"]}
    return {"status": "ok", "error": None, **scalars(metrics), **series_columns(metrics)}


def _run(item: tuple[int, Scenario]) -> tuple[int, dict]:
    """One job in a worker (:func:`~swarmtrack.analysis.runs.run_one`): its status, error, wall time,
    metrics and time series; an exception is a failed run, not a stop."""
    k, scenario = item
    t0 = time.perf_counter()
    try:
        row = _row(run_one(scenario))
    except Exception as exc:  # noqa: BLE001 - stored with the run, the sweep goes on
        row = {"status": "failed", "error": f"{type(exc).__name__}: {exc}"}
    row["wall_s"] = time.perf_counter() - t0
    row["batch"] = 1
    return k, row


def _run_batch(item: tuple[list[int], list[Scenario]]) -> list[tuple[int, dict]]:
    """Jobs that run as one batch of worlds (:mod:`swarmtrack.sim.batch`; the same numbers as one at a time): each
    row's ``wall_s`` is its share of the batch's wall time and ``batch`` the number of worlds. A batch that raises
    is run again one job at a time, so each run gets its own status."""
    ks, scenarios = item
    if len(ks) == 1:
        return [_run((ks[0], scenarios[0]))]
    t0 = time.perf_counter()
    try:
        results = [summary(rec) for rec in batch.simulate_batch(scenarios)]
    except Exception:  # noqa: BLE001 - each run's own outcome comes from running it alone
        return [_run((k, s)) for k, s in zip(ks, scenarios, strict=True)]
    share = (time.perf_counter() - t0) / len(ks)
    return [(k, {**_row(m), "wall_s": share, "batch": len(ks)}) for k, m in zip(ks, results, strict=True)]


#: Simulated seconds of the warm-up run a worker makes before its first job (:func:`warm`).
WARM_UP_S = 1.0


def warm(scenario: Scenario | None = None) -> float:
    """Load in this process what a run needs, once: the imports and, by a run of the first :data:`WARM_UP_S`
    simulated seconds of ``scenario`` (imports only without one), the compiled kernels from numba's cache (about
    0.6 s in a fresh process). Every worker does this before its first job, so a job's stored wall time is its own
    and a Dask cluster's workers are ready before the sweep's clock matters. A failing warm-up run is ignored: the
    real run reports it. Returns the seconds it took."""
    t0 = time.perf_counter()  # the imports are this module's (the simulator's, the metrics')
    if scenario is not None:
        short = WARM_UP_S if scenario.duration is None else min(scenario.duration, WARM_UP_S)
        _run((0, scenario.model_copy(update={"duration": short})))
    return time.perf_counter() - t0


def _worker_init(scenario: Scenario | None) -> None:
    """A local worker process's start: the parent handles Ctrl-C (:func:`worker_signals`), then :func:`warm`."""
    worker_signals()
    warm(scenario)


def sweep(scenario: str, grid: dict[str, list[str]], runs: int, out: Path, workers: int | None = None,
          resume: bool = False, overrides: Sequence[str] = (), on_done: Callable[[int, int], None] | None = None,
          cluster: str | None = None) -> Path:
    """Run every grid setting × seeds 1..``runs`` of ``scenario`` not yet in the store ``out``; return the store.

    Every job is resolved (and so validated: an unknown key, a value of the wrong type) before any runs. An
    existing store is refused unless ``resume``; a store of another format always. ``cluster``: run on Dask, an
    existing scheduler (``tcp://HOST:PORT``) or ``"local"`` (a LocalCluster of ``workers`` processes); the
    scheduler is reached before anything is written."""
    version = package_version()
    jobs = []
    for setting in settings(grid):
        sets = [*overrides, *(f"{k}={v}" for k, v in setting.items())]
        for seed in range(1, runs + 1):
            try:
                resolved = load_scenario(scenario, sets, seed=seed)
            except ScenarioError as exc:
                raise ScenarioError(f"setting {setting}: {exc}") from None
            jobs.append((setting, seed, resolved, run_key(resolved, version)))
    client = dask_client(cluster, workers, warm_with=jobs[0][2] if jobs else None) if cluster else None
    try:
        return _sweep(scenario, grid, runs, out, workers, resume, overrides, on_done, client, jobs, version)
    finally:
        if client is not None:
            close_client(client)


def _sweep(scenario, grid, runs, out, workers, resume, overrides, on_done, client, jobs, version) -> Path:
    manifest = out / "sweep.json"
    store = out / "results"
    if manifest.exists():
        check_format(out, "use another --out")
        if not resume:
            raise ScenarioError(f"{out} holds a sweep already; add --resume to run only what is missing, or use "
                                "another --out")
    elif out.exists() and any(out.iterdir()):
        raise ScenarioError(f"{out} exists and is not a sweep's result store; use another --out")
    store.mkdir(parents=True, exist_ok=True)
    asked = {"format": STORE_FORMAT, "scenario": scenario, "grid": grid, "runs": runs,
             "overrides": list(overrides), "written_by": outputs.version()}
    if manifest.exists():  # a resumed sweep may widen the grid: keep every value asked for, in the order asked
        before = json.loads(manifest.read_text())
        if before.get("scenario") != scenario or before.get("overrides") != list(overrides):
            raise ScenarioError(f"{out} holds a sweep of {before.get('scenario')!r} with --set "
                                f"{before.get('overrides')}; resume it with the same scenario and --set, or use "
                                "another --out")
        merged = {k: list(v) for k, v in before.get("grid", {}).items()}
        for k, values in grid.items():
            merged.setdefault(k, [])
            merged[k] += [v for v in values if v not in merged[k]]
        asked.update(grid=merged, runs=max(runs, before.get("runs", 0)))
    outputs.write_together({manifest: outputs.dump_json(asked)})
    todo = [job for job in jobs if not (store / f"{job[3][:24]}.parquet").exists()]
    done = len(jobs) - len(todo)
    if on_done:
        on_done(done, len(jobs))

    def keep(job, row: dict) -> None:
        nonlocal done
        setting, seed, _, key = job
        _write_row(store / f"{key[:24]}.parquet",
                   {**{f"param.{k}": v for k, v in setting.items()}, "seed": seed, **row, "version": version,
                    "key": key})
        done += 1
        if on_done:
            on_done(done, len(jobs))

    n_workers = 1 if workers == 1 else (workers or os.cpu_count() or 1)
    tasks = [(ks, [todo[k][2] for k in ks]) for ks in batches([job[2] for job in todo], n_workers)]
    if client is not None:
        from distributed import as_completed

        for future in as_completed(client.map(_run_batch, tasks, pure=False)):
            for k, row in future.result():
                keep(todo[k], row)
    elif n_workers == 1 or len(tasks) <= 1:
        if todo:
            warm(todo[0][2])
        for task in tasks:
            for k, row in _run_batch(task):
                keep(todo[k], row)
    else:
        with multiprocessing.Pool(min(n_workers, len(tasks)), _worker_init, (todo[0][2],)) as pool:
            for done_rows in pool.imap_unordered(_run_batch, tasks):
                for k, row in done_rows:
                    keep(todo[k], row)
    return out


def dask_client(cluster: str, workers: int | None, warm_with: Scenario | None = None):
    """A Dask client: of a new LocalCluster (``"local"``, one single-threaded process per worker) or of the
    scheduler at ``cluster``; an unreachable scheduler is a :class:`ScenarioError` naming the address. Every
    worker present is warmed (:func:`warm`, with a short run of ``warm_with``) before the client is returned, so
    the start-up is paid here and not in the first jobs; workers that cannot import swarmtrack are a
    :class:`ScenarioError` too, before any run."""
    try:
        from distributed import Client, LocalCluster
    except ImportError:  # the dask extra; swarmtrack sweep and reproduce refuse --cluster without it before this
        from swarmtrack.extras import EXTRAS, missing, refusal

        raise ScenarioError(refusal("--cluster", "dask", missing("dask") or list(EXTRAS["dask"]))) from None
    if cluster == "local":
        local = LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1, processes=True,
                             dashboard_address=None)
        client = Client(local)
    else:
        try:
            client = Client(cluster, timeout="5s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise ScenarioError(f"--cluster {cluster}: cannot reach a Dask scheduler there ({type(exc).__name__}: "
                                f"{exc})") from None
    try:
        client.run(warm, warm_with)
    except Exception as exc:  # noqa: BLE001 - whatever a remote worker raised, named
        close_client(client)
        raise ScenarioError(f"--cluster {cluster}: its workers cannot run swarmtrack ({type(exc).__name__}: "
                            f"{exc})") from None
    return client


def close_client(client) -> None:
    """Close a :func:`dask_client` and the LocalCluster it started (never a shared scheduler)."""
    cluster = client.cluster
    client.close()
    if cluster is not None:  # the LocalCluster this sweep started, not a shared one
        cluster.close()


def _write_row(path: Path, row: dict) -> None:
    """One run's row as a Parquet file, written whole or not at all (a temporary name, then a rename); lists (the
    time series) as list-of-float64 columns, None a null."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.table({k: pa.array([v], type=pa.list_(pa.float64())) if isinstance(v, list) else [v]
                      for k, v in row.items()})
    tmp = path.with_name(f".{path.name}.partial")
    pq.write_table(table, tmp)
    tmp.replace(path)


def check_format(out: Path, remedy: str) -> None:
    """Refuse (:class:`ScenarioError`, the cause named) a store whose manifest is unreadable or of another format."""
    try:
        manifest = json.loads((Path(out) / "sweep.json").read_text())
        fmt, by = manifest.get("format"), manifest.get("written_by")
    except (OSError, ValueError, AttributeError):
        fmt, by = None, None
    if fmt != STORE_FORMAT:
        by = f" (written by {by})" if by else ""
        raise ScenarioError(f"{out}: a result store of format {fmt!r}{by}, this swarmtrack reads and writes format "
                            f"{STORE_FORMAT} (rows with the runs' time series); {remedy}")


def load_results(out: Path):
    """Every stored run of the sweep in ``out`` as one pandas table (one row per run). A store of another format,
    or a row without the columns this version writes (:data:`ROW_COLUMNS`, and :data:`OK_ROW_COLUMNS` for an
    ``ok`` run), is refused with a :class:`ScenarioError` naming the file and the columns."""
    import pandas as pd
    import pyarrow.parquet as pq

    out = Path(out)
    check_format(out, "sweep again into another --out")
    files = sorted((out / "results").glob("*.parquet"))
    if not files:
        return pd.DataFrame()
    tables = []
    for f in files:
        table = pq.read_table(f)
        status = table.column("status")[0].as_py() if "status" in table.column_names else None
        missing = [c for c in (*ROW_COLUMNS, *(OK_ROW_COLUMNS if status == "ok" else ()))
                   if c not in table.column_names]
        if missing:
            raise ScenarioError(f"{f}: a stored run without {', '.join(missing)}, which format {STORE_FORMAT} rows "
                                "have (written by another swarmtrack?); sweep again into another --out")
        tables.append(table.to_pandas())
    return pd.concat(tables, ignore_index=True)


#: The metrics of every run that ``summarize`` tabulates, after the registered sections' headlines.
GENERIC_HEADLINE = ("spacing_offset",)


def headline() -> tuple[str, ...]:
    """The metrics ``summarize`` tabulates, when a sweep has them: the registered sections' headlines, then
    :data:`GENERIC_HEADLINE`."""
    return (*(name for metric in registry.all_metrics() for name in metric.headline), *GENERIC_HEADLINE)


def summarize(out: Path) -> tuple[str, dict]:
    """Mean ± std and the 95 % t-interval of the mean of every headline metric per setting, over the stored runs
    that finished (``ok``); counts of diverged and failed runs beside. Returns the markdown table and the numbers."""
    table = load_results(out)
    if table.empty:
        raise ScenarioError(f"{out}: no stored runs (is it a sweep's result store?)")
    params = [c for c in table.columns if c.startswith("param.")]
    metrics = [m for m in headline() if m in table.columns and table[m].notna().any()]
    groups = {(k if isinstance(k, tuple) else (k,)): g for k, g in table.groupby(params)} if params else {(): table}
    order = {tuple(s.values()): n for n, s in enumerate(settings(json.loads((out / "sweep.json").read_text())["grid"]))}
    numbers, rows = [], []
    ordered = sorted(groups, key=lambda k: order.get(tuple(k), len(order)))  # the grid's own order
    for key in ordered:
        runs = groups[key]
        ok = runs[runs["status"] == "ok"]
        entry = {"setting": dict(zip((p[6:] for p in params), key, strict=True)), "runs": len(runs),
                 "ok": len(ok), "diverged": int((runs["status"] == "diverged").sum()),
                 "failed": int((runs["status"] == "failed").sum()), "metrics": {}}
        cells = []
        for m in metrics:
            st = mean_std_ci(ok[m].dropna().to_numpy(dtype=float))
            entry["metrics"][m] = st if st["n"] else None
            if not st["n"]:
                cells.append("—")
                continue
            ci = st["ci95"]
            interval = "" if ci is None else f" [{ci[0]:.4g}, {ci[1]:.4g}]"
            cells.append(f"{st['mean']:.4g} ± {st['std']:.2g}{interval}")
        numbers.append(entry)
        rows.append([*(str(k) for k in key), f"{entry['ok']}/{entry['runs']}", *cells])
    md = markdown_table([*(p[6:] for p in params), "ok runs", *(f"{m} mean ± std [95 % CI]" for m in metrics)], rows)
    series = {q: [{"setting": e["setting"], **band}
                  for e, key in zip(numbers, ordered, strict=True)
                  if (band := series_band(groups[key], q)) is not None]
              for q in series_labels()}
    series = {q: bands for q, bands in series.items() if bands}
    md += "\n\n## Time series\n\n" + _series_text(series, table)
    return md, {"settings": numbers, "metrics": metrics, "params": [p[6:] for p in params], "series": series}


def series_band(runs, quantity: str) -> dict | None:
    """Mean and ±1 std over the ``ok`` runs in ``runs`` of one time series, per bin, with the count of runs that
    have the bin (None: no run has it), the runs aligned on their bins as
    :func:`~swarmtrack.analysis.statistics.binned_band` aligns them; as lists, None where no run has the bin."""
    col = f"series.{quantity}"
    if col not in runs.columns:
        return None
    ok = runs[(runs["status"] == "ok") & runs[col].map(lambda v: hasattr(v, "__len__") and len(v) > 0)]
    if ok.empty:
        return None
    band = binned_band(list(ok[col]), list(ok["series.bin_s"]))

    def cells(a):
        return [float(x) if k else None for x, k in zip(a, band["n"], strict=True)]

    return {"bin_s": band["bin_s"], "t": band["t"].tolist(), "mean": cells(band["mean"]), "std": cells(band["std"]),
            "n": band["n"].tolist(), "runs": band["runs"]}


def _series_text(series: dict, table) -> str:
    """What the time-series section of ``summary.md`` says: the series drawn, or why there are none."""
    if not series:
        if not (table["status"] == "ok").any():
            return "No time series: no stored run finished (ok)."
        return "No time series: the finished runs recorded none of " + ", ".join(series_labels()) + "."
    labels = series_labels()
    lines = []
    for q, bands in series.items():
        widths = sorted({b["bin_s"] for b in bands})
        bins = "/".join(f"{w:g}" for w in widths)
        lines.append(f"- `{q}` ({labels.get(q, q)}): mean ± 1 std over seeds per bin of {bins} s, {len(bands)} "
                     f"setting(s), {sum(b['runs'] for b in bands)} runs")
    return "\n".join(lines)


#: Settings drawn in one time-series figure; more go to further figures (``…_over_time_2.png``).
BANDS_PER_FIGURE = 6


def plot_series(numbers: dict, folder: Path) -> list[Path]:
    """Each time series of :func:`summarize` over time: per setting the mean line and a ±1 std band over the seeds
    (:func:`swarmtrack.analysis.figure_style.plot_band`), ``<quantity>_over_time.png``."""
    from swarmtrack.analysis import figure_style  # matplotlib, only when drawing

    paths = []
    labels = series_labels()
    for q, bands in numbers.get("series", {}).items():
        for page in range(0, len(bands), BANDS_PER_FIGURE):
            fig = figure_style.new_figure((7.2, 4.2))
            ax = fig.add_subplot(1, 1, 1)
            for band in bands[page:page + BANDS_PER_FIGURE]:
                label = ", ".join(f"{k}={v}" for k, v in band["setting"].items()) or q
                nan = [float("nan") if v is None else v for v in band["mean"]]
                figure_style.plot_band(ax, band["t"], nan, [float("nan") if v is None else v for v in band["std"]],
                                f"{label} ({band['runs']} runs)")
            if q == "nees":
                ax.axhline(4.0, color="0.4", ls="--", lw=0.9, label="4: a consistent filter")
            ax.set_xlabel("t [s]")
            ax.set_ylabel(labels.get(q, q))
            ax.set_title(f"{q}: mean, ±1 std over seeds", fontsize="medium")
            ax.legend(fontsize="small")
            ax.grid(alpha=0.3)
            suffix = "" if not page else f"_{page // BANDS_PER_FIGURE + 1}"
            paths.append(figure_style.save_figure(fig, folder / f"{q}_over_time{suffix}.png"))
    return paths


def plot_summary(numbers: dict, folder: Path) -> list[Path]:
    """Each headline metric against each grid key (mean and 95 % interval; the other keys' settings as lines)."""
    from swarmtrack.analysis import figure_style  # matplotlib, only when drawing

    paths = []
    params = numbers["params"]
    for m in numbers["metrics"]:
        for p in params:
            fig = figure_style.new_figure((6.4, 4.0))
            ax = fig.add_subplot(1, 1, 1)
            lines: dict[tuple, list] = {}
            for e in numbers["settings"]:
                s = e["setting"]
                rest = tuple((q, s[q]) for q in params if q != p)
                if e["metrics"].get(m):
                    lines.setdefault(rest, []).append((s[p], e["metrics"][m]))
            for rest, pts in lines.items():
                xs = [str(x) for x, _ in pts]
                mean = [v["mean"] for _, v in pts]
                lo = [v["ci95"][0] if v["ci95"] else v["mean"] for _, v in pts]
                hi = [v["ci95"][1] if v["ci95"] else v["mean"] for _, v in pts]
                label = ", ".join(f"{q}={v}" for q, v in rest) or m
                ax.errorbar(xs, mean, yerr=[[a - b for a, b in zip(mean, lo, strict=True)],
                                            [b - a for a, b in zip(mean, hi, strict=True)]],
                            marker="o", capsize=3, label=label)
            ax.set_xlabel(p)
            ax.set_ylabel(m)
            ax.set_title(f"{m} vs {p}: mean, 95 % interval over seeds", fontsize="medium")
            if len(lines) > 1:
                ax.legend(fontsize="small")
            ax.grid(alpha=0.3)
            paths.append(figure_style.save_figure(fig, folder / f"{m}_vs_{p.replace('.', '_')}.png"))
    return paths
