import importlib

from click.testing import CliRunner

from swarmtrack.analysis.papers import PAPERS, Paper
from swarmtrack.scenarios import builtin_names


def test_every_paper_is_registered_under_its_name_with_builtin_experiments_or_variants():
    assert {"l24", "l23"} <= set(PAPERS)
    for key, paper in PAPERS.items():
        assert isinstance(paper, Paper) and paper.name == key and paper.title
        assert paper.experiments
        # each experiment is a built-in scenario, or a declared variant of one
        assert {paper.resolve(e)[0] for e in paper.experiments} <= set(builtin_names())
        assert callable(paper.analyse) and callable(paper.figures)


def test_the_published_tables_are_complete():
    from swarmtrack.analysis.papers import l23, l24

    assert set(l24.RMSE) == {"cv", "ct", "fs"}
    for phases in l24.RMSE.values():  # Tables 1-3
        assert set(phases) == {"linear", "sinusoidal", "circular", "total"}
        assert all(len(row) == 4 for row in phases.values())
    assert l24.RMSE["cv"]["total"][0] == 0.2077  # Table 1, 20.77 cm
    assert l23.SPREAD["no-fusion"][0] == 0.2647  # L23 Table 1


def test_the_registry_drives_the_cli_choices(monkeypatch):
    import swarmtrack.cli as cli

    res = CliRunner().invoke(cli.main, ["reproduce", "--help"])
    assert res.exit_code == 0
    assert "{" + "|".join(sorted(PAPERS)) + "}" in res.output
    assert all(p.title in res.output for p in PAPERS.values())
    res = CliRunner().invoke(cli.main, ["reproduce", "w99"])
    assert res.exit_code == 2 and "'w99' is not one of" in res.output and "Traceback" not in res.output

    fake = Paper("w99", "A paper added with one registry line", ("l24-cv",), lambda runs: ([], "", {}),
                 lambda out: [])
    monkeypatch.setitem(PAPERS, "w99", fake)
    try:
        res = CliRunner().invoke(importlib.reload(cli).main, ["reproduce", "--help"])
        assert "w99" in res.output and fake.title in res.output
    finally:
        monkeypatch.undo()
        importlib.reload(cli)
