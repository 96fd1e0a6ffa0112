"""Writing outputs: a folder replaced whole, files replaced together, CSV in one format.

Nothing partial is left behind on failure, and an existing folder is replaced only when it is
one that inertiafit wrote (it holds the marker file), so a mistyped ``--out`` cannot wipe a
folder of someone's data. Both writers stage everything in a temporary sibling first.
"""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pandas as pd

from inertiafit.errors import InputError

__all__ = ["MARKER", "check_replaceable", "output_folder", "replace_files", "write_csv"]

MARKER = ".inertiafit-output"


def check_replaceable(out: Path) -> None:
    """Refuse an ``out`` that is a file, or a non-empty folder inertiafit did not write."""
    if out.exists():
        if not out.is_dir():
            raise InputError(f"out: {out} exists and is not a folder")
        if any(out.iterdir()) and not (out / MARKER).exists():
            raise InputError(
                f"out: folder {out} exists, is not empty and was not written by inertiafit; "
                "choose a new folder"
            )


@contextmanager
def _staging(parent: Path, prefix: str) -> Iterator[Path]:
    """A temporary folder inside ``parent``, removed if it still exists afterwards."""
    tmp = Path(tempfile.mkdtemp(prefix=prefix, dir=parent))
    try:
        yield tmp
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@contextmanager
def output_folder(out: str | Path) -> Iterator[Path]:
    """Yield a temporary folder; on success it replaces ``out``, on error it is removed."""
    out = Path(out)
    check_replaceable(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with _staging(out.parent, f".{out.name}.") as tmp:
        yield tmp
        (tmp / MARKER).write_text("written by inertiafit; the whole folder is replaced on rerun\n")
        if out.exists():
            shutil.rmtree(out)
        tmp.rename(out)


@contextmanager
def replace_files(folder: str | Path) -> Iterator[Path]:
    """Yield a temporary folder inside ``folder``; its files then replace their namesakes.

    On success every file of the temporary folder replaces its namesake in ``folder``; on
    error nothing in ``folder`` changes.
    """
    folder = Path(folder)
    with _staging(folder, ".report-") as tmp:
        yield tmp
        for path in sorted(tmp.iterdir()):
            shutil.move(path, folder / path.name)


def write_csv(frame: pd.DataFrame, path: str | Path) -> Path:
    """A table as CSV in inertiafit's one format (``%.8g``, LF): same data, same bytes."""
    path = Path(path)
    frame.to_csv(path, index=False, float_format="%.8g", lineterminator="\n")
    return path
