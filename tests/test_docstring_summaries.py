"""The summary line of every docstring is valid reStructuredText on its own.

The API reference lists each module, class and function by the first sentence of its docstring
(Sphinx autosummary cuts at the first period followed by a space or the end); a role such as
``:func:`~pkg.mod.`` broken over a line break at a period leaves an unclosed backquote there,
which stops the documentation build (warnings are errors).

Reference: the rule that inline markup must be closed in the same text (docutils), checked as
an even number of backquotes in every summary.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
_SENTENCE = re.compile(r"^(.*?\.)(\s|$)")


def summaries() -> list[tuple[str, str]]:
    """``(place, summary)`` of every documented module, class and function of the package."""
    out = []
    for path in sorted((ROOT / "neweul_py").rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        nodes = [tree, *(n for n in ast.walk(tree)
                         if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef))]
        for node in nodes:
            doc = ast.get_docstring(node)
            if not doc:
                continue
            first = doc.split("\n\n")[0].replace("\n", " ")
            match = _SENTENCE.match(first)
            place = f"{path.relative_to(ROOT)}:{getattr(node, 'name', '<module>')}"
            out.append((place, match.group(1) if match else first))
    return out


def test_an_unclosed_role_is_found() -> None:
    """Reference: the summary of a role broken at its dotted path."""
    text = "The body (:func:`~neweul_py.ffrf.\nsplice.ffrf_cloud`) of a node."
    summary = _SENTENCE.match(text.replace("\n", " ")).group(1)
    assert summary.count("`") % 2 == 1


def test_every_summary_closes_its_markup() -> None:
    """Every summary of the package: the failure lists the place and the summary."""
    found = summaries()
    assert len(found) > 500
    bad = [f"{place}: {text[:120]}" for place, text in found if text.count("`") % 2]
    assert not bad, "\n" + "\n".join(bad)
