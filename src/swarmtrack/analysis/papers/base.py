"""What a paper module provides (:class:`Paper`), the claims it checks (:class:`Claim`) and shared statistics."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from swarmtrack.analysis.statistics import mean_std_ci, stats

__all__ = ["Analyse", "Claim", "Paper", "converged", "mean_std_ci", "stats"]

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
    #: What a study measures beside its runs' metrics (timings, other libraries on the same inputs):
    #: ``study(by_scenario, overrides, runs) -> (claims, markdown, numbers)``, run after :attr:`analyse`.
    study: Callable[..., tuple[list[Claim], str, dict]] | None = None

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


def converged(runs: list[dict]) -> list[dict]:
    """The runs whose filter did not diverge."""
    return [r for r in runs if "diverged" not in r]
