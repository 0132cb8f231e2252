"""Shipped text says what is, not how it came to be.

The package, the tests, the documentation, the examples, the benchmarks and the README name no
step of the development (an issue, session or item number, an audit), no path of a developer's
machine, and cite no design document outside the repository (the architecture page is
``docs/architecture.md``). History belongs in ``CHANGELOG.md`` and git, which are not scanned.

Reference: the patterns below, each a plain regular expression over every line of every text
file of those trees; a hit fails with its file, line and text.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TREES = ("neweul_py", "tests", "docs", "examples", "benchmarks")
FILES = ("README.md",)
SUFFIXES = {".py", ".md", ".rst", ".txt", ".yaml", ".yml", ".json", ".toml", ".cfg", ".csv",
            ".SID_FEM"}
#: Build output and the untracked outputs of example runs (``.gitignore``), not written text.
SKIP_DIRS = {"__pycache__", "_build", ".ipynb_checkpoints"}
SKIP_PREFIXES = (("docs", "api", "generated"),)
SKIP_UNDER_EXAMPLES = {"data", "out"}

#: What each pattern catches, and the pattern (case-insensitive).
PATTERNS = {
    "an issue number": r"\bissues?\s+#?\d+",
    "a session number": r"\bsessions?[\s-]+\d+",
    "an item number": r"\bitems?\s+\d+",
    "an audit": r"\baudit(s|ed|ing|or)?\b",
    "a helper (the development role)": (r"\bhelper's\b|\bhelpers'\s"
                                        r"|\bhelper\s+(session|branch|engineer)"),
    "a design document outside the repository": r"\bDESIGN\.md\b",
    "a developer's path": r"(?<![\w.])/(work|home|root)/|(?<![\w.])/tmp/\w",
}
_COMPILED = {what: re.compile(pattern, re.IGNORECASE) for what, pattern in PATTERNS.items()}
_SELF = Path(__file__).resolve()


def shipped_files() -> list[Path]:
    """Every text file of the scanned trees (links not followed: ``docs/examples`` is a link to
    ``examples``, scanned once), and the README."""
    out = [ROOT / name for name in FILES]
    for tree in TREES:
        for path in sorted((ROOT / tree).rglob("*")):
            rel = path.relative_to(ROOT)
            dirs = rel.parts[:-1]
            if (path == _SELF or any(part in SKIP_DIRS for part in dirs)
                    or any(dirs[:len(prefix)] == prefix for prefix in SKIP_PREFIXES)
                    or (dirs[:1] == ("examples",) and SKIP_UNDER_EXAMPLES & set(dirs))):
                continue
            if any(parent.is_symlink() for parent in path.parents if ROOT in parent.parents):
                continue
            if path.is_file() and not path.is_symlink() and path.suffix in SUFFIXES:
                out.append(path)
    return out


def hits(text: str) -> list[tuple[int, str, str]]:
    """``(line number, what, line)`` of every pattern found in ``text``; a pattern may run over
    a line break (``session`` at the end of one line, its number on the next)."""
    lines = text.splitlines()
    found = []
    for what, pattern in _COMPILED.items():
        for match in pattern.finditer(text):
            number = text.count("\n", 0, match.start()) + 1
            found.append((number, what, lines[number - 1].strip()))
    return sorted(found)


#: Lines written the way the old text was, one per pattern; each is joined from parts at
#: run time (``"{…}"`` fields), so that this file itself holds none of the words it forbids.
_FORBIDDEN_EXAMPLES = [
    ("as {} 14 asks", "issue", "an issue number"),
    ("superseded in {} 16", "session", "a session number"),
    ("with the {}-19 body", "session", "a session number"),
    ("meets {} 4 on the TM", "item", "an item number"),
    ("the {} found", "audit", "an audit"),
    ("a {}'s exploration", "helper", "a helper (the development role)"),
    ("see {}.md", "DESIGN", "a design document outside the repository"),
    ("--dir /{}/data/s19/r1", "work", "a developer's path"),
    ("-o /{}/fix5/me", "tmp", "a developer's path"),
    ("it was 0.8 before {}\n        19 (no source)", "session", "a session number"),
    ("cd /{}/someone/neweul", "home", "a developer's path"),
]


@pytest.mark.parametrize(
    ("line", "what"),
    [(template.format(word), what) for template, word, what in _FORBIDDEN_EXAMPLES],
)
def test_each_pattern_finds_its_word(line: str, what: str) -> None:
    """Reference: one line written the way the old text was, per pattern."""
    assert [w for _, w, _ in hits(line)] == [what]


@pytest.mark.parametrize(
    "line",
    [
        "skfem.helpers import dot",
        "a small helper shared by the readers",
        "the issue of stiffness",
        "tmp_path / 'x'",
        "docs/architecture.md",
        "auditory canal",
    ],
)
def test_technical_words_pass(line: str) -> None:
    """Reference: the same words in their technical sense."""
    assert hits(line) == []


def test_shipped_text_names_no_process_step_or_machine_path() -> None:
    """Every scanned file, every line: the failure lists ``file:line: what: text``."""
    files = shipped_files()
    assert len(files) > 100 and ROOT / "docs" / "architecture.md" in files
    problems = []
    for path in files:
        text = path.read_text(encoding="utf-8", errors="replace")
        for number, what, line in hits(text):
            problems.append(f"{path.relative_to(ROOT)}:{number}: {what}: {line[:120]}")
    assert not problems, "\n" + "\n".join(problems)


def test_readmes_are_short() -> None:
    """Reference: the documentation's rule that a README is a how-to with today's figures —
    at most 150 lines (the history is in ``CHANGELOG.md``, the reference on the site)."""
    readmes = [ROOT / "README.md", ROOT / "benchmarks" / "README.md",
               *sorted((ROOT / "examples").glob("*/README.md")), ROOT / "examples" / "README.md"]
    long = {str(p.relative_to(ROOT)): n for p in readmes
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > 150}
    assert not long, long
