"""Files written whole or not at all, never replacing what they must not (outputs.partial_files)."""

import os
from pathlib import Path

import pytest

from swarmtrack.outputs import MANIFEST, OutputError, dump_json, partial_files, run_folder


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
