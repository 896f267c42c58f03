"""Writing results without ever destroying a user's files.

* A run's folder is written into a hidden staging folder beside it and moved into place only when complete;
  an interruption (Ctrl-C, SIGTERM, an error) removes the staging folder and leaves nothing half-written.
* An existing non-empty folder is refused unless ``overwrite``; even then only the files an earlier swarmtrack
  run listed in its ``manifest.json`` are replaced: the tool deletes only what it created.
* The destination is checked again when the staged folder is moved into place: without ``overwrite``, a folder
  that another run filled meanwhile (two runs started together with the same ``--out``) is never replaced; the
  late run fails (:class:`OutputError`, exit 2 in the CLI) saying so, and its staged files are removed.
* JSON is strict (``null``, never ``NaN``) and every output names the swarmtrack version that wrote it.
* A staging folder carries a marker (:data:`STAGING_MARKER`: the process id, its start time and the host); one left
  by a run that was killed (SIGKILL, a power cut) is removed by the next run into the same folder when the marker
  says for sure that it was a swarmtrack run into that folder, on this host, whose process is gone
  (:func:`clean_stale_staging`); any other is left as it is, and said so.
"""

from __future__ import annotations

import contextlib
import errno
import functools
import glob
import json
import math
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
from collections.abc import Callable
from contextlib import contextmanager
from pathlib import Path

from swarmtrack import __version__

MANIFEST = "manifest.json"
#: The marker file in a run's staging folder (never moved into the run folder): who stages there.
STAGING_MARKER = ".swarmtrack-staging.json"


class OutputError(ValueError):
    """An output folder that cannot be used, with a message naming it and why."""


def package_version() -> str:
    """The running swarmtrack's version: the source's ``__version__`` (an editable install's metadata keeps the version
    it was installed at, so reading it would key caches with a stale version after an upgrade of the checkout)."""
    return __version__


@functools.lru_cache(maxsize=1)
def version() -> str:
    """``swarmtrack X.Y.Z``, plus the git commit when run from a checkout with one."""
    text = f"swarmtrack {package_version()}"
    here = Path(__file__).resolve().parent
    try:
        commit = subprocess.run(["git", "-C", str(here), "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True, timeout=5)
    except (OSError, subprocess.SubprocessError):
        return text
    if commit.returncode == 0 and commit.stdout.strip():
        text += f" (git {commit.stdout.strip()})"
    return text


def finite(value):
    """``value`` with every non-finite float replaced by None (JSON ``null``), recursively."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [finite(v) for v in value]
    return value


def dump_json(value) -> str:
    """Strict JSON text (``allow_nan=False`` after :func:`finite`)."""
    return json.dumps(finite(value), indent=2, allow_nan=False)


@contextmanager
def signals_held():
    """Ctrl-C and SIGTERM wait until the block has run (a rename of several files is not cut halfway)."""
    blocked = {signal.SIGINT, signal.SIGTERM}
    signal.pthread_sigmask(signal.SIG_BLOCK, blocked)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, blocked)


@contextmanager
def partial_files(paths: list[Path], *, keep_suffix: bool = False, overwrite: bool = True):
    """One fresh hidden temporary file beside each of ``paths`` (``mkstemp``: never an existing file), to write
    in the block; afterwards they replace ``paths`` together (signals held), or, on an error, are removed.
    Only files this function created are ever deleted. ``keep_suffix``: the temporary name ends in the path's
    suffix (for writers that pick the format by it). ``overwrite`` False: a path that appeared meanwhile is never
    replaced (:class:`OutputError`, nothing moved)."""
    made = []
    try:
        for path in paths:
            path.parent.mkdir(parents=True, exist_ok=True)
            suffix = f".partial{path.suffix}" if keep_suffix else ".partial"
            fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)
            os.close(fd)
            made.append(Path(name))
        yield made
        with signals_held():
            if not overwrite:
                for path in paths:
                    if path.exists() or path.is_symlink():
                        raise OutputError(f"{path}: the file appeared meanwhile; add --overwrite to replace it")
            for tmp, path in zip(made, paths, strict=True):
                os.replace(tmp, path)
    finally:
        for tmp in made:
            tmp.unlink(missing_ok=True)


def write_together(texts: dict[Path, str]) -> None:
    """Write several text files so that they appear together or not at all."""
    with partial_files(list(texts)) as tmps:
        for tmp, text in zip(tmps, texts.values(), strict=True):
            tmp.write_text(text)


class Terminated(BaseException):
    """SIGTERM or SIGINT (Ctrl-C), raised as an exception so that cleanup runs."""


@contextmanager
def terminate_as_exception():
    """Turn SIGTERM and SIGINT into :class:`Terminated` while the block runs (main thread only). SIGINT is taken
    too, rather than left to Python's KeyboardInterrupt: CPython remembers a KeyboardInterrupt that crossed
    certain C code and then ends the process by SIGINT whatever exit code the program chose (seen here now and
    then as a return code of −2 instead of 130)."""
    def handler(signum, frame):
        if in_compiler(frame):  # an exception inside numba's LLVM callbacks crashes the process: try again soon
            signal.setitimer(signal.ITIMER_REAL, RETRY_S)
            return
        raise Terminated()

    signals = (signal.SIGTERM, signal.SIGINT, signal.SIGALRM)
    try:
        previous = {sig: signal.signal(sig, handler) for sig in signals}
    except ValueError:  # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        for sig, old in previous.items():
            signal.signal(sig, old)


#: How soon a termination that arrived during compilation is tried again, s.
RETRY_S = 0.05
_COMPILER = (f"{os.sep}numba{os.sep}", f"{os.sep}llvmlite{os.sep}")


def in_compiler(frame) -> bool:
    """Whether ``frame`` or a caller runs numba's or llvmlite's Python code (compiling a kernel, or in one of LLVM's
    callbacks into Python, where an exception cannot unwind and leaves LLVM broken: seen as a segfault when Ctrl-C
    arrived while a kernel compiled for the first time)."""
    while frame is not None:
        if any(part in frame.f_code.co_filename for part in _COMPILER):
            return True
        frame = frame.f_back
    return False


def check_file_destination(path: Path, option: str, overwrite: bool) -> None:
    """Refuse a file destination given as ``option`` (:class:`OutputError`): a folder, an existing file without
    ``overwrite``, a place in a folder that does not exist (none is created) or cannot be written to."""
    if path.is_dir():
        raise OutputError(f"{option} {path}: is a folder, not a file")
    if (path.exists() or path.is_symlink()) and not overwrite:
        raise OutputError(f"{option} {path}: the file exists; add --overwrite to replace it")
    _check_parent(path, option)


def _check_parent(path: Path, option: str) -> None:
    """Refuse ``path`` whose folder does not exist (none is created) or cannot be written to."""
    parent = path.absolute().parent
    if not parent.is_dir():
        raise OutputError(f"{option} {path}: no folder {parent}")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputError(f"{option} {path}: cannot write in {parent}")


def _dangling(path: Path, option: str) -> OutputError | None:
    """The refusal of ``path`` when it is a symbolic link that leads nowhere (None otherwise)."""
    if path.is_symlink() and not path.exists():
        return OutputError(f"{option} {path}: a symbolic link to {os.readlink(path)}, which does not exist, is "
                           "there; remove the link or choose another place")
    return None


def check_new_destination(path: Path, option: str = "--out", rule: str = "what is there is never replaced") -> None:
    """Refuse ``path`` when something is there already, a symbolic link that leads nowhere included, or when its
    folder does not exist or cannot be written to (:class:`OutputError` naming it; ``rule`` says why something there
    is refused)."""
    dangling = _dangling(path, option)
    if dangling is not None:
        raise dangling
    if os.path.lexists(path):
        raise OutputError(f"{option} {path}: something is already there ({rule})")
    _check_parent(path, option)


def check_destination(out: Path, overwrite: bool) -> None:
    """Refuse ``out`` when it cannot receive a run: a file, a symbolic link that leads nowhere, a non-empty folder
    that is not an earlier run (or is one and ``overwrite`` is off), or a place the user cannot write to."""
    dangling = _dangling(out, "--out")
    if dangling is not None:
        raise dangling
    if out.exists() and not out.is_dir():
        raise OutputError(f"--out {out}: a file is there, not a folder")
    if out.is_dir() and any(out.iterdir()):
        if earlier_run_files(out) is None:
            raise OutputError(f"--out {out}: the folder is not empty and holds no swarmtrack run "
                              f"(no {MANIFEST} written by swarmtrack); choose another folder")
        if not overwrite:
            raise OutputError(f"--out {out}: holds an earlier run; add --overwrite to replace its files "
                              "(only those its manifest lists)")
    parent = _existing_parent(out)
    if not parent.is_dir():
        raise OutputError(f"--out {out}: {parent} is a file, so no folder can be made inside it")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputError(f"--out {out}: cannot write in {parent}")


def earlier_run_files(out: Path) -> list[str] | None:
    """The files a swarmtrack run wrote in ``out``, from its manifest; None when ``out`` holds no manifest that
    swarmtrack wrote (another tool's ``manifest.json`` is not ours to act on). Entries that would leave ``out``
    (absolute, ``..``) are never listed."""
    try:
        manifest = json.loads((out / MANIFEST).read_text())
    except (OSError, UnicodeDecodeError, ValueError):
        return None
    if not (isinstance(manifest, dict) and str(manifest.get("written_by", "")).startswith("swarmtrack ")
            and isinstance(manifest.get("files"), list)):
        return None
    return [f for f in manifest["files"] if isinstance(f, str) and not Path(f).is_absolute()
            and ".." not in Path(f).parts]


def _no_link_on_the_way(out: Path, rel: str) -> bool:
    """Whether ``out/rel`` is reached without a symbolic link: neither it nor a folder between ``out`` and it is
    one, so deleting it cannot reach outside ``out`` (a user may have put a link where the earlier run had a
    folder)."""
    path = out
    for part in Path(rel).parts:
        path = path / part
        if path.is_symlink():
            return False
    return True


def _existing_parent(path: Path) -> Path:
    path = path.absolute()
    while not path.exists():
        path = path.parent
    return path


def _process_start(pid: int) -> int | None:
    """When process ``pid`` started (clock ticks after boot, ``/proc/<pid>/stat``), None where it cannot be read."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
        return int(stat[stat.rindex(")") + 2:].split()[19])  # field 22, after the command name in parentheses
    except (OSError, ValueError, IndexError):
        return None


def _running(pid: int, started: int | None) -> bool:
    """Whether process ``pid`` (started at ``started``, when known) still runs on this host."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass  # another user's process: running
    now = _process_start(pid)
    return started is None or now is None or now == started  # another start time: the id was given again


def _staging_marker(out: Path) -> dict:
    return {"written_by": version(), "out": str(out), "host": socket.gethostname(), "pid": os.getpid(),
            "started": _process_start(os.getpid())}


def clean_stale_staging(out: Path, note: Callable[[str], None] | None = None) -> list[Path]:
    """Remove the staging folders beside ``out`` that earlier runs into ``out`` left when they were killed, and
    only those: a hidden ``.<name>.*.partial`` folder (not a link) whose marker (:data:`STAGING_MARKER`) names
    ``out`` and this host, and a process that no longer runs. Any other staging folder of ``out`` (another host's,
    one without a marker, one that cannot be removed) is left as it is and ``note`` says so (default: a line on
    stderr); one of a run still going is left silently. Returns the folders removed."""
    note = note or (lambda text: print(text, file=sys.stderr))
    removed = []
    for path in sorted(out.parent.glob(f".{glob.escape(out.name)}.*.partial")):
        if path.is_symlink() or not path.is_dir():
            continue
        try:
            marker = json.loads((path / STAGING_MARKER).read_text())
            pid, host, started = int(marker["pid"]), str(marker["host"]), marker.get("started")
            mine = marker["out"] == str(out)
        except (OSError, UnicodeDecodeError, ValueError, KeyError, TypeError):
            note(f"note: {path} looks like the staging folder of a run into {out} but holds no marker of "
                 "swarmtrack's; it was left as it is (remove it once no run writes there)")
            continue
        if not mine:
            continue  # another folder's, whose name begins as this one's
        if host != socket.gethostname():
            note(f"note: {path} is the staging folder of a run into {out} by process {pid} on {host}; it was left "
                 "as it is (remove it once that run is over)")
            continue
        if _running(pid, started if isinstance(started, int) else None):
            continue
        try:
            shutil.rmtree(path)
        except OSError as exc:
            note(f"note: {path}, left by an earlier run into {out} (process {pid}, gone), could not be removed: "
                 f"{exc.strerror or exc}")
            continue
        removed.append(path)
        note(f"removed {path}: the staging folder an earlier run into {out} left when it was stopped (process {pid}, "
             "gone)")
    return removed


@contextmanager
def run_folder(out: Path, overwrite: bool = False):
    """Stage a run's files in a hidden sibling of ``out`` and move them into ``out`` when the block ends
    normally; on any interruption the staging folder is removed (a run that is killed leaves it, marked; the next
    run into ``out`` removes it: :func:`clean_stale_staging`). Yields the staging folder; files written there are
    listed in ``out/manifest.json``."""
    out = out.absolute()
    check_destination(out, overwrite)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        clean_stale_staging(out)
        tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".partial", dir=out.parent))
    except OSError as exc:
        raise OutputError(f"--out {out}: {exc.strerror or exc}") from None
    try:
        try:
            (tmp / STAGING_MARKER).write_text(dump_json(_staging_marker(out)))
        except OSError as exc:
            raise OutputError(f"--out {out}: {exc.strerror or exc}") from None
        with terminate_as_exception():
            yield tmp
            marker = tmp / STAGING_MARKER
            files = sorted(str(p.relative_to(tmp)) for p in tmp.rglob("*") if p.is_file() and p != marker)
            (tmp / MANIFEST).write_text(dump_json({"written_by": version(), "files": files}))
            with signals_held():  # the move is not interrupted halfway
                marker.unlink(missing_ok=True)  # the run's folder does not keep it (the run may have removed it)
                _move_into_place(tmp, out, files, overwrite)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _filled_meanwhile(out: Path) -> OutputError:
    return OutputError(f"--out {out}: another run wrote its files there while this one ran (it was free when this "
                       "run started); they were left as they are and this run's files were not kept; run again with "
                       "another --out, or add --overwrite to replace that run")


def _place_exclusively(tmp: Path, out: Path, rels: list[str]) -> None:
    """Put the staged files ``rels`` into the existing folder ``out`` without replacing anything: each is linked in
    (copied when ``out`` is on another file system), and a file that is already there (another run's, arrived
    meanwhile) stops the move: what this run placed, and only that, is removed again, and the run is refused."""
    placed: list[tuple[Path, int]] = []  # each file this run created, with its inode
    made: list[Path] = []
    try:
        for rel in rels:
            dst = out / rel
            for folder in reversed(Path(rel).parents[:-1]):
                try:
                    (out / folder).mkdir()
                    made.append(out / folder)
                except FileExistsError:
                    pass  # there already (made by this loop, or not ours: never removed)
            try:
                os.link(tmp / rel, dst)
                placed.append((dst, os.stat(dst).st_ino))
            except OSError as exc:
                if exc.errno != errno.EXDEV:
                    raise
                with open(tmp / rel, "rb") as src, open(dst, "xb") as copy:
                    placed.append((dst, os.fstat(copy.fileno()).st_ino))  # ours from its creation, even half-copied
                    shutil.copyfileobj(src, copy)
    except OSError as exc:
        for path, inode in placed:  # only the files this run created, still the same files
            with contextlib.suppress(OSError):
                if os.stat(path).st_ino == inode:
                    path.unlink()
        for folder in reversed(made):
            with contextlib.suppress(OSError):
                folder.rmdir()
        if isinstance(exc, FileExistsError):
            raise _filled_meanwhile(out) from None
        raise OutputError(f"--out {out}: {exc.strerror or exc}") from None


def _move_into_place(tmp: Path, out: Path, files: list[str], overwrite: bool = True) -> None:
    """Move the staged run into ``out``: a rename when ``out`` does not exist (it fails, and nothing is replaced,
    if another run's folder got there first); into an existing empty ``out`` (the user's folder, left in place)
    file by file without replacing anything (:func:`_place_exclusively`); else, with ``overwrite``, the earlier
    run's files (and only those, regular files, not links) are deleted and the new ones moved in. Without
    ``overwrite`` a destination that filled since :func:`check_destination` is refused (:class:`OutputError`). A new
    file whose place is taken by something the earlier run did not write is refused before anything changes."""
    if not out.exists():
        try:
            tmp.rename(out)  # atomic; fails if another run's folder appeared meanwhile
        except OSError as exc:
            if out.is_dir() and any(out.iterdir()):
                raise _filled_meanwhile(out) from None
            raise OutputError(f"--out {out}: {exc.strerror or exc}") from None
        return
    if not any(out.iterdir()):
        _place_exclusively(tmp, out, [*files, MANIFEST])
        return
    if not overwrite:
        raise _filled_meanwhile(out)
    old = earlier_run_files(out) or []  # checked by check_destination
    ours = set(old) | {MANIFEST}
    taken = [f for f in files if f not in ours and (out / f).exists()]
    if taken:
        raise OutputError(f"--out {out}: {taken[0]} is there and was not written by the earlier run; "
                          "move it or choose another folder")
    linked = [f for f in files if not _no_link_on_the_way(out, f)]
    if linked:
        raise OutputError(f"--out {out}: {linked[0]} would be written through a symbolic link the earlier run "
                          "did not make; remove the link or choose another folder")
    for rel in old:
        target = out / rel
        if _no_link_on_the_way(out, rel) and target.is_file():
            target.unlink()
    for rel in sorted({str(Path(r).parent) for r in old} - {"."}, key=len, reverse=True):
        folder = out / rel
        if _no_link_on_the_way(out, rel) and folder.is_dir() and not any(folder.iterdir()):
            folder.rmdir()  # a folder the earlier run made and left empty
    for rel in [*files, MANIFEST]:
        dst = out / rel
        dst.parent.mkdir(parents=True, exist_ok=True)
        os.replace(tmp / rel, dst)
