"""Files written whole or not at all, never replacing what they must not (outputs.partial_files)."""

import pytest

from swarmtrack.outputs import OutputError, partial_files


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
