"""Bad scenario input: every case is one :class:`ScenarioError` naming the field or the cause."""

import os

import pytest

from swarmtrack.scenarios import ScenarioError, load_scenario
from swarmtrack.scenarios.loader import apply_override, load_raw


def _file(tmp_path, content: bytes | str, name: str = "s.yaml") -> str:
    f = tmp_path / name
    f.write_bytes(content if isinstance(content, bytes) else content.encode())
    return str(f)


# --- the file itself -------------------------------------------------------------------------------------------

@pytest.mark.parametrize("content, message", [
    (b"\xff\xfe\x00\x01binary\x00", "not a UTF-8 text file"),
    ("name: caf\u00e9\n".encode("latin-1"), r"not a UTF-8 text file \(byte 0xe9 at offset 9\)"),
    (b"name: x\x00\n", "not valid YAML"),
    (b"", "empty scenario file"),
    (b"# only a comment\n\n   # and another\n", "empty scenario file"),
    (b"---\n", "empty scenario file"),
    (b"[" * 10_000 + b"]" * 10_000, "nested more than 50 levels deep"),
    (b"swarm:\n" + b"".join(b"  " * k + b"a:\n" for k in range(1, 2000)), "nested more than 50 levels deep"),
    (b"name: a\nseed: 1\nname: b\n", r"duplicate key 'name' \(first given on line 1\) \(line 3"),
    (b"swarm:\n  n_uavs: 3\n  n_uavs: 5\n", r"duplicate key 'n_uavs' \(first given on line 2\)"),
    (b"swarm: {n_uavs: 3, n_uavs: 5}\n", "duplicate key 'n_uavs'"),
    (b"- 1\n- 2\n", "must be a mapping"),
    (b"a: 1\n---\nb: 2\n", "not valid YAML: expected a single document in the stream: but found another document"),
])
def test_bad_files_are_one_message(tmp_path, content, message):
    path = _file(tmp_path, content)
    with pytest.raises(ScenarioError, match=message) as err:
        load_scenario(path)
    assert str(err.value).startswith(path) and len(str(err.value).splitlines()) == 1


def test_a_byte_order_mark_and_merge_keys_are_fine(tmp_path):
    path = _file(tmp_path, "\ufeffname: bom\nswarm: {<<: {n_uavs: 4, vehicle: quadrotor}, n_uavs: 5}\n".encode())
    scn = load_scenario(path)
    assert scn.name == "bom" and scn.swarm.n_uavs == 5


def test_explicit_empty_mapping_runs_the_defaults(tmp_path):
    assert load_scenario(_file(tmp_path, "{}\n")).name == "custom"


def test_a_folder_is_not_a_scenario(tmp_path):
    (tmp_path / "d.yaml").mkdir()
    with pytest.raises(ScenarioError, match="is a folder, not a scenario file"):
        load_raw(str(tmp_path / "d.yaml"))


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root reads a chmod 000 file")
def test_an_unreadable_file_is_named(tmp_path):
    path = _file(tmp_path, "name: x\n")
    os.chmod(path, 0)
    try:
        with pytest.raises(ScenarioError, match="cannot be read"):
            load_raw(path)
    finally:
        os.chmod(path, 0o644)


def test_a_read_error_is_named_even_as_root(tmp_path, monkeypatch):
    path = _file(tmp_path, "name: x\n")

    def denied(self):
        raise PermissionError(13, "Permission denied", str(self))

    monkeypatch.setattr(type(tmp_path), "read_bytes", denied)
    with pytest.raises(ScenarioError, match=r"s.yaml: cannot be read \(Permission denied\)$"):
        load_raw(path)


def test_override_values_get_the_same_checks():
    with pytest.raises(ScenarioError, match="duplicate key 'n_uavs'"):
        apply_override({}, "swarm={n_uavs: 3, n_uavs: 4}")
    with pytest.raises(ScenarioError, match="nested more than"):
        apply_override({}, "estimator.q=" + "[" * 5000 + "]" * 5000)
