"""Docstrings and comments in flexmb/ state the contract, not a lab notebook.

A timing figure ("0.3 ms", "~8 s of CPU", "50 us", "~10x faster", "speed-up of 5") belongs in
BENCHMARKS.md, under the benchmark that measured it (or its "Timings moved from docstrings"
section, which says where each came from); an issue number ("issue 21", "#21") belongs in git's
history. Evidence that explains a decision stays, as a ratio or an accuracy figure (e.g.
`flexmb.linearisation.RESIDUAL_MAX`'s residuals).

Read from the source like `tests/test_layout.py`: module, class and function docstrings and
attribute docstrings (a string statement after an assignment) with `ast`, comments (``#`` and
``#:``) with `tokenize`. A match that is not a timing or an issue number goes in `ALLOWED` with
its reason.
"""

from __future__ import annotations

import ast
import io
import re
import tokenize
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "flexmb"

_NUMBER = r"(?<![\w.^-])~?\d[\d.,]*(?:e-?\d+)?"
_RANGE = r"\s*(?:-\s*\d[\d.]*\s*)?"
#: A number with a time unit (seconds only where no exponent or product follows: "s^-1", "s * 2"),
#: a "N x faster", a "speed-up of N".
TIMING = re.compile(
    _NUMBER + _RANGE + r"(?:ms|us|µs|μs|ns)\b"
    r"|" + _NUMBER + _RANGE + r"s\b(?!\s*[-^/*]\s*-?\d)"
    r"|" + _NUMBER + r"\s*(?:min|minutes|seconds|hours?)\b"
    r"|" + _NUMBER + r"\s*(?:x|×|times)\s+(?:faster|slower|quicker|as\s+fast|less\s+time|more\s+time|speed)"
    r"|speed-?ups?\s+(?:of\s+)?~?\d", re.M)
#: "issue 21", "issues 19 and 29", "#21" (after a space or a parenthesis: ``"<name>#2"`` is a column
#: suffix), "PR 12".
ISSUE = re.compile(r"\bissues?\s+#?\d+|(?:(?<=\s)|(?<=\())#\d+\b|\bPR\s*#?\d+", re.I)

#: "path:text matched" -> reason. Keep it short: each one is a figure the test cannot tell apart.
ALLOWED: dict = {}


def _docstrings(tree: ast.AST):
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if not isinstance(body, list):
            continue
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            first = body[0] if body else None
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) \
                    and isinstance(first.value.value, str):
                yield first.lineno, first.value.value
        for before, stmt in zip(body, body[1:]):  # attribute docstrings
            if isinstance(before, (ast.Assign, ast.AnnAssign)) and isinstance(stmt, ast.Expr) \
                    and isinstance(stmt.value, ast.Constant) and isinstance(stmt.value.value, str):
                yield stmt.lineno, stmt.value.value


def _comments(source: str):
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type == tokenize.COMMENT:
            yield tok.start[0], tok.string


def findings(root: Path = ROOT) -> list:
    """``(path:line, "timing" | "issue", matched text)`` of every docstring and comment under ``root``."""
    out = []
    for path in sorted(root.rglob("*.py")):
        source = path.read_text(encoding="utf-8")
        name = path.relative_to(root.parent).as_posix()
        texts = [*_docstrings(ast.parse(source)), *_comments(source)]
        for line, text in texts:
            for what, pattern in (("timing", TIMING), ("issue", ISSUE)):
                for m in pattern.finditer(text):
                    found = " ".join(m.group(0).split())
                    if f"{name}:{found}" not in ALLOWED:
                        out.append((f"{name}:{line + text.count(chr(10), 0, m.start())}", what, found))
    return out


def test_no_timing_figure_or_issue_number_in_flexmb_docstrings_or_comments():
    found = findings()
    assert not found, ("timings go to BENCHMARKS.md, history to git (issue 27 item 6):\n"
                       + "\n".join(f"  {where}: {what} {text!r}" for where, what, text in found))


@pytest.mark.parametrize("text, what", [
    ("compiling the manipulator costs ~0.3 ms", "timing"),
    ("the first solve: ~8 s of CPU", "timing"),
    ("50 us -> about 2 us per evaluation", "timing"),
    ("1-2 ms of a 4 ms call", "timing"),
    ("the same arrays, ~5x\n    faster on large patterns", "timing"),
    ("did not finish in 15 min", "timing"),
    ("printing speed-ups of 5-21x", "timing"),
    ("(issue 21)", "issue"),
    ("issues 19 and 29", "issue"),
    ("see #12 for the history", "issue"),
])
def test_the_patterns_find_what_they_are_for(text, what):
    assert (TIMING if what == "timing" else ISSUE).search(text)


@pytest.mark.parametrize("text", [
    "a time step dt [s]", "frequencies [Hz] f1 ... f6", "Eq. 2.5", "1e-9 relative", "6 modes, 250 DOFs",
    'the first free ``"<name>#2"`` suffix', "omega^2 2e-12", "stiffness [N m/rad] 1.5", "3 x 3 matrices",
    "a rate [1/s] of 2 s^-1", "``w0 + i h J_l(w0)^-1 s`` with the spin",
])
def test_the_patterns_leave_units_and_equations_alone(text):
    assert not TIMING.search(text) and not ISSUE.search(text)


def test_every_allowed_entry_is_still_needed():
    used = set()
    for path in ROOT.rglob("*.py"):
        source = path.read_text(encoding="utf-8")
        name = path.relative_to(ROOT.parent).as_posix()
        for _, text in [*_docstrings(ast.parse(source)), *_comments(source)]:
            for pattern in (TIMING, ISSUE):
                used.update(f"{name}:{' '.join(m.group(0).split())}" for m in pattern.finditer(text))
    assert not set(ALLOWED) - used, f"no longer matched, remove: {sorted(set(ALLOWED) - used)}"
