"""Writing an output folder whole: into a temporary sibling, then renamed into place.

Nothing partial is left behind on failure, and an existing folder is replaced only when it is
one that inertiafit wrote (it holds the marker file), so a mistyped ``--out`` cannot wipe a
folder of someone's data.
"""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from inertiafit.errors import InputError

MARKER = ".inertiafit-output"


def check_replaceable(out: Path) -> None:
    """Refuse an ``out`` that is a file, or a non-empty folder inertiafit did not write."""
    if out.exists():
        if not out.is_dir():
            raise InputError(f"--out {out}: exists and is not a folder")
        if any(out.iterdir()) and not (out / MARKER).exists():
            raise InputError(
                f"--out {out}: folder exists, is not empty and was not written by inertiafit; "
                "choose a new folder"
            )


@contextmanager
def output_folder(out: str | Path) -> Iterator[Path]:
    """Yield a temporary folder; on success it replaces ``out``, on error it is removed."""
    out = Path(out)
    check_replaceable(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        yield tmp
        (tmp / MARKER).write_text("written by inertiafit; the whole folder is replaced on rerun\n")
        if out.exists():
            shutil.rmtree(out)
        tmp.rename(out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
