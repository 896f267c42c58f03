"""Plain-text tables for the terminal and Markdown reports."""

from __future__ import annotations

from swarmtrack.analysis.metrics import COMPONENTS


def format_rmse_table(rmse: dict[str, dict[str, float]], title: str) -> str:
    """RMSE table in cm and cm/s, one row per phase, as L24 Tables 1-3."""
    lines = [title, f"{'':12s}" + "".join(f"{c:>9s}" for c in COMPONENTS)]
    for phase, row in rmse.items():
        lines.append(f"{phase:12s}" + "".join(f"{100 * row[c]:9.2f}" for c in COMPONENTS))
    return "\n".join(lines)


def markdown_table(header: list[str], rows: list[list[str]]) -> str:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(out)
