"""Writing outputs: the output folder checked, claimed and replaced whole; CSV in one format.

The rules of an output folder (``--out``), which every command that writes one follows:

- **Checked before any work** (:func:`check_out`): ``out`` may not be a file, the current
  folder or one of its ancestors, or a folder holding an input of the run (manifest, trial
  files, pilot folder, prior or design file); its parent must be writable. A symlink is
  followed: its target is checked and replaced, and the link is kept.
- **Only inertiafit's own outputs are ever replaced** (:func:`check_replaceable`): an existing
  folder is replaced only when it is empty, or when every entry in it is listed, with its size,
  in its marker file :data:`MARKER`, which inertiafit writes into every output folder. A file
  someone added or changed, or a folder of an older inertiafit whose marker lists nothing, is
  refused with one line naming it. A subfolder that is an output folder of its own (``export
  --out <results>/exp``) is inertiafit's too when it passes the same check by its own marker.
- **One run at a time per folder**: the check claims ``out`` with a lock file beside it,
  ``.<name>.lock``, holding the process id and host of the run; another run is refused while
  it is held. A lock left by a process that has died on this host is taken over. The claim is
  released when the output is written, or when the command decorated with
  :func:`guard_outputs` ends.
- **Replacing is a swap** (:func:`output_folder`): everything is written into a staging folder
  beside ``out``; then the old folder is renamed aside, the staging folder renamed to ``out``
  and the old folder removed last. A failure at any step leaves one whole folder, old or new,
  at ``out``; an old folder that cannot be removed afterwards (a read-only subfolder) is left
  aside with a one-line warning, and the new outputs stay.
- **Paths written are final paths** (:func:`final_text`): while a staging folder is written,
  a path into it (a study simulated inside the output, as ``inertiafit demo`` does) is written
  as the path it will have once the folder is swapped in; the staging name never outlives it.
- **Nothing partial is left behind**: a staging folder is removed on any error, on Ctrl-C and
  on SIGTERM (which ends the command as an error does while it runs). One left by a run that
  was killed outright (SIGKILL, a power cut) is removed, with a warning naming it, by the next
  run that claims the same folder: holding the lock, no live run can be writing it.

:func:`replace_files` (``inertiafit report``) redraws files of an existing folder with the same
swap: the folder is copied, the new files replace their namesakes in the copy, and the copy
replaces the folder whole, so a failure half-way leaves the old complete set.
"""

from __future__ import annotations

import atexit
import functools
import json
import os
import re
import secrets
import shutil
import socket
import sys
import tempfile
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from inertiafit._checks import unnameable
from inertiafit.errors import InputError
from inertiafit.io.stops import signals_held, sigterm_ends, stop_point

__all__ = [
    "MARKER",
    "check_as_written",
    "check_out",
    "check_replaceable",
    "final_path",
    "final_text",
    "guard_outputs",
    "holds_only",
    "output_folder",
    "replace_files",
    "write_csv",
]

#: Name of the marker file of an output folder: a JSON object whose ``files`` lists every
#: entry inertiafit wrote (relative POSIX paths; a file with its size in bytes, an empty
#: folder as ``"name/"`` with ``null``).
MARKER = ".inertiafit-output"
_ABOUT = "written by inertiafit; replaced whole on rerun while it holds only the files listed"
#: Longest folder name allowed: the staging, aside and lock names add up to 26 bytes to it.
_MAX_NAME = 255 - 32


# -- the marker ------------------------------------------------------------------------------


def _listing(folder: Path) -> dict[str, int | None]:
    """Every entry of ``folder`` but the marker: files (and symlinks) with sizes, empty folders."""

    def fail(err: OSError) -> None:
        raise InputError(f"out: cannot read {err.filename} ({err.strerror})")

    entries: dict[str, int | None] = {}
    for root, dirs, files in os.walk(folder, onerror=fail):
        here = Path(root)
        rel = here.relative_to(folder)
        for name in list(dirs):
            if (here / name).is_symlink():  # listed as a file, never followed
                dirs.remove(name)
                files.append(name)
        for name in files:
            entries[(rel / name).as_posix()] = (here / name).lstat().st_size
        if not dirs and not files and rel != Path("."):
            entries[rel.as_posix() + "/"] = None
    entries.pop(MARKER, None)
    return entries


def _read_marker(folder: Path) -> dict[str, int | None] | None:
    """The entries a marker lists; ``None`` for a marker that lists none (an older one)."""
    try:
        doc = json.loads((folder / MARKER).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError):
        return None
    files = doc.get("files") if isinstance(doc, dict) else None
    return dict(files) if isinstance(files, dict) else None


def _write_marker(folder: Path, files: dict[str, int | None]) -> None:
    doc = {"about": _ABOUT, "files": dict(sorted(files.items()))}
    (folder / MARKER).write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")


def check_as_written(folder: str | Path, names: Iterable[str]) -> None:
    """Refuse a data file of an output folder whose size is not the one its marker lists.

    ``inertiafit report`` redraws figures and tables from the data files of a folder; a
    truncated or edited ``traces.csv`` would be drawn without a word. A file the marker does not
    list (a folder of an older inertiafit, a file never written) is not checked.
    """
    folder = Path(folder)
    listed = _read_marker(folder) or {}
    for name in names:
        path = folder / name
        expected = listed.get(name)
        if expected is None or not path.is_file():
            continue
        size = path.stat().st_size
        if size != expected:
            raise InputError(
                f"{path}: {size} bytes where inertiafit wrote {expected}: changed or truncated "
                "since it was written; rerun the analysis to rebuild it"
            )


def check_replaceable(out: str | Path) -> None:
    """Refuse an ``out`` that is a file, or a folder holding anything inertiafit did not write.

    A folder may be replaced when it does not exist, is empty, or every entry in it is listed,
    with its present size, in its marker :data:`MARKER`. A folder whose marker lists nothing
    (written by an older inertiafit) is refused: what else it holds cannot be told. A subfolder
    the marker does not list but that holds a marker of its own (an ``export --out
    <results>/exp``) is inertiafit's when it passes this same check; it is replaced with the rest.

    Raises
    ------
    InputError
        One line naming the folder and the first entry at fault.
    """
    out = Path(out)
    if not out.exists():
        return
    if not out.is_dir():
        raise InputError(f"out: {out} exists and is not a folder")
    present = _listing(out)
    if not present:
        return
    if not (out / MARKER).exists():
        raise InputError(
            f"out: folder {out} exists, is not empty and was not written by inertiafit; "
            "choose a new folder"
        )
    listed = _read_marker(out)
    if listed is None:
        raise InputError(
            f"out: folder {out} was written by an older inertiafit that did not list its files, "
            "so it may hold files of yours; delete it yourself or choose a new folder"
        )
    nested: list[str] = []  # unlisted subfolders that are output folders of their own
    for entry, size in sorted(present.items()):
        if any(entry.startswith(folder) for folder in nested):
            continue
        if entry not in listed:
            parts = entry.split("/")
            tops = ["/".join(parts[:i]) + "/" for i in range(1, len(parts))]
            # a whole folder of someone else's is named as such
            foreign = [t for t in tops if not any(name.startswith(t) for name in listed)]
            if foreign and (out / foreign[0] / MARKER).is_file():
                check_replaceable(out / foreign[0])  # names what in it is not inertiafit's
                nested.append(foreign[0])
                continue
            found = (foreign or [entry])[0]
            left = _LEFT_BEHIND.fullmatch(found.rstrip("/"))
            if left:  # a run into a subfolder (an export) killed before it cleaned up
                raise InputError(
                    f"out: folder {out} holds {found}, left by a run into {out / left['name']} "
                    "that was killed; run that command again (it removes it) or delete "
                    f"{found} yourself"
                )
            raise InputError(
                f"out: folder {out} holds {found}, which inertiafit did not "
                "write; move it out of the folder or choose a new folder"
            )
        if listed[entry] != size:
            raise InputError(
                f"out: {out / entry} has changed since inertiafit wrote it; "
                "move it out of the folder or choose a new folder"
            )


def holds_only(out: str | Path, names: Iterable[str]) -> bool:
    """Whether ``out`` is missing, empty, or holds nothing of inertiafit's but ``names``.

    A refused run writes its ``diagnostics.csv`` into ``out`` only then: an earlier run's
    complete outputs are never replaced by the table of a run that failed. Call it after
    :func:`check_out` (which refuses a folder holding anything inertiafit did not write).
    """
    target = _resolve(out)
    if not target.is_dir():
        return not target.exists()
    return set(_listing(target)) <= set(names)


# -- checks before any work, and the lock ----------------------------------------------------


@dataclass
class _Claim:
    """A folder this process has claimed: its lock file and the parents made for it."""

    lock: Path
    token: str
    made: list[Path] = field(default_factory=list)
    writing: bool = False


#: Folders claimed by this process (resolved path -> claim).
_CLAIMS: dict[Path, _Claim] = {}


def _resolve(out: str | Path, label: str = "out: ") -> Path:
    text = os.fspath(out)
    if "\0" in text:
        raise InputError(f"{label}the path holds a NUL character; expected a folder path")
    try:
        target = Path(text).expanduser().resolve()
        size = len(os.fsencode(target.name))
    except (OSError, RuntimeError) as exc:
        raise InputError(f"{label}{text}: cannot follow the path ({exc})") from None
    except UnicodeEncodeError as exc:
        raise InputError(
            f"{label}{text!r}: {unnameable(exc)}; choose another name or run in a UTF-8 locale"
        ) from None
    if size > _MAX_NAME:
        raise InputError(
            f"{label}folder name too long ({size} bytes; expected at most {_MAX_NAME})"
        )
    if target.is_symlink():  # resolve() stops at a loop
        raise InputError(
            f"{label}{text} is a symlink that leads nowhere (a loop); expected a folder"
        )
    return target


def _check_place(
    out: str | Path, target: Path, inputs: Iterable[str | Path | None], label: str = "out: "
) -> None:
    """Where ``out`` may be: not the current folder's, not an input's, not a file's."""
    try:
        cwd = Path.cwd().resolve()
    except OSError:  # the current folder was removed: nothing to protect there
        cwd = None
    if cwd is not None and cwd.is_relative_to(target):
        raise InputError(
            f"{label}{out} is the current folder or holds it, and an output folder is replaced "
            "whole; choose another folder (or run from outside it)"
        )
    for item in inputs:
        if item is None or "\0" in os.fspath(item):
            continue
        try:
            path = Path(item).expanduser().resolve()
        except (OSError, RuntimeError):
            continue
        if path.is_relative_to(target):
            how = "is" if path == target else "holds"
            raise InputError(
                f"{label}{out} {how} the input {item} of this run, and an output folder is "
                "replaced whole; choose an output folder outside the inputs"
            )
    if target.exists() and not target.is_dir():
        raise InputError(f"{label}{out} exists and is not a folder")
    above = target.parent
    while not above.exists():
        above = above.parent
    if not above.is_dir():
        raise InputError(f"{label}{above} is a file, not a folder; expected a folder path")


def _alive(pid: int) -> bool:
    """Whether process ``pid`` of this host is running (unknown counts as running)."""
    if pid <= 0:
        return False
    if sys.platform == "win32":  # os.kill(pid, 0) would end the process there
        import ctypes

        kernel32 = ctypes.windll.kernel32  # type: ignore[attr-defined]
        handle = kernel32.OpenProcess(0x1000, False, pid)  # PROCESS_QUERY_LIMITED_INFORMATION
        if not handle:
            return False
        code = ctypes.c_ulong()
        kernel32.GetExitCodeProcess(handle, ctypes.byref(code))
        kernel32.CloseHandle(handle)
        return code.value == 259  # STILL_ACTIVE
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # another user's process
        return True
    return True


def _stale(lock: Path, text: str) -> bool:
    """A lock whose process has died on this host (or an empty one a minute old)."""
    parts = text.split()
    if len(parts) < 2 or not parts[0].isdigit():
        try:
            return time.time() - lock.stat().st_mtime > 60
        except OSError:
            return True
    return parts[1] == socket.gethostname() and not _alive(int(parts[0]))


def _held(out: str | Path, lock: Path, text: str, label: str) -> InputError:
    parts = text.split()
    who = f"process {parts[0]} on {parts[1]}" if len(parts) >= 2 else "another run"
    return InputError(
        f"{label}{out} is being written by another inertiafit run ({who}; lock {lock}); "
        "wait for it to finish, or delete the lock file if no run is going"
    )


def _make_parents(folder: Path, label: str) -> list[Path]:
    missing = []
    while not folder.exists():
        missing.append(folder)
        folder = folder.parent
    made: list[Path] = []
    for path in reversed(missing):
        try:
            path.mkdir()
        except FileExistsError:
            continue
        except OSError as exc:
            _remove_empty(made)
            raise InputError(f"{label}cannot create the folder {path} ({exc.strerror})") from None
        made.append(path)
    return made


def _remove_empty(folders: list[Path]) -> None:
    for path in reversed(folders):
        try:
            path.rmdir()
        except OSError:
            return


def _claim(out: str | Path, target: Path, label: str = "out: ") -> None:
    """Claim ``target`` for this process with its lock file (created with ``O_EXCL``)."""
    if target in _CLAIMS:
        if _CLAIMS[target].writing:
            raise InputError(f"{label}{out} is being written by this process already")
        return
    made = _make_parents(target.parent, label)
    lock = target.parent / f".{target.name}.lock"
    token = f"{os.getpid()} {socket.gethostname()} {secrets.token_hex(4)}\n"
    for _ in range(5):
        try:
            fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            try:
                text = lock.read_text(encoding="utf-8", errors="replace")
            except FileNotFoundError:  # released meanwhile
                continue
            except OSError:
                text = ""
            if not _stale(lock, text):
                _remove_empty(made)
                raise _held(out, lock, text, label) from None
            # Taken over by renaming it away: only one run can move a given file.
            grave = lock.with_name(f"{lock.name}.{secrets.token_hex(4)}")
            try:
                os.rename(lock, grave)
            except OSError:
                continue
            moved = grave.read_text(encoding="utf-8", errors="replace")
            if moved != text:  # another run's fresh lock: put it back
                try:
                    os.link(grave, lock)
                finally:
                    grave.unlink()
                _remove_empty(made)
                raise _held(out, lock, moved, label) from None
            grave.unlink()
            continue
        except OSError as exc:
            _remove_empty(made)
            raise InputError(
                f"{label}cannot write in {target.parent} ({exc.strerror}); "
                "choose a folder you can write to"
            ) from None
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(token)
        _CLAIMS[target] = _Claim(lock, token, made)
        _remove_leftovers(target)
        return
    raise _held(out, lock, "", label)


#: What a run into ``<name>`` leaves beside it when killed outright: its staging folder and
#: its lock (:func:`_leftovers`), as the entries of the parent folder they sit in.
_STAGING_SUFFIX = r"(?:new|draw)-[a-z0-9_]{8}"  # eight of mkdtemp's characters
_LEFT_BEHIND = re.compile(rf"\.(?P<name>.+)\.(?:{_STAGING_SUFFIX}|lock)")


def _leftovers(target: Path) -> list[Path]:
    """The staging folders of ``target`` beside it, by the names :func:`_staging` gives them.

    Only real folders named ``.<name>.new-XXXXXXXX`` or ``.<name>.draw-XXXXXXXX`` (eight of
    ``mkdtemp``'s characters); never a folder moved aside by a swap (``.old-``), which may hold
    the only copy of the old outputs.
    """
    pattern = re.compile(rf"\.{re.escape(target.name)}\.{_STAGING_SUFFIX}")
    # Names first, from os.scandir: a Path per entry cost 2.6 s in a folder of 250 000 (/tmp).
    try:
        with os.scandir(target.parent) as entries:
            found = [
                entry.path
                for entry in entries
                if pattern.fullmatch(entry.name) and entry.is_dir(follow_symlinks=False)
            ]
    except OSError:
        return []
    return sorted(Path(path) for path in found)


def _remove_leftovers(target: Path) -> None:
    """Remove the staging folders of ``target`` left by runs killed outright, each named.

    Called with ``target``'s lock just taken: every run writes its staging folder only while it
    holds the lock and removes it before letting go, so one found now belongs to no live run.
    """
    for path in _leftovers(target):
        try:
            shutil.rmtree(path)
        except OSError as exc:
            _warn(
                f"{path} is left from a run into {target} that was killed, and could not be "
                f"removed ({exc.strerror or exc}); delete that folder yourself"
            )
        else:
            _warn(f"removed {path}, left unfinished by a run into {target} that was killed")


def _release(target: Path, *, written: bool = False) -> None:
    """Remove this process's lock of ``target`` (and the parents made for it if unused)."""
    claim = _CLAIMS.pop(target, None)
    if claim is None:
        return
    try:
        if claim.lock.read_text(encoding="utf-8") == claim.token:
            claim.lock.unlink()
    except OSError:
        pass
    if not written:
        _remove_empty(claim.made)


@atexit.register
def _release_all() -> None:
    for target in list(_CLAIMS):
        _release(target)


def check_out(out: str | Path, *, inputs: Iterable[str | Path | None] = ()) -> Path:
    """Check an output folder before any work, and claim it for this run.

    Parameters
    ----------
    out : path
        The output folder (``--out``); a symlink is followed to its target.
    inputs : paths
        The run's input files and folders (``None`` items are skipped): ``out`` may not be
        one of them or hold one.

    Returns
    -------
    Path
        The folder, resolved.

    Raises
    ------
    InputError
        One line: ``out`` is a file, the current folder or an ancestor of it, holds an input,
        holds anything inertiafit did not write (:func:`check_replaceable`), is in a folder
        that cannot be written, or is being written by another run (its lock is held).
    """
    target = _resolve(out)
    _check_place(out, target, inputs)
    _claim(out, target)
    try:
        check_replaceable(target)
    except BaseException:
        _release(target)
        raise
    return target


def guard_outputs[**P, R](func: Callable[P, R]) -> Callable[P, R]:
    """Decorate a command that writes an output folder: it can be ended cleanly.

    While it runs, SIGTERM ends it as an error does (``SystemExit`` with status 143), so
    staging folders are removed, even where Python swallowed that exception
    (:mod:`inertiafit.io.stops`); when it ends, every folder it claimed with :func:`check_out`
    and did not write is released (its lock removed).
    """

    @functools.wraps(func)
    def guarded(*args: P.args, **kwargs: P.kwargs) -> R:
        before = set(_CLAIMS)
        try:
            with sigterm_ends():
                done = func(*args, **kwargs)
                stop_point()  # a SIGTERM whose exception Python swallowed still ends it
                return done
        finally:
            for target in set(_CLAIMS) - before:
                _release(target)

    return guarded


# -- staging and the swap --------------------------------------------------------------------

#: Each staging folder being written now -> the folder it becomes when swapped in, in the
#: order they were made (an output folder staged inside another's staging folder comes later).
_STAGED: dict[Path, Path] = {}


def final_text(text: str) -> str:
    """``text`` with every staging folder being written now named by its final folder.

    A path written into an output file while its folder is staged (the manifest of a study
    simulated inside the output, a trial file's path in the provenance) would otherwise name a
    folder that is gone once the staging folder is renamed into place. Nested staging folders
    are resolved innermost first.
    """
    for tmp, target in reversed(_STAGED.items()):
        text = text.replace(str(tmp), str(target))
    return text


def final_path(path: str | Path) -> Path:
    """``path`` as it will be once the output folders being written now are swapped in."""
    return Path(final_text(os.fspath(path)))


@contextmanager
def _staged_as(tmp: Path, target: Path) -> Iterator[Path]:
    """Register ``tmp`` as the staging folder of ``target`` for :func:`final_text`."""
    _STAGED[tmp] = target
    try:
        yield tmp
    finally:
        _STAGED.pop(tmp, None)


@contextmanager
def _staging(parent: Path, prefix: str) -> Iterator[Path]:
    """A temporary folder inside ``parent``, removed if it still exists afterwards.

    It gets the permissions of a folder made by ``mkdir`` (``mkdtemp`` makes it private).
    """
    tmp = Path(tempfile.mkdtemp(prefix=prefix, dir=parent))
    try:
        mask = os.umask(0o022)
        os.umask(mask)
        tmp.chmod(0o777 & ~mask)
        yield tmp
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _warn(message: str) -> None:
    print(f"inertiafit: warning: {' '.join(message.split())}", file=sys.stderr)


def _swap(new: Path, target: Path, out: str | Path, label: str = "out: ") -> None:
    """Put the complete folder ``new`` at ``target``: old aside, new in, old removed last."""
    with signals_held():
        if not target.exists():
            try:
                os.rename(new, target)
            except OSError as exc:
                raise InputError(
                    f"{label}could not put the new outputs at {out} ({exc.strerror})"
                ) from None
            return
        aside = target.with_name(f".{target.name}.old-{secrets.token_hex(4)}")
        try:
            os.rename(target, aside)
        except OSError as exc:
            raise InputError(
                f"{label}could not move {out} aside to replace it ({exc.strerror}); it is "
                "unchanged and the new outputs were discarded"
            ) from None
        try:
            os.rename(new, target)
        except OSError as exc:
            try:
                os.rename(aside, target)
            except OSError:
                raise InputError(
                    f"{label}could not put the new outputs at {out} ({exc.strerror}); the old "
                    f"outputs are whole in {aside}"
                ) from None
            raise InputError(
                f"{label}could not put the new outputs at {out} ({exc.strerror}); it is "
                "unchanged and the new outputs were discarded"
            ) from None
    try:
        shutil.rmtree(aside)
    except OSError as exc:
        _warn(
            f"the new outputs are in {out}, but the old ones moved aside to {aside} could not "
            f"all be removed ({exc.strerror or exc}); delete that folder yourself"
        )


@contextmanager
def output_folder(out: str | Path) -> Iterator[Path]:
    """Yield a staging folder; on success it replaces ``out`` whole, on error it is removed.

    ``out`` is checked and claimed (:func:`check_out`) unless this process claimed it already;
    the claim is released at the end. The marker listing every file written is added last.
    """
    target = _resolve(out)
    if target not in _CLAIMS:
        check_out(out)
    claim = _CLAIMS[target]
    if claim.writing:
        raise InputError(f"out: {out} is being written by this process already")
    claim.writing = True
    written = False
    try:
        with (
            sigterm_ends(),
            _staging(target.parent, f".{target.name}.new-") as staged,
            _staged_as(staged, target) as tmp,
        ):
            yield tmp
            stop_point()  # asked to stop (the exception swallowed): not swapped in
            _write_marker(tmp, _listing(tmp))
            check_replaceable(target)  # again: under the lock, nothing of yours appeared
            _swap(tmp, target, out)
            written = True
    finally:
        claim.writing = False
        _release(target, written=written)


@contextmanager
def replace_files(folder: str | Path) -> Iterator[Path]:
    """Yield a temporary folder; its files then replace their namesakes in ``folder``, together.

    ``folder`` must exist; it is checked and claimed as an output folder is (not the current
    folder, a writable parent, one run at a time) but may hold anything: it is copied whole
    beside itself, the new files replace their namesakes in the copy, and the copy replaces
    ``folder`` by the swap of :func:`output_folder`. On error nothing in ``folder`` changes.
    Its marker, if it lists files, then lists the new ones too (and nothing else new); a new
    file whose namesake is not listed, or has changed since it was written, is refused.
    """
    target = _resolve(folder, "")
    if not target.is_dir():
        raise InputError(f"{folder}: no such output folder")
    _check_place(folder, target, (), "")
    _claim(folder, target, "")
    claim = _CLAIMS[target]
    claim.writing = True
    written = False
    try:
        with (
            sigterm_ends(),
            _staging(target.parent, f".{target.name}.draw-") as drawing,
            _staging(target.parent, f".{target.name}.new-") as whole,
            _staged_as(drawing, target) as tmp,
            _staged_as(whole, target),
        ):
            yield tmp
            stop_point()
            drawn = _listing(tmp)
            try:
                shutil.copytree(target, whole, symlinks=True, dirs_exist_ok=True)
            except OSError as exc:
                raise InputError(
                    f"{folder}: could not copy the folder to redraw it whole "
                    f"({str(exc).splitlines()[0][:200]}); nothing changed"
                ) from None
            listed = _read_marker(whole)
            if listed is None:  # nothing tells inertiafit's files from the user's: keep them
                have = _listing(whole)
                tops = {name.split("/")[0] for name in drawn}
                clash = sorted({name.split("/")[0] for name in have} & tops)
                if clash:
                    shown = ", ".join(clash)
                    raise InputError(
                        f"{folder}: {shown} would be overwritten, and the folder has no "
                        f"{MARKER} to say inertiafit wrote them (a copied posterior.nc?); move "
                        "them out, or redraw in a folder holding only the data files"
                    )
            if listed is not None:  # a listing to tell inertiafit's files from others'
                have = _listing(whole)
                for name in sorted(drawn):
                    if name in have and listed.get(name, -1) != have[name]:
                        raise InputError(
                            f"{folder}: {name} was not written by inertiafit, or has changed "
                            "since, and would be overwritten; move it out of the folder"
                        )
            try:
                for path in sorted(tmp.iterdir()):
                    dest = whole / path.name
                    if dest.is_dir() and not dest.is_symlink():
                        shutil.rmtree(dest)
                    os.replace(path, dest)
            except OSError as exc:
                raise InputError(
                    f"{folder}: could not place the redrawn file {exc.filename} "
                    f"({exc.strerror}); nothing changed"
                ) from None
            if listed is not None:  # still only inertiafit's files listed
                now = _listing(whole)
                _write_marker(whole, {k: v for k, v in listed.items() if k in now} | drawn)
            _swap(whole, target, folder, "")
            written = True
    finally:
        claim.writing = False
        _release(target, written=written)


def write_csv(frame: pd.DataFrame, path: str | Path) -> Path:
    """A table as CSV in inertiafit's one format (``%.8g``, LF): same data, same bytes."""
    path = Path(path)
    frame.to_csv(path, index=False, float_format="%.8g", lineterminator="\n")
    return path
