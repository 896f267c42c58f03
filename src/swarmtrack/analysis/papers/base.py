"""What a paper module provides (:class:`Paper`), the claims it checks (:class:`Claim`) and shared statistics."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

#: ``analyse(by_scenario) -> (claims, markdown, numbers)``; ``by_scenario`` maps each experiment to its runs'
#: metrics (one dict per seed, ``{"diverged": message}`` for a run whose filter diverged).
Analyse = Callable[[dict[str, list[dict]]], tuple[list["Claim"], str, dict]]


@dataclass(frozen=True)
class Paper:
    """One reproducible paper: its built-in scenarios, how to compare their runs with it, its figures."""

    name: str  #: short name, the ``swarmtrack reproduce`` argument
    title: str
    experiments: tuple[str, ...]  #: built-in scenario names, each run over seeds 1..runs
    analyse: Analyse
    figures: Callable[..., list[Path]]  #: ``figures(out, overrides)``: the paper's figures (seed 1) into a folder
    #: Figures drawn from the runs themselves, by name (``"8"``) → the experiments they need. A paper that declares
    #: them is called ``figures(out, overrides, by_scenario, figure)`` with its runs, and ``swarmtrack reproduce
    #: --figure NAME`` runs only that group's experiments (its ``analyse`` then gets only those, and must cope).
    figure_groups: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    #: Experiments that are a built-in scenario with overrides, by name → ``(scenario, overrides)`` (a study of one
    #: scenario under many settings); the runs are named after the experiment.
    variants: Mapping[str, tuple[str, tuple[str, ...]]] = field(default_factory=dict)

    def resolve(self, experiment: str, overrides: Sequence[str] = ()) -> tuple[str, list[str]]:
        """The built-in scenario and the overrides of ``experiment`` (the user's ``overrides`` last)."""
        if experiment not in self.variants:
            return experiment, list(overrides)
        scenario, own = self.variants[experiment]
        return scenario, [*own, f"name={experiment}", *overrides]


@dataclass
class Claim:
    """A statement of the paper, the paper's and the project's numbers for it, and whether the project's hold."""

    id: str
    text: str
    paper: object
    project: object
    holds: bool

    def as_dict(self) -> dict:
        return {"id": self.id, "text": self.text, "paper": self.paper, "project": self.project,
                "holds": bool(self.holds)}


def stats(values: list[float]) -> tuple[float, float]:
    """Mean and standard deviation over seeds."""
    a = np.asarray(values, dtype=float)
    return float(a.mean()), float(a.std())


def mean_std_ci(values) -> dict:
    """Mean, standard deviation (over seeds, as :func:`stats`) and the 95 % t-interval of the mean, and the count;
    None where undefined (no values; one value has no interval)."""
    a = np.asarray(list(values), dtype=float)
    if a.size == 0:
        return {"mean": None, "std": None, "ci95": None, "n": 0}
    mean, std = float(a.mean()), float(a.std())
    ci = None
    if a.size > 1:
        from scipy.stats import t

        half = float(t.ppf(0.975, a.size - 1) * a.std(ddof=1) / np.sqrt(a.size))
        ci = [mean - half, mean + half]
    return {"mean": mean, "std": std, "ci95": ci, "n": int(a.size)}


def converged(runs: list[dict]) -> list[dict]:
    """The runs whose filter did not diverge."""
    return [r for r in runs if "diverged" not in r]
