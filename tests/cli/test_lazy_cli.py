"""``swarmtrack --help`` answers from :data:`swarmtrack.cli.COMMANDS` without importing any command (issue 26): the
listing is click's own, every registered command is in it, and the table's one-line helps are the commands' own.
How fast it answers is measured by benchmarks/bench_cli.py, not here."""

from __future__ import annotations

import json
import subprocess
import sys

import click
import pytest
from click.testing import CliRunner

from swarmtrack import cli

#: What ``import swarmtrack.cli`` and ``swarmtrack --help`` must not import: the numerics, the data frames, the
#: figures, the schema, the cluster, the live swarm's transport, the autopilot link, the log readers, the progress bar.
HEAVY = {"numpy", "numba", "llvmlite", "scipy", "pandas", "pyarrow", "matplotlib", "shapely", "pydantic", "yaml",
         "dask", "distributed", "zenoh", "pymavlink", "rosbags", "mcap", "pyulog", "stonesoup", "rich"}

_HELP_IN_A_FRESH_PROCESS = """\
import json, sys
from swarmtrack.cli import main
try:
    main(["--help"], prog_name="swarmtrack")
except SystemExit as exc:
    code = exc.code
heavy = sorted(m for m in sys.modules if m.split(".")[0] in set(json.loads(sys.argv[1])))
ours = sorted(m for m in sys.modules if m.split(".")[0] == "swarmtrack")
print(json.dumps({"code": code, "heavy": heavy, "ours": ours}))
"""


def test_help_lists_every_command_and_imports_none_of_them():
    proc = subprocess.run([sys.executable, "-c", _HELP_IN_A_FRESH_PROCESS, json.dumps(sorted(HEAVY))],
                          capture_output=True, text=True, timeout=60)
    *help_lines, last = proc.stdout.splitlines()
    found = json.loads(last)
    assert found == {"code": 0, "heavy": [], "ours": ["swarmtrack", "swarmtrack.cli"]}, proc.stderr
    listed = help_lines[help_lines.index("Commands:") + 1:]
    assert [line.split()[0] for line in listed] == sorted(cli.COMMANDS)


def _loaded() -> dict[str, click.Command]:
    """Every command of the table, imported as running it would (a fresh group: nothing shared with cli.main)."""
    group = cli.LazyGroup("swarmtrack", lazy=cli.COMMANDS)
    ctx = click.Context(group, info_name="swarmtrack")
    return {name: group.get_command(ctx, name) for name in group.list_commands(ctx)}


@pytest.fixture(scope="module")
def loaded() -> dict[str, click.Command]:
    return _loaded()


def test_the_table_names_each_command_and_its_own_first_sentence(loaded):
    for name, (_, sentence) in cli.COMMANDS.items():
        command = loaded[name]
        assert isinstance(command, click.Command) and command.name == name
        assert sentence == command.get_short_help_str(10**6), f"{name}: the table's help is not the command's"


@pytest.mark.parametrize("width", [40, 80, 120, 250])
def test_the_listing_is_the_one_click_makes_from_the_imported_commands(loaded, width):
    lazy = cli.LazyGroup("swarmtrack", lazy=cli.COMMANDS, help=cli.main.help)
    eager = click.Group("swarmtrack", commands=loaded, help=cli.main.help)
    assert lazy.get_help(click.Context(lazy, info_name="swarmtrack", terminal_width=width, max_content_width=width)) \
        == eager.get_help(click.Context(eager, info_name="swarmtrack", terminal_width=width, max_content_width=width))
    assert not lazy.commands  # the lazy group's help imported nothing


def test_a_commands_own_help_and_an_unknown_command_answer_as_before():
    res = CliRunner().invoke(cli.main, ["scenarios", "-h"])
    assert res.exit_code == 0 and res.output.startswith("Usage: main scenarios [OPTIONS]")
    res = CliRunner().invoke(cli.main, ["no-such-command"])
    assert res.exit_code == 2 and "No such command 'no-such-command'" in res.output
