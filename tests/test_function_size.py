"""Functions short enough to read at once: at most MAX_BODY lines of body.

The body is measured from its first statement after the docstring to its end.
Every function counts: methods, nested functions and the compiled kernels. The
few compiled kernels that cannot be split are listed, with the reason, in the
table under ``## Long compiled kernels`` in ``docs/architecture.md``; a listed
name that no longer exists, or is no longer long, fails too, so the list stays true.
"""

from __future__ import annotations

import ast
import re
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ROOTS = (ROOT / "src" / "lpik", ROOT / "benchmarks" / "lpik_bench")
ARCHITECTURE = ROOT / "docs" / "architecture.md"
HEADING = "## Long compiled kernels"
#: The most lines a function's body may have (its docstring not counted).
MAX_BODY = 60

Function = ast.FunctionDef | ast.AsyncFunctionDef


def body_lines(node: Function) -> int:
    """Lines from the first statement after the docstring to the end of the function."""
    body = node.body
    if ast.get_docstring(node, clean=False) is not None:
        body = body[1:]
    if not body:
        return 0
    return body[-1].end_lineno - body[0].lineno + 1  # type: ignore[operator]


def functions(tree: ast.AST, prefix: str = "") -> Iterator[tuple[str, Function]]:
    """Every function below ``tree`` with its qualified name (``Class.method``, ``outer.inner``)."""
    for node in ast.iter_child_nodes(tree):
        if isinstance(node, Function):
            name = prefix + node.name
            yield name, node
            yield from functions(node, name + ".")
        elif isinstance(node, ast.ClassDef):
            yield from functions(node, prefix + node.name + ".")
        else:
            yield from functions(node, prefix)


def sizes() -> dict[str, int]:
    """``path:function`` -> body lines, for every function of lpik and lpik_bench."""
    found = {}
    for root in ROOTS:
        for path in sorted(root.rglob("*.py")):
            tree = ast.parse(path.read_text(encoding="utf-8"))
            where = path.relative_to(ROOT).as_posix()
            for name, node in functions(tree):
                found[f"{where}:{name}"] = max(found.get(f"{where}:{name}", 0), body_lines(node))
    return found


def table_rows() -> list[str]:
    """The rows of the table under :data:`HEADING` in docs/architecture.md, past its head."""
    text = ARCHITECTURE.read_text(encoding="utf-8")
    assert HEADING in text.splitlines(), f"docs/architecture.md has no section {HEADING!r}"
    section = text.split(HEADING + "\n", 1)[1].split("\n## ", 1)[0]
    return [line for line in section.splitlines() if line.startswith("|")][2:]


#: A row of the table: | `path:function` | reason |
ROW = re.compile(r"^\|\s*`([^`:]+\.py:[\w.]+)`\s*\|\s*(\S.*?)\s*\|\s*$")


def listed_kernels() -> dict[str, str]:
    """The kernels the table lists: ``path:function`` -> reason."""
    return {m.group(1): m.group(2) for m in map(ROW.match, table_rows()) if m}


def test_every_row_names_a_function_and_a_reason() -> None:
    wrong = [row for row in table_rows() if not ROW.match(row)]
    assert not wrong, f"rows not of the form | `path.py:function` | reason |: {wrong}"


def test_no_function_is_over_the_size() -> None:
    listed = listed_kernels()
    big = [
        f"{name} ({n} lines)"
        for name, n in sorted(sizes().items())
        if n > MAX_BODY and name not in listed
    ]
    assert not big, f"functions over {MAX_BODY} lines of body: " + ", ".join(big)


def test_every_listed_kernel_exists_and_is_long() -> None:
    found = sizes()
    stale = [
        f"{name} ({'gone' if name not in found else f'{found[name]} lines'})"
        for name in listed_kernels()
        if found.get(name, 0) <= MAX_BODY
    ]
    assert not stale, f"listed under {HEADING!r} but not over {MAX_BODY} lines: " + ", ".join(stale)
