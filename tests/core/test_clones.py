"""No run of six or more lines shared between two modules (issue 33, "How we will know").

A clone detector in plain Python (the ``duplicates`` command of the development machines is
not on CI), over ``src/hydropwa/**/*.py`` and the C sources (``*.c``, ``*.h``).

Each file is reduced to its *normalised* lines, as ``duplicates`` reads them:

- white space folded (stripped, inner runs to one space);
- dropped: blank lines, comments (``#`` in Python, found with :mod:`tokenize` so a ``#``
  inside a string stays; ``//`` and ``/* … */`` in C), lines of lone punctuation (brackets,
  commas, colons, quotes: a closing ``)`` or a ``\"\"\"`` says nothing), and import lines
  (every line of a Python ``import``/``from … import`` statement, found with :mod:`ast`, and
  C ``#include`` lines) and the module's ``__all__`` list: like the imports, it declares
  names, and a package's ``__init__`` repeats its modules' public names in it by rule (each
  name re-exported explicitly, STYLE.md), so an alphabetical run of them is no copied logic;
- docstrings are **kept**: a docstring copied into two modules is a copy too (it drifts
  like code), and keeping them makes this test agree with ``duplicates``.

Lines are compared to the letter. Comparing shapes instead (names, numbers and strings
abstracted, as ``duplicates`` also does) was tried: over ``src`` it gives about 9,000 runs, nearly
all keyword-argument lists, typer option blocks and ``self.x = x`` constructors, so it is noise
for a test that must pass or fail.

Every window of :data:`MIN_LINES` consecutive normalised lines is hashed; a window found in
two different files is a shared run, and overlapping windows of one file pair that follow
each other are merged into one run (``a.py:10-24 ~ b.py:40-54``, the original line numbers).
Repeats inside one module are not counted here (``python tests/core/test_clones.py --within``
lists them, to look at).

Runs with one side in a file that another engineer is editing in parallel are listed in
:data:`ALLOWED` per file pair, with the number of shared normalised lines as a ceiling and the
reason; a pair that is not listed, a pair that grew past its ceiling, and a listed pair that
shares nothing any more all fail, so the list only shrinks. ``python tests/core/test_clones.py``
prints every shared run.
"""

from __future__ import annotations

import ast
import io
import re
import sys
import tokenize
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2] / "src" / "hydropwa"
MIN_LINES = 6
SUFFIXES = (".py", ".c", ".h")
_LONE_PUNCTUATION = re.compile(r"""^[\s()\[\]{},;:.'"`\\]*$""")
_C_COMMENT = re.compile(r"//[^\n]*|/\*.*?\*/", re.DOTALL)
_C_STRING = re.compile(r'"(?:\\.|[^"\\\n])*"')

#: (file, file) → (shared normalised lines at most, why), for a pair with one side in a file that
#: another engineer edits in parallel (the lead merges them after that stop). The measured sizes
#: are ceilings. Empty: the last entries (the solver's argument list, spelled out in the loop, its
#: generated entries and the front) went with ``_entries.SolverRun``.
ALLOWED: dict[tuple[str, str], tuple[int, str]] = {}


@dataclass(frozen=True)
class Run:
    """One run of lines shared by two files (1-based, inclusive, original line numbers)."""

    a: str
    a_first: int
    a_last: int
    b: str
    b_first: int
    b_last: int
    lines: int  #: normalised lines shared

    def __str__(self) -> str:
        return (
            f"{self.a}:{self.a_first}-{self.a_last} ~ {self.b}:{self.b_first}-{self.b_last}"
            f" ({self.lines} lines)"
        )


def _fold(line: str) -> str:
    return " ".join(line.split())


def _is_all(node: ast.stmt) -> bool:
    """``__all__ = [...]`` (or ``+=``, annotated) at module level."""
    targets = node.targets if isinstance(node, ast.Assign) else [getattr(node, "target", None)]
    kinds = ast.Assign | ast.AugAssign | ast.AnnAssign
    return isinstance(node, kinds) and any(
        isinstance(t, ast.Name) and t.id == "__all__" for t in targets
    )


def _python_lines(text: str) -> list[tuple[int, str]]:
    """The normalised lines of Python source: (line number, text)."""
    lines = text.splitlines()
    drop: set[int] = set()
    tree = ast.parse(text)
    names = [n for n in ast.walk(tree) if isinstance(n, ast.Import | ast.ImportFrom)]
    for node in names + [n for n in tree.body if _is_all(n)]:
        drop.update(range(node.lineno, (node.end_lineno or node.lineno) + 1))
    cut: dict[int, int] = {}  # line → column where its comment starts
    for tok in tokenize.generate_tokens(io.StringIO(text).readline):
        if tok.type == tokenize.COMMENT:
            cut[tok.start[0]] = tok.start[1]
    out = []
    for number, line in enumerate(lines, start=1):
        if number in drop:
            continue
        if number in cut:
            line = line[: cut[number]]
        if not _LONE_PUNCTUATION.match(line):
            out.append((number, _fold(line)))
    return out


def _c_lines(text: str) -> list[tuple[int, str]]:
    """The normalised lines of C source: comments blanked (line count kept), includes dropped."""

    def blank(m: re.Match[str]) -> str:
        if m.group(0).startswith('"'):
            return m.group(0)
        return "\n" * m.group(0).count("\n")

    text = re.sub(_C_STRING.pattern + "|" + _C_COMMENT.pattern, blank, text, flags=re.DOTALL)
    out = []
    for number, line in enumerate(text.splitlines(), start=1):
        if line.strip().startswith("#include") or _LONE_PUNCTUATION.match(line):
            continue
        out.append((number, _fold(line)))
    return out


def normalised_lines(path: Path) -> list[tuple[int, str]]:
    """The lines of ``path`` that count, normalised (see the module docstring)."""
    text = path.read_text(encoding="utf-8")
    return _python_lines(text) if path.suffix == ".py" else _c_lines(text)


def _merge(
    a: str, b: str, starts: list[tuple[int, int]], la: list[int], lb: list[int], n: int
) -> list[Run]:
    """Join the matching windows of one file pair (index pairs) into maximal runs."""
    runs = []
    pending = set(starts)
    for i, j in sorted(starts):
        if (i, j) not in pending:
            continue
        k = 0
        while (i + k, j + k) in pending:
            pending.discard((i + k, j + k))
            k += 1
        last = k - 1 + n - 1
        runs.append(Run(a, la[i], la[i + last], b, lb[j], lb[j + last], k + n - 1))
    return runs


def shared_runs(root: Path = ROOT, n: int = MIN_LINES, within: bool = False) -> list[Run]:
    """Every run of ``n`` or more normalised lines that two files under ``root`` share.

    ``within=True`` lists the runs repeated inside one file instead (a window against a later,
    non-overlapping one).
    """
    files = sorted(p for p in root.rglob("*") if p.suffix in SUFFIXES and p.is_file())
    texts: dict[str, list[str]] = {}
    numbers: dict[str, list[int]] = {}
    places: dict[tuple[str, ...], list[tuple[str, int]]] = defaultdict(list)
    for path in files:
        rel = path.relative_to(root).as_posix()
        lines = normalised_lines(path)
        numbers[rel] = [ln for ln, _ in lines]
        texts[rel] = [t for _, t in lines]
        for i in range(len(lines) - n + 1):
            places[tuple(texts[rel][i : i + n])].append((rel, i))
    pairs: dict[tuple[str, str], list[tuple[int, int]]] = defaultdict(list)
    for where in places.values():
        for x, (fa, ia) in enumerate(where):
            for fb, ib in where[x + 1 :]:
                if (fa == fb) == within and (fa != fb or ib - ia >= n):
                    pairs[fa, fb].append((ia, ib))
    runs: list[Run] = []
    for (a, b), starts in sorted(pairs.items()):
        runs.extend(_merge(a, b, starts, numbers[a], numbers[b], n))
    return runs


def lines_per_pair(runs: list[Run]) -> dict[tuple[str, str], int]:
    """Shared normalised lines per file pair."""
    out: dict[tuple[str, str], int] = defaultdict(int)
    for run in runs:
        out[run.a, run.b] += run.lines
    return dict(out)


def violations(runs: list[Run], allowed: dict[tuple[str, str], tuple[int, str]]) -> list[str]:
    """What ``runs`` break of ``allowed``: unlisted pairs, pairs past their ceiling, stale entries."""
    per_pair = lines_per_pair(runs)
    new = [f"not allowed: {r}" for r in runs if (r.a, r.b) not in allowed]
    grown = [
        f"grown: {a} ~ {b}: {per_pair[a, b]} lines > ceiling {allowed[a, b][0]}"
        for a, b in per_pair
        if (a, b) in allowed and per_pair[a, b] > allowed[a, b][0]
    ]
    stale = [f"stale (shares nothing now): {a} ~ {b}" for a, b in allowed if (a, b) not in per_pair]
    return new + grown + stale


def test_no_run_of_six_lines_shared_between_two_modules_but_the_listed_ones():
    found = violations(shared_runs(), ALLOWED)
    assert not found, (
        "lines shared between two modules (write the logic once and call it from both, or, "
        "where one side is another engineer's file, list the pair in ALLOWED with a reason; "
        "remove stale entries):\n" + "\n".join(found)
    )


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")


_SIX = [f"value_{k} = compute({k}, scale={k}.5)" for k in range(6)]


def test_the_detector_finds_a_planted_six_line_clone_and_ignores_five(tmp_path):
    # six shared lines, one side with a comment, a blank line, lone quotes, an import and
    # other indentation between them: normalised, they are the same six lines
    _write(tmp_path / "a" / "one.py", "x = 1\n" + "\n".join(_SIX) + "\ny = 2\n")
    noisy = ["def f():", "    import os", *("    " + s for s in _SIX[:3])]
    noisy += ["    # a comment", "", '    """', '    """', *("    " + s for s in _SIX[3:])]
    _write(tmp_path / "b" / "two.py", "\n".join(noisy) + "\n")
    # five shared lines only, and a six-line repeat inside one file
    _write(tmp_path / "c.py", "\n".join(_SIX[:5]) + "\nz = 3\n")
    _write(tmp_path / "d.py", "\n".join(["q = 0", *_SIX[:5], "r = 0", *_SIX[:5]]) + "\n")
    runs = shared_runs(tmp_path)
    assert [str(r) for r in runs] == ["a/one.py:2-7 ~ b/two.py:3-12 (6 lines)"]
    within = shared_runs(tmp_path, within=True)
    assert [str(r) for r in within] == []


def test_the_detector_merges_overlapping_windows_and_reads_c(tmp_path):
    body = [f"x[{k}] = f(y[{k}], {k});" for k in range(9)]
    c1 = ["#include <math.h>", "/* header", "   comment */", *body[:4], "// note", *body[4:]]
    _write(tmp_path / "one.c", "\n".join(c1) + "\n")
    _write(tmp_path / "two.c", "\n".join(["int a;", *body, "}"]) + "\n")
    _write(tmp_path / "three.py", "\n".join([*_SIX, "pass", *_SIX]) + "\n")
    runs = shared_runs(tmp_path)
    assert [str(r) for r in runs] == ["one.c:4-13 ~ two.c:2-10 (9 lines)"]
    within = shared_runs(tmp_path, within=True)
    assert [str(r) for r in within] == ["three.py:1-6 ~ three.py:8-13 (6 lines)"]


def test_the_allowed_list_only_shrinks(tmp_path):
    # one pair sharing 7 lines, one sharing 6: a listed ceiling passes, a lower one fails as
    # grown, an unlisted pair fails as new, a listed pair without runs fails as stale
    seven = [*_SIX, "value_6 = compute(6, scale=6.5)"]
    _write(tmp_path / "a.py", "\n".join(seven) + "\n")
    _write(tmp_path / "b.py", "\n".join(["q = 0", *seven]) + "\n")
    _write(tmp_path / "c.py", "\n".join([*_SIX[::-1], "w = 1", *_SIX]) + "\n")
    runs = shared_runs(tmp_path)
    pairs = sorted(lines_per_pair(runs).items())
    assert pairs == [(("a.py", "b.py"), 7), (("a.py", "c.py"), 6), (("b.py", "c.py"), 6)]
    why = "test"
    allowed = {("a.py", "b.py"): (7, why), ("a.py", "c.py"): (6, why), ("b.py", "c.py"): (6, why)}
    assert violations(runs, allowed) == []
    allowed["a.py", "b.py"] = (6, why)
    del allowed["b.py", "c.py"]
    allowed["a.py", "d.py"] = (6, why)
    found = violations(runs, allowed)
    assert [f.split(":")[0] for f in found] == [
        "not allowed",
        "grown",
        "stale (shares nothing now)",
    ]
    assert "b.py" in found[0] and "c.py" in found[0] and "7 lines > ceiling 6" in found[1]


def test_a_hash_inside_a_string_is_not_a_comment(tmp_path):
    lines = [f's{k} = "#{k} shared"' for k in range(6)]
    _write(tmp_path / "a.py", "\n".join(lines) + "\n")
    _write(tmp_path / "b.py", "\n".join(ln.split('"')[0] + '""' for ln in lines) + "\n")
    assert shared_runs(tmp_path) == []


if __name__ == "__main__":
    found = shared_runs(within="--within" in sys.argv)
    for run in found:
        sys.stdout.write(f"{run}\n")
    sys.stdout.write(f"{len(found)} runs, {sum(r.lines for r in found)} lines\n")
