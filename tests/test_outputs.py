"""Files written whole or not at all, never replacing what they must not (outputs.partial_files)."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from swarmtrack.cli import main
from swarmtrack.outputs import (
    MANIFEST,
    STAGING_MARKER,
    OutputError,
    check_destination,
    check_new_destination,
    dump_json,
    partial_files,
    run_folder,
)


def test_a_file_that_appeared_meanwhile_is_not_replaced_without_overwrite(tmp_path):
    target = tmp_path / "movie.gif"
    with pytest.raises(OutputError, match="appeared meanwhile"):
        with partial_files([target], keep_suffix=True, overwrite=False) as (tmp,):
            assert tmp.suffix == ".gif" and tmp.name.startswith(".movie.gif.")
            tmp.write_text("new")
            target.write_text("the user's")  # appears while the writer works
    assert target.read_text() == "the user's"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["movie.gif"]  # the partial file is gone


def test_with_overwrite_the_new_file_replaces_the_old_and_nothing_else_remains(tmp_path):
    target = tmp_path / "report.json"
    target.write_text("old")
    with partial_files([target]) as (tmp,):
        tmp.write_text("new")
    assert target.read_text() == "new" and [p.name for p in tmp_path.iterdir()] == ["report.json"]


def _other_run(out):
    """Another swarmtrack run's files in ``out`` (its manifest lists them)."""
    out.mkdir(exist_ok=True)
    (out / "metrics.json").write_text("{}")
    (out / MANIFEST).write_text(dump_json({"written_by": "swarmtrack 0 (the other run)", "files": ["metrics.json"]}))


@pytest.mark.parametrize("start", ["absent", "empty"])
def test_a_run_folder_another_run_filled_meanwhile_is_never_replaced_without_overwrite(tmp_path, start):
    out = tmp_path / "run"
    if start == "empty":
        out.mkdir()
    with pytest.raises(OutputError, match="another run wrote its files there while this one ran"):
        with run_folder(out) as staged:
            (staged / "recording.txt").write_text("the late run's")
            _other_run(out)  # the other run moves its files into place between the check and the move
    assert sorted(p.name for p in out.iterdir()) == ["manifest.json", "metrics.json"]
    assert "the other run" in (out / MANIFEST).read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]  # no staging folder left


def test_with_overwrite_a_run_folder_filled_meanwhile_is_replaced_file_by_file(tmp_path):
    out = tmp_path / "run"
    with run_folder(out, overwrite=True) as staged:
        (staged / "recording.txt").write_text("the late run's")
        _other_run(out)
    assert sorted(p.name for p in out.iterdir()) == ["manifest.json", "recording.txt"]


def test_an_empty_folder_given_as_out_is_kept_and_the_run_lands_in_it(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    out.chmod(0o750)  # the user's folder, with its own permissions: never removed and made again
    inode = out.stat().st_ino
    with run_folder(out) as staged:
        (staged / "sub").mkdir()
        (staged / "sub" / "recording.txt").write_text("ours")
        (staged / "metrics.json").write_text("{}")
    assert out.stat().st_ino == inode and out.stat().st_mode & 0o777 == 0o750
    assert sorted(str(p.relative_to(out)) for p in out.rglob("*")) == ["manifest.json", "metrics.json", "sub",
                                                                       "sub/recording.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def test_a_file_another_run_puts_into_an_empty_out_during_the_move_is_kept_and_only_ours_are_removed(
        tmp_path, monkeypatch):
    out = tmp_path / "run"
    out.mkdir()
    real_link = os.link

    def racing_link(src, dst):  # the other run's manifest arrives just before this run places its own
        if Path(dst).name == MANIFEST:
            _other_run(out)
        return real_link(src, dst)

    monkeypatch.setattr(os, "link", racing_link)
    with pytest.raises(OutputError, match="another run wrote its files there while this one ran"):
        with run_folder(out) as staged:
            (staged / "recording.txt").write_text("the late run's")
    assert sorted(p.name for p in out.iterdir()) == ["manifest.json", "metrics.json"]  # the other run's, whole
    assert "the other run" in (out / MANIFEST).read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


_STAGE_AND_WAIT = """
import sys, time
from pathlib import Path
from swarmtrack.outputs import run_folder
with run_folder(Path(sys.argv[1])) as tmp:
    (tmp / "metrics.json").write_text("{}")
    print(tmp, flush=True)
    time.sleep(120)
"""


def _staging(out: Path) -> subprocess.Popen:
    """A process staging a run into ``out`` (it waits there); its staging folder is its first line of output."""
    return subprocess.Popen([sys.executable, "-c", _STAGE_AND_WAIT, str(out)], stdout=subprocess.PIPE, text=True)


def test_the_staging_folder_a_killed_run_left_is_removed_by_the_next_run_into_that_folder_and_only_it(
        tmp_path, capsys):
    out = tmp_path / "run"
    killed, running = _staging(out), _staging(out)
    try:
        left, live = Path(killed.stdout.readline().strip()), Path(running.stdout.readline().strip())
        killed.kill()  # SIGKILL: no cleanup runs
        killed.wait(timeout=30)
        assert left.is_dir() and live.is_dir()
        # staging folders this run cannot be sure of: another host's, one without a marker, another folder's
        other_host = tmp_path / ".run.otherhost.partial"
        other_host.mkdir()
        marker = json.loads((left / STAGING_MARKER).read_text())
        (other_host / STAGING_MARKER).write_text(json.dumps({**marker, "host": "elsewhere"}))
        unmarked = tmp_path / ".run.unmarked.partial"
        unmarked.mkdir()
        other_out = tmp_path / ".run.b.xyz.partial"  # a run into run.b
        other_out.mkdir()
        (other_out / STAGING_MARKER).write_text(json.dumps({**marker, "out": str(tmp_path / "run.b")}))
        capsys.readouterr()
        with run_folder(out) as staged:
            (staged / "metrics.json").write_text("{}")
        notes = capsys.readouterr().err
        assert not left.exists() and f"removed {left}" in notes  # the killed run's: gone, and said so
        assert live.is_dir()  # the running one's: kept
        assert other_host.is_dir() and unmarked.is_dir() and other_out.is_dir()  # kept
        assert f"{other_host} is the staging folder of a run into {out} by process" in notes
        assert f"{unmarked} looks like the staging folder" in notes and str(other_out) not in notes
        assert sorted(p.name for p in out.iterdir()) == [MANIFEST, "metrics.json"]  # the marker is not kept
    finally:
        for p in (killed, running):
            if p.poll() is None:
                p.kill()
                p.wait()


def test_a_dangling_symbolic_link_as_destination_is_refused_naming_it(tmp_path):
    link = tmp_path / "out"
    link.symlink_to(tmp_path / "nowhere")
    for check in (lambda: check_destination(link, overwrite=True), lambda: check_new_destination(link)):
        with pytest.raises(OutputError, match="symbolic link to .*nowhere, which does not exist"):
            check()
    assert link.is_symlink() and not (tmp_path / "nowhere").exists()


def test_export_onto_a_dangling_symbolic_link_is_one_message_and_exit_2(tmp_path):
    run = tmp_path / "run"
    (run / "recording").mkdir(parents=True)  # the destination is checked before the run is read
    link = tmp_path / "run.mcap"
    link.symlink_to(tmp_path / "nowhere")
    res = CliRunner().invoke(main, ["export", str(run), "--out", str(link)])
    assert res.exit_code == 2 and str(link) in res.output and "symbolic link" in res.output, res.output
    assert not isinstance(res.exception, NotADirectoryError) and "Traceback" not in res.output
    assert link.is_symlink() and sorted(p.name for p in tmp_path.iterdir()) == ["run", "run.mcap"]
