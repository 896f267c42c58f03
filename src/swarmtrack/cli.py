"""Command line: ``swarmtrack run | reproduce | sweep | summarize | validate | schema | identify | scenarios | live |
world | agent | keygen | export | replay``.

This module is what ``swarmtrack`` starts with, so it imports click and nothing of the simulator: the commands are
listed in :data:`COMMANDS` ("module:attribute" and their one-line help) and a command's module is imported only when
that command is run or its own ``--help`` is asked (click's lazy-loading group). ``swarmtrack --help`` answers
from the table. The commands themselves are in :mod:`swarmtrack.commands`, :mod:`swarmtrack.live.commands`,
:mod:`swarmtrack.interop.commands` and :mod:`swarmtrack.replay.commands`.

Bad input (scenario, override, option) prints one message naming the field and exits with code 2; a run's
folder is staged and moved into place only when complete, and never replaces what the tool did not write
(:mod:`swarmtrack.outputs`).
"""

from __future__ import annotations

import atexit
import contextlib
import gc
import importlib
from gettext import gettext as _

import click

#: Every command: its name → ("module:attribute" of the click command, or of a function without arguments that
#: makes it; the first sentence of its help, which ``swarmtrack --help`` shortens as click does). A test checks
#: that each sentence is the command's own.
COMMANDS: dict[str, tuple[str, str]] = {
    "agent": ("swarmtrack.live.commands:agent_cmd",
              "Run UAV --uav's onboard stack (estimator, controller) of SCENARIO, as on its companion computer: its "
              "navigation, detections and radio from the world (or its navigation from its autopilot, --autopilot), "
              "its neighbours' messages over Zenoh; with --field, no world: its own sensor's topic and the real "
              "network."),
    "monitor": ("swarmtrack.field.commands:monitor_cmd",
                "Join SCENARIO's field swarm read-only and record what its agents publish (their probes, commands and "
                "counts, and the truth when --truth is given) into the run folder --out; Ctrl-C keeps the steps "
                "recorded."),
    "stand-in": ("swarmtrack.field.commands:standin_cmd",
                 "Run SCENARIO as a field deployment on this machine, with nothing a real one lacks: each UAV's "
                 "vehicle over MAVLink, its camera on its own Zenoh topic, its agent (swarmtrack agent --field) "
                 "hearing the others directly, and a monitor recording into --out; no world process plays the "
                 "radio."),
    "engage": ("swarmtrack.live.commands:engage_cmd",
               "Ask UAV --uav's swarmtrack agent to fly its vehicle again after a handover to the operator (or, with "
               "--release, to hand it back), through the autopilot's ground-station link at --to."),
    "export": ("swarmtrack.interop.commands:export_cmd",
               "Write the run in RUN (a swarmtrack run folder) as standard messages: the truth and every UAV's "
               "estimate with its covariance (docs/replay.md lists the topics)."),
    "identify": ("swarmtrack.commands:identify_cmd", "Identify the UAV's position-controlled dynamics (W20 eqs."),
    "keygen": ("swarmtrack.live.commands:keygen_cmd",
               "Write a new swarm key to FILE (readable by its owner only); an existing FILE is never replaced."),
    "live": ("swarmtrack.live.commands:live_cmd",
             "Run SCENARIO with every UAV's onboard stack in its own process (swarmtrack agent --uav I), talking over "
             "Eclipse Zenoh on loopback with this world process: in lockstep (the run folder of swarmtrack run, with "
             "the same numbers) or at wall-clock rate (--realtime)."),
    "replay": ("swarmtrack.replay.commands:replay_cmd",
               "Run a scenario's onboard stack (its estimator; the controller is not run) on recorded navigation and "
               "detections instead of a simulated world: LOGS are a swarmtrack run folder, ROS bags (ROS 1, ROS 2 "
               "sqlite3 or MCAP), PX4 ULog files or CSV files."),
    "reproduce": ("swarmtrack.commands:reproduce_command",
                  "Run a paper's experiments over several seeds and check its claims."),
    "run": ("swarmtrack.commands:run_cmd",
            "Run one closed-loop simulation of SCENARIO (a built-in name or a YAML file)."),
    "scenarios": ("swarmtrack.commands:scenarios_cmd", "List the built-in scenarios."),
    "schema": ("swarmtrack.commands:schema_cmd",
               "Every scenario key: dotted path, type, default, allowed values and unit (docs/scenarios.md)."),
    "summarize": ("swarmtrack.commands:summarize_cmd",
                  "Summarize a sweep's result store OUT: mean ± std and the 95 % interval of each metric per setting "
                  "(printed, and written to OUT/summary.md and OUT/summary.json together), each metric against each "
                  "grid key, and each time series (position error, NEES, formation tracking error) as mean lines with "
                  "±1 std bands over the seeds per setting, as figures in OUT/summary/ (listed in summary.md)."),
    "sweep": ("swarmtrack.commands:sweep_cmd",
              "Run SCENARIO over the cross product of grid values x seeds 1..RUNS, in parallel."),
    "validate": ("swarmtrack.commands:validate_cmd",
                 "Check SCENARIO (a built-in name or a YAML file) and print it fully resolved, as run writes "
                 "scenario.yaml."),
    "world": ("swarmtrack.live.commands:world_cmd",
              "Run the truth side of SCENARIO alone (world, sensors, simulated radio, recorder) and wait for its UAVs' "
              "processes (swarmtrack agent --uav I --connect ENDPOINT) to join."),
}


class LazyGroup(click.Group):
    """A group whose commands are imported when first asked for (click's lazy-loading pattern): ``lazy`` maps a
    command's name to ("module:attribute", the first sentence of its help). Running a command, its ``--help`` or
    shell completion imports it (once per group); the group's own ``--help`` lists the sentences, shortened as click
    shortens a command's help, and imports nothing."""

    def __init__(self, *args, lazy: dict[str, tuple[str, str]], **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.lazy = dict(lazy)

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*super().list_commands(ctx), *self.lazy})

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name in self.lazy and cmd_name not in self.commands:
            self.add_command(self._load(cmd_name), cmd_name)
        return super().get_command(ctx, cmd_name)

    def _load(self, name: str) -> click.Command:
        module, _, attr = self.lazy[name][0].partition(":")
        with _collector_paused():
            found = getattr(importlib.import_module(module), attr)
        command = found if isinstance(found, click.Command) else found()
        if not isinstance(command, click.Command):
            raise TypeError(f"{self.lazy[name][0]} (command {name!r}) is not a click command nor makes one")
        return command

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        """click's listing, with a stand-in holding the table's sentence for each command not imported yet."""
        commands = []
        for name in self.list_commands(ctx):
            cmd = self.commands.get(name) or click.Command(name, help=self.lazy[name][1])
            if not cmd.hidden:
                commands.append((name, cmd))
        if commands:
            limit = formatter.width - 6 - max(len(name) for name, _ in commands)
            with formatter.section(_("Commands")):
                formatter.write_dl([(name, cmd.get_short_help_str(limit)) for name, cmd in commands])


@click.group(cls=LazyGroup, lazy=COMMANDS, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="swarmtrack")
def main() -> None:
    """Cooperative target estimation and tracking by UAV swarms."""
    if not _exit_fast:
        _exit_fast.append(atexit.register(gc.freeze))


@contextlib.contextmanager
def _collector_paused():
    """Imports without the cycle collector, then ``gc.freeze``: a command's imports (numpy, numba, pydantic, the
    simulator) make about a million objects that live as long as the process, and the collector's passes over them
    while they were made took about a sixth of the imports' time; frozen, the collections of the run itself do not
    walk them again. The collector's state is restored."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        gc.freeze()
        if enabled:
            gc.enable()


#: Once a command runs, its process ends without the cycle collector's final passes over what it imported:
#: ``gc.freeze`` at exit (an atexit handler; the other handlers and the modules' teardown still run). A command has
#: written and closed its files before it returns; collecting the cycles of numba, pandas and pydantic as the
#: interpreter ended took 0.4-0.6 s of a 3.5 s ``swarmtrack run l24-cv --no-plots``.
_exit_fast: list = []


if __name__ == "__main__":  # pragma: no cover
    main()
