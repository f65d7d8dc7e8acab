"""The code blocks of the README and the documentation pages, and how a test runs each kind.

A block is a fenced block (three backticks) with a language: ``python`` blocks are executed (one
namespace per page, in page order), ``sh`` blocks line by line in a shell, ``toml`` and ``json``
blocks parsed (a ``toml`` block with ``[chain]``, ``[curve]`` and ``[control]`` is validated as a
scenario). ``text`` blocks and blocks without a language are output and are not run. An HTML
comment ``<!-- no-test: why -->`` on the line just before a block leaves it out (a command that
needs a cluster or waits for a client).
"""
from __future__ import annotations

import re
import shlex
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FENCE = re.compile(r"^(`{3,})([\w-]*)[^\n]*\n(.*?)^\1[ \t]*$", re.S | re.M)
NO_TEST = re.compile(r"<!--\s*no-test\b[^>]*-->\s*$")
RUN = ("python", "sh", "toml", "json")


@dataclass(frozen=True)
class Block:
    """One fenced block: the page, its line number, the language, the text, and whether to skip it."""

    page: Path
    line: int
    lang: str
    text: str
    skip: bool

    @property
    def id(self) -> str:
        """``page:line``, relative to the repository."""
        return f"{self.page.relative_to(ROOT)}:{self.line}"


def pages() -> list[Path]:
    """The README and every Markdown page of the documentation (guide pages included, generated ones not)."""
    docs = ROOT / "docs"
    return [ROOT / "README.md"] + sorted(p for p in docs.rglob("*.md")
                                         if not {"_build", "reference", "api", "auto_examples"} & set(p.parts))


def blocks(page: Path) -> list[Block]:
    """The fenced blocks of one page (MyST directives such as ``{toctree}`` left out)."""
    text = page.read_text()
    out = []
    for m in FENCE.finditer(text):
        before = text[:m.start()].rstrip("\n").rsplit("\n", 1)[-1]
        line = text.count("\n", 0, m.start()) + 1
        out.append(Block(page, line, m.group(2), m.group(3), bool(NO_TEST.search(before))))
    return out


def runnable() -> list[Block]:
    """Every block that a test runs or parses."""
    return [b for p in pages() for b in blocks(p) if b.lang in RUN]


def commands(text: str) -> list[tuple[str, int]]:
    """The command lines of an ``sh`` block with the exit status each expects.

    A comment containing ``refused`` or ``exit N`` sets the expected status (2, or N); else 0.

    Parameters
    ----------
    text : str
        The block.

    Returns
    -------
    list of (str, int)
        The command (comment removed) and its expected exit status.
    """
    out = []
    for raw in text.replace("\\\n", " ").splitlines():
        command, _, comment = raw.partition(" #")
        command = command.strip()
        if not command or command.startswith("#"):
            continue
        status = re.search(r"exit (\d+)", comment)
        out.append((command, int(status.group(1)) if status else 2 if "refused" in comment else 0))
    return out


#: Flags added to a ``coordarm`` command so that the test is fast (only where the line does not set them).
FAST = {"run": ["--duration", "1"], "compare": ["--duration", "1"], "sweep": ["--vary", "duration=0.5"]}


def fast(command: str) -> str:
    """``command`` with short runs: ``--duration 1`` (or a short sweep) unless it sets its own duration.

    A ``coordarm run ... --yes`` of a run refused for its size runs 0.01 s instead. ``make`` targets
    (``make demo``, ``make test``, ``make docs``) are the CI's own steps: they become ``true``.

    Parameters
    ----------
    command : str
        One command line of a block.

    Returns
    -------
    str
        The line to run.
    """
    parts = []
    for piece in command.split("&&"):
        words = shlex.split(piece)
        if words[:1] == ["make"] and len(words) == 2 and words[1] in ("demo", "test", "docs"):
            parts.append("true")
            continue
        if words[:1] == ["coordarm"] and len(words) > 2:
            sub = words[1]
            if "--yes" in words:
                words += ["--duration", "0.01"]
            elif sub in FAST and "duration" not in piece:
                words += FAST[sub]
            if sub == "report" and not words[2].endswith(".mcap") and "duration" not in piece:
                words += ["--duration", "1"]
        parts.append(shlex.join(words))
    return " && ".join(parts)
