"""Drivers as extras (issue 38, :mod:`swarmtrack.extras`): the table is pyproject.toml's, and in a virtual environment
that holds only what ``pip install swarmtrack`` installs (the distributions its core dependencies pull in, linked
from this environment; swarmtrack itself from this checkout's ``src``) the simulator, its analysis and the core
commands run, while each command that needs a driver says which extra to install, exits with code 2 and writes
nothing."""

from __future__ import annotations

import importlib.metadata as md
import json
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import click
import pytest
from packaging.requirements import Requirement

import swarmtrack
from swarmtrack import cli, extras, registry

SRC = Path(swarmtrack.__file__).resolve().parents[1]
PROJECT = tomllib.loads((SRC.parent / "pyproject.toml").read_text())["project"]
OPTIONAL = PROJECT["optional-dependencies"]
TIMEOUT = 600  # a generous bound against a hang: a first run in a fresh checkout compiles numba's kernels


def _canon(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def _closure(requirements: list[str]) -> set[str]:
    """Every distribution installing ``requirements`` brings (their markers evaluated here, extras followed), as
    installed in this environment."""
    found: dict[str, set[str]] = {}
    todo = [Requirement(r) for r in requirements]
    while todo:
        req = todo.pop()
        name, wanted = _canon(req.name), set(req.extras)
        if name in found and wanted <= found[name]:
            continue
        found.setdefault(name, set()).update(wanted)
        for text in md.requires(req.name) or []:
            nxt = Requirement(text)
            if nxt.marker is None or any(nxt.marker.evaluate({"extra": e}) for e in {*found[name], ""}):
                todo.append(nxt)
    return set(found)


# --- the table ----------------------------------------------------------------------------------------------------

def test_each_extra_of_the_table_is_pyprojects_with_the_modules_its_distributions_install():
    drivers = {e: [Requirement(r) for r in OPTIONAL[e]] for e in extras.EXTRAS}
    importable, core = md.packages_distributions(), _closure(PROJECT["dependencies"])
    for extra, table in extras.EXTRAS.items():
        named = {_canon(r.name) for r in drivers[extra]}
        assert named <= set(table), f"pyproject's {extra!r} asks for {named - set(table)}, not in extras.EXTRAS"
        brought = _closure(OPTIONAL[extra])
        assert set(table) <= brought, f"extras.EXTRAS[{extra!r}] lists {set(table) - brought}, not in pyproject's"
        for dist, module in table.items():
            assert dist in {_canon(d) for d in importable.get(module, [])}, f"{dist} does not install {module}"
        assert not set(table) & core, f"{extra!r}: a core dependency pulls in {set(table) & core} anyway"
    [every] = [Requirement(r) for r in OPTIONAL["all"]]
    assert every.name == "swarmtrack" and every.extras == set(extras.EXTRAS)
    assert "swarmtrack[all]" in OPTIONAL["dev"]  # make run and make test install .[dev]: everything


def test_every_replay_reader_that_needs_an_extra_names_a_distribution_of_it():
    needs = [r.extra for r in registry.kinds(registry.READER).values() if r.extra is not None]
    assert {"rosbags", "pyulog"} <= {dist for _, dist in needs}
    for extra, dist in needs:
        extras.missing(extra, [dist])  # a distribution of that extra (else ValueError)


def test_a_missing_distribution_is_one_line_naming_the_extra_and_exit_2(monkeypatch):
    monkeypatch.setitem(extras.EXTRAS, "radio", {"swarmtrack-no-such-dist": "swarmtrack_no_such_module",
                                                "click": "click"})
    with pytest.raises(click.ClickException) as caught:
        extras.require("radio", "swarmtrack radio")
    assert caught.value.exit_code == 2
    assert caught.value.format_message() == ("swarmtrack radio needs the 'radio' extra (swarmtrack-no-such-dist): "
                                             "pip install 'swarmtrack[radio]'")
    extras.require("radio", "swarmtrack radio --local", ["click"])  # only what that use needs
    with pytest.raises(ValueError, match="not in the 'radio' extra"):
        extras.missing("radio", ["numpy"])


# --- an environment without the extras: slow (about 13 s together, most of it swarmtrack starting in subprocesses) --

def _venv(root: Path, requirements: list[str]) -> Path:
    """A virtual environment at ``root`` whose site-packages links the files of the distributions ``requirements``
    bring (as installed here) and puts this checkout's ``src`` on the path; its python."""
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(root)], check=True, timeout=120)
    [site] = root.glob("lib/python*/site-packages")
    for name in sorted(_closure(requirements)):
        dist = md.distribution(name)
        assert dist.files is not None, f"{name}: no RECORD, its files are unknown"
        for top in sorted({Path(f).parts[0] for f in dist.files} - {"..", "__pycache__"}):
            if not (site / top).exists() and dist.locate_file(top).exists():
                (site / top).symlink_to(dist.locate_file(top))
    (site / "swarmtrack-checkout.pth").write_text(f"{SRC}\n")
    return root / "bin" / "python"


def _env() -> dict[str, str]:
    """This environment's variables, without those that would put other packages on the venv's path."""
    drop = {"PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV", "PYTHONSTARTUP"}
    return {**{k: v for k, v in os.environ.items() if k not in drop}, "PYTHONNOUSERSITE": "1"}


def _swarmtrack(python: Path, cwd: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(python), "-m", "swarmtrack", *args], cwd=cwd, env=_env(), capture_output=True,
                          text=True, timeout=TIMEOUT)


@pytest.fixture(scope="module")
def core(tmp_path_factory) -> Path:
    """The python of an environment with swarmtrack's core dependencies and nothing else."""
    return _venv(tmp_path_factory.mktemp("core-venv") / "venv", PROJECT["dependencies"])


_WHAT_IS_THERE = """\
import importlib, json, sys
import swarmtrack
found = {}
for module in json.loads(sys.argv[1]):
    try:
        importlib.import_module(module)
        found[module] = True
    except ImportError:
        found[module] = False
print(json.dumps({"swarmtrack": swarmtrack.__file__, "found": found}))
"""

#: Modules that are a driver themselves (they import an extra's package at module level): the live swarm, the
#: autopilot side, Stone Soup's interop (the stonesoup extra), the field. Every other module imports without any extra.
DRIVER_MODULES = ("swarmtrack.live.", "swarmtrack.autopilot.", "swarmtrack.interop.stonesoup", "swarmtrack.field.")
_IMPORT_EVERY_CORE_MODULE = """\
import importlib, json, pkgutil, sys
import swarmtrack
failed = {}
for info in pkgutil.walk_packages(swarmtrack.__path__, "swarmtrack."):
    if info.name.startswith(tuple(json.loads(sys.argv[1]))) or info.name == "swarmtrack.__main__":
        continue
    try:
        importlib.import_module(info.name)
    except Exception as exc:
        failed[info.name] = repr(exc)
for name in swarmtrack._PUBLIC:  # the public API: imported on first use
    getattr(swarmtrack, name)
print(json.dumps(failed))
"""


@pytest.mark.slow
def test_the_environment_lacks_every_extra_and_imports_swarmtrack_from_this_checkout(core, tmp_path):
    modules = sorted({m for table in extras.EXTRAS.values() for m in table.values()} | {"mcap", "stonesoup"})
    proc = subprocess.run([str(core), "-c", _WHAT_IS_THERE, json.dumps(modules)], cwd=tmp_path, env=_env(),
                          capture_output=True, text=True, timeout=TIMEOUT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    seen = json.loads(proc.stdout)
    assert Path(seen["swarmtrack"]).resolve() == Path(swarmtrack.__file__).resolve()
    assert seen["found"] == dict.fromkeys(modules, False)


@pytest.mark.slow
def test_every_module_but_the_drivers_imports_without_extras(core, tmp_path):
    proc = subprocess.run([str(core), "-c", _IMPORT_EVERY_CORE_MODULE, json.dumps(DRIVER_MODULES)], cwd=tmp_path,
                          env=_env(), capture_output=True, text=True, timeout=TIMEOUT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert json.loads(proc.stdout.splitlines()[-1]) == {}


@pytest.mark.slow
def test_the_simulator_and_the_core_commands_run_without_extras(core, tmp_path):
    run = _swarmtrack(core, tmp_path, "run", "l24-cv", "--no-plots", "--set", "duration=2", "--out", "run")
    assert run.returncode == 0, run.stderr[-2000:]
    assert (tmp_path / "run" / "metrics.json").is_file()
    for args in (["validate", "l24-ct"], ["schema"], ["scenarios"],
                 ["replay", "run", "--no-plots", "--out", "replayed"],  # a run folder: pyarrow only
                 ["export", "run", "--format", "csv", "--out", "exported"]):  # no bag: rosbags not needed
        proc = _swarmtrack(core, tmp_path, *args)
        assert proc.returncode == 0, (args, proc.stderr[-2000:])
    assert (tmp_path / "replayed" / "metrics.json").is_file() and (tmp_path / "exported").is_dir()


#: Each command that needs an extra, as run without it: its arguments, the extra, the distributions it names.
REFUSED = [
    (["live", "l24-cv", "--out", "out", "--insecure"], "live", "eclipse-zenoh, msgspec, pymavlink"),
    (["world", "l24-cv", "--out", "out", "--insecure"], "live", "eclipse-zenoh, msgspec, pymavlink"),
    (["agent", "l24-cv", "--uav", "1", "--insecure"], "live", "eclipse-zenoh, msgspec, pymavlink"),
    (["keygen", "swarm.key"], "live", "msgspec"),
    (["agent", "l24-cv", "--uav", "1", "--field", "--insecure"], "field", "eclipse-zenoh, msgspec, pymavlink, rosbags"),
    (["monitor", "l24-cv", "--out", "out", "--insecure"], "field", "eclipse-zenoh, msgspec, pymavlink, rosbags"),
    (["stand-in", "l24-cv", "--out", "out"], "field", "eclipse-zenoh, msgspec, pymavlink, rosbags"),
    (["run", "l24-cv", "--out", "out", "--foxglove"], "foxglove", "foxglove-sdk"),
    (["run", "l24-cv", "--out", "out", "--ros2"], "ros2", "cyclonedds, rosbags"),
    (["engage", "--uav", "1", "--to", "127.0.0.1:18570"], "autopilot", "pymavlink"),
    (["export", "run", "--out", "out"], "logs", "rosbags"),
    (["export", "run", "--format", "rosbag2", "--out", "out"], "logs", "rosbags"),
    (["replay", "flight.ulg", "--scenario", "l24-cv", "--out", "out"], "logs", "pyulog"),
    (["replay", "detections.csv", "flight.bag", "--scenario", "l24-cv", "--out", "out"], "logs", "rosbags"),
    (["sweep", "l24-cv", "--runs", "1", "--out", "out", "--cluster", "local"], "dask", "dask, distributed"),
    (["reproduce", "l24", "--runs", "1", "--out", "out", "--cluster", "local"], "dask", "dask, distributed"),
]


def _inputs(folder: Path) -> None:
    """What the refused commands are given: a run folder's shape, a ULog, a bag, a CSV (never read)."""
    (folder / "run" / "recording").mkdir(parents=True)
    for name in ("flight.ulg", "flight.bag", "detections.csv"):
        (folder / name).write_bytes(b"")


def _tree(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


@pytest.mark.slow
def test_each_command_that_needs_an_extra_names_it_exits_2_and_writes_nothing(core, tmp_path):
    procs = []
    for i, (args, _, _) in enumerate(REFUSED):  # side by side: each is a few tenths of a second of start-up
        cwd = tmp_path / str(i)
        cwd.mkdir()
        _inputs(cwd)
        procs.append((cwd, _tree(cwd), subprocess.Popen([str(core), "-m", "swarmtrack", *args], cwd=cwd, env=_env(),
                                                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)))
    wrong = []
    for (args, extra, dists), (cwd, before, proc) in zip(REFUSED, procs, strict=True):
        out, err = proc.communicate(timeout=TIMEOUT)
        said = f"Error: swarmtrack {args[0]}"
        told = f"needs the '{extra}' extra ({dists}): pip install 'swarmtrack[{extra}]'"
        lines = err.strip().splitlines()
        if proc.returncode != 2 or out or len(lines) != 1 or not (lines[0].startswith(said) and
                                                                   lines[0].endswith(told)):
            wrong.append(f"{' '.join(args)}: exit {proc.returncode}, stdout {out!r}, stderr {err[-1500:]!r}")
        elif _tree(cwd) != before:
            wrong.append(f"{' '.join(args)}: wrote {sorted(set(_tree(cwd)) - set(before))}")
    assert not wrong, "\n".join(wrong)


_HELP_EACH = """\
import json, sys
from click.testing import CliRunner
from swarmtrack.cli import main
runner = CliRunner()
print(json.dumps({name: runner.invoke(main, [name, "--help"]).exit_code for name in json.loads(sys.argv[1])}))
"""


@pytest.mark.slow
def test_every_command_is_checked_here_and_each_helps_without_its_extra(core, tmp_path):
    """Each command of the table is either run above without extras or refused there; all of them, refused or
    not, still answer ``--help`` (a command's module imports no extra's package)."""
    core_commands = {"run", "validate", "schema", "scenarios", "replay", "export", "identify", "summarize", "sweep",
                     "reproduce"}  # identify, summarize: their modules import in the environment (test above)
    assert {args[0] for args, _, _ in REFUSED} | core_commands == set(cli.COMMANDS)
    proc = subprocess.run([str(core), "-c", _HELP_EACH, json.dumps(sorted(cli.COMMANDS))], cwd=tmp_path, env=_env(),
                          capture_output=True, text=True, timeout=TIMEOUT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert json.loads(proc.stdout.splitlines()[-1]) == dict.fromkeys(sorted(cli.COMMANDS), 0)


@pytest.fixture(scope="module")
def live_only(tmp_path_factory) -> Path:
    """The python of an environment with the core and the live extra, without the autopilot extra."""
    return _venv(tmp_path_factory.mktemp("live-venv") / "venv", [*PROJECT["dependencies"], *OPTIONAL["live"]])


@pytest.mark.slow
def test_with_the_live_extra_a_serial_autopilot_still_needs_the_autopilot_extra(live_only, tmp_path):
    key = _swarmtrack(live_only, tmp_path, "keygen", "swarm.key")
    assert key.returncode == 0 and (tmp_path / "swarm.key").is_file(), key.stderr[-2000:]
    proc = _swarmtrack(live_only, tmp_path, "agent", "l24-cv", "--uav", "1", "--insecure",
                       "--autopilot", "serial:///dev/ttyACM0:921600")
    assert proc.returncode == 2 and proc.stderr.strip().splitlines() == [
        "Error: swarmtrack agent --autopilot serial:// needs the 'autopilot' extra (pyserial): "
        "pip install 'swarmtrack[autopilot]'"]
