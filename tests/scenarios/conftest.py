import pytest
from click.testing import CliRunner

from swarmtrack.cli import main


@pytest.fixture
def refused():
    """``refused(scenario, override, words)``: ``swarmtrack validate SCENARIO --set OVERRIDE`` exits 2 with one
    message holding every one of ``words`` and no traceback."""
    def check(scenario: str, override: str, words: list[str]) -> None:
        result = CliRunner().invoke(main, ["validate", scenario, "--set", override])
        assert result.exit_code == 2, result.output
        for w in words:
            assert w in result.output, result.output
        assert "Traceback" not in result.output

    return check
