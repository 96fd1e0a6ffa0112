"""Run a tutorial (``docs/tutorials/*.md``) as a reader would: every block, literally, in order.

A tutorial's fenced blocks are of three sorts, told by their language:

- **run**: ``python`` blocks are executed in one namespace (one Python session, as a reader
  pasting them into one would), their printed output kept; ``sh`` blocks are run by ``bash``
  as one script each (``-e``: the first failing command fails the block), with this
  environment's ``bin`` first on ``PATH`` (the ``inertiafit`` command of an activated
  environment);
- **saved**: a ``{code-block}`` directive with a ``:caption:`` is a file the reader saves
  under that name (the caption shows it), relative to the tutorial's folder: it is written
  there when the runner reaches it;
- **shown**: ``text``, ``console`` and ``toml`` blocks without a caption are displayed, not
  run (output listings, a manifest the tutorial's own code writes, a fragment); a test
  compares them with what the run made where the tutorial says they are that.

Any other language, and a fence without one, is an error: nothing is skipped silently.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

TUTORIALS = Path(__file__).parents[1] / "docs" / "tutorials"
#: Languages run, and languages only shown.
RUN = ("python", "sh")
SHOWN = ("text", "console", "toml")
#: A fence of three or more backticks, its info string and its body, up to the same fence.
FENCE = re.compile(
    r"^(?P<fence>`{3,})(?P<info>[^`\n]*)\n(?P<body>.*?)^(?P=fence)[ \t]*$",
    re.MULTILINE | re.DOTALL,
)
#: A MyST directive's info string: ``{code-block} toml``.
DIRECTIVE = re.compile(r"^\{(?P<name>[\w-]+)\}\s*(?P<argument>.*)$")
OPTION = re.compile(r"^:(?P<key>[\w-]+):\s*(?P<value>.*)$")


@dataclass(frozen=True)
class Block:
    """One fenced block: its language, its code, the file it is saved as, where it is."""

    language: str
    code: str
    line: int
    saved_as: str = ""

    @property
    def where(self) -> str:
        return f"line {self.line}"


def blocks(tutorial: Path, language: str | None = None) -> list[Block]:
    """Every fenced block of ``tutorial`` (or those of one language), in order.

    Raises ``ValueError`` for a block of a language neither run nor shown, a fence without a
    language and a ``{code-block}`` without a ``:caption:`` (what would it be saved as?).
    Other MyST directives (``{toctree}``) are not code and are left out.
    """
    text = tutorial.read_text(encoding="utf-8")
    out = []
    for match in FENCE.finditer(text):
        line = text.count("\n", 0, match.start()) + 1
        info, body = match["info"].strip(), match["body"]
        directive = DIRECTIVE.match(info)
        if directive and directive["name"] != "code-block":
            continue
        saved_as = ""
        if directive:
            info = directive["argument"].strip()
            options, _, body = body.partition("\n\n")
            for option in options.splitlines():
                found = OPTION.match(option.strip())
                if found is None:
                    msg = f"{tutorial.name}, line {line}: {{code-block}} option {option!r}"
                    raise ValueError(msg)
                if found["key"] == "caption":
                    saved_as = found["value"].strip()
            if not saved_as:
                msg = f"{tutorial.name}, line {line}: a {{code-block}} needs :caption: <file>"
                raise ValueError(msg)
        if not info:
            msg = f"{tutorial.name}, line {line}: a fence without a language"
            raise ValueError(msg)
        lang = info.split()[0]
        if not saved_as and lang not in RUN + SHOWN:
            msg = (
                f"{tutorial.name}, line {line}: language {lang!r} is neither run "
                f"({', '.join(RUN)}) nor shown ({', '.join(SHOWN)})"
            )
            raise ValueError(msg)
        if language in (None, lang):
            out.append(Block(lang, body, line, saved_as))
    return out


@dataclass
class Session:
    """What running a tutorial left: its folder, the Python namespace, each block's output.

    The outputs are also saved in the folder (``outputs.json``): :meth:`load` gives them to a
    process that did not run the tutorial (pytest-xdist's other worker), without a namespace.
    """

    folder: Path
    namespace: dict[str, Any] = field(default_factory=dict)
    outputs: list[tuple[Block, str]] = field(default_factory=list)

    OUTPUTS = "outputs.json"

    def save(self) -> None:
        records = [{"block": vars(b), "output": out} for b, out in self.outputs]
        (self.folder / self.OUTPUTS).write_text(json.dumps(records, indent=1), encoding="utf-8")

    @classmethod
    def load(cls, folder: Path) -> Session:
        records = json.loads((folder / cls.OUTPUTS).read_text(encoding="utf-8"))
        return cls(folder, outputs=[(Block(**r["block"]), r["output"]) for r in records])

    def output(self, language: str, k: int = -1) -> str:
        """The output of the ``k``-th run block of ``language`` (default the last)."""
        return [out for b, out in self.outputs if b.language == language][k]

    @property
    def log(self) -> str:
        return "\n".join(
            f"--- {b.language} block, {b.where}\n{b.code}\n--- output\n{out}"
            for b, out in self.outputs
        )


def shell_environment() -> dict[str, str]:
    """This environment's ``bin`` first on ``PATH`` and one BLAS thread, as in the suite."""
    env = dict(os.environ)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env.update(OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
    return env


def run_tutorial(tutorial: Path, folder: Path, *, timeout: float = 600) -> Session:
    """Run every block of ``tutorial`` in order in ``folder``; its log as ``tutorial.log``.

    A block that fails raises ``AssertionError`` naming the tutorial, the block's line and
    what it printed; the log written so far is in the folder.
    """
    session = Session(folder)
    env = shell_environment()
    try:
        with contextlib.chdir(folder):
            for block in blocks(tutorial):
                if block.saved_as:
                    target = Path(block.saved_as)
                    target.parent.mkdir(parents=True, exist_ok=True)
                    target.write_text(block.code, encoding="utf-8")
                    session.outputs.append((block, f"saved {block.saved_as}\n"))
                elif block.language == "python":
                    said = io.StringIO()
                    code = compile(block.code, f"{tutorial.name}, {block.where}", "exec")
                    try:
                        with contextlib.redirect_stdout(said):
                            exec(code, session.namespace)
                    except Exception as exc:
                        msg = f"{tutorial.name}, python block at {block.where} raised: {exc!r}"
                        raise AssertionError(f"{msg}\n{said.getvalue()}") from exc
                    session.outputs.append((block, said.getvalue()))
                elif block.language == "sh":
                    done = subprocess.run(
                        ["bash", "-e", "-c", block.code],
                        env=env,
                        capture_output=True,
                        text=True,
                        encoding="utf-8",
                        timeout=timeout,
                        check=False,
                    )
                    said = done.stdout + done.stderr
                    session.outputs.append((block, said))
                    assert done.returncode == 0, (
                        f"{tutorial.name}, sh block at {block.where} exited "
                        f"{done.returncode}:\n{block.code}\n{said}"
                    )
    finally:
        (folder / "tutorial.log").write_text(session.log, encoding="utf-8")
        session.save()
    return session


def stated(tutorial: Path, pattern: str) -> list[float]:
    """The numbers a sentence of the tutorial states: ``pattern``'s groups, as floats.

    The test that checks a claim reads it from the page, so the page and the test cannot
    drift apart: a reworded claim fails here, naming the pattern.
    """
    text = " ".join(tutorial.read_text(encoding="utf-8").split())
    found = re.search(pattern, text)
    assert found is not None, f"{tutorial.name} no longer states {pattern!r}"
    return [float(g) for g in found.groups()]
