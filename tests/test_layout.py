"""The layout of the code: layers one way, no import cycles, comments that stay true.

``docs/architecture.md`` describes the layers this test holds. Every import is
read: at module level, inside functions, under ``if TYPE_CHECKING:`` and in
``try`` blocks, in ``src/lpik`` and in ``benchmarks/lpik_bench``. Importing
``a.b.c`` runs the packages ``a`` and ``a.b`` too, so an import reaches its
target and every package above it (but the importer's own packages, which
Python has run already).
"""

from __future__ import annotations

import ast
import functools
import re
from dataclasses import dataclass
from pathlib import Path

import tomllib

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "src" / "lpik"
BENCH = ROOT / "benchmarks" / "lpik_bench"
#: The top-level packages whose imports this test reads.
OURS = ("lpik", "lpik_bench")

#: lpik's layers, bottom first: a module of lpik may import only modules of its
#: own layer or below. A prefix stands for that module and every module under
#: it; the longest matching prefix decides. ``lpik`` itself (the package's
#: ``__init__``, the facade) is the top layer and covers no other module.
LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("facts", ("lpik.types", "lpik.defaults", "lpik.tolerances", "lpik.labels", "lpik.exceptions",
               "lpik.naming", "lpik.robots.base", "lpik.version", "lpik.bands")),
    ("core", ("lpik.problem", "lpik.result", "lpik.check", "lpik.limits", "lpik.highs",
              "lpik.continuation", "lpik.linalg")),
    ("robots", ("lpik.robots",)),
    ("command", ("lpik.command",)),
    ("collision", ("lpik.collision",)),
    ("methods", ("lpik.methods", "lpik.problem_json")),
    ("fast", ("lpik.fast",)),
    ("control", ("lpik.control",)),
    ("paper", ("lpik.paper",)),
    ("maps", ("lpik.maps",)),
    ("console", ("lpik.console",)),
    ("cli", ("lpik.cli",)),
    ("facade", ("lpik",)),
)  # fmt: skip
#: The one module of lpik that may import lpik_bench: the ``lpik bench`` command.
BENCH_COMMAND = "lpik.cli.bench"


@dataclass(frozen=True)
class Import:
    """One import statement's target, resolved to a module of ours.

    Attributes:
        source: The importing module.
        target: The imported module (``from a import b``: ``a.b`` when that is a
            module, else ``a``).
        line: Line of the import statement in the source.
    """

    source: str
    target: str
    line: int

    def reached(self) -> tuple[str, ...]:
        """The target and the packages above it that the import runs."""
        parts = self.target.split(".")
        above = (".".join(parts[:k]) for k in range(1, len(parts)))
        run = (p for p in above if p != self.source and not self.source.startswith(p + "."))
        return (*run, self.target)

    def __str__(self) -> str:
        return f"{self.source}:{self.line} -> {self.target}"


def module_name(path: Path) -> str:
    """The dotted name of a source file of lpik or lpik_bench."""
    parts = path.with_suffix("").relative_to(_root_of(path)).parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _root_of(path: Path) -> Path:
    """The folder that holds the top-level package ``path`` is in."""
    return PACKAGE.parent if path.is_relative_to(PACKAGE) else BENCH.parent


@functools.cache
def modules() -> dict[str, Path]:
    """Every module of lpik and lpik_bench by name."""
    paths = sorted([*PACKAGE.rglob("*.py"), *BENCH.rglob("*.py")])
    return {module_name(p): p for p in paths}


def _base(name: str, is_package: bool, node: ast.ImportFrom) -> str:
    """The module a ``from ... import`` names, with a relative import resolved."""
    if node.level == 0:
        return node.module or ""
    package = name.split(".") if is_package else name.split(".")[:-1]
    package = package[: len(package) - (node.level - 1)]
    return ".".join([*package, *([node.module] if node.module else [])])


def read_imports(name: str, source: str, *, is_package: bool = False) -> tuple[Import, ...]:
    """Every import of ours in ``source`` (module ``name``), wherever in it it is written."""
    known = modules()
    found: list[Import] = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [Import(name, alias.name, node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = _base(name, is_package, node)
            for alias in node.names:
                sub = f"{base}.{alias.name}"
                found.append(Import(name, sub if sub in known else base, node.lineno))
    return tuple(dict.fromkeys(i for i in found if i.target.split(".")[0] in OURS))


@functools.cache
def imports(name: str) -> tuple[Import, ...]:
    """Every import of ours in the module ``name``."""
    path = modules()[name]
    text = path.read_text(encoding="utf-8")
    return read_imports(name, text, is_package=path.name == "__init__.py")


def lpik_modules() -> list[str]:
    """The names of lpik's modules."""
    return [name for name in modules() if name.split(".")[0] == "lpik"]


def layer(name: str) -> int:
    """The rank of ``name``'s layer in :data:`LAYERS` (bottom 0); -1 for no layer."""
    if name == "lpik":
        return len(LAYERS) - 1
    best, rank = -1, -1
    for i, (_, prefixes) in enumerate(LAYERS[:-1]):
        for prefix in prefixes:
            if (name == prefix or name.startswith(prefix + ".")) and len(prefix) > best:
                best, rank = len(prefix), i
    return rank


def test_every_module_of_lpik_is_in_a_layer() -> None:
    lost = [name for name in lpik_modules() if layer(name) < 0]
    assert not lost, f"modules in no layer (add them to LAYERS): {lost}"


def test_every_prefix_of_the_layers_names_a_module() -> None:
    stale = [p for _, prefixes in LAYERS for p in prefixes if p not in modules()]
    assert not stale, f"LAYERS names modules that do not exist: {stale}"


def test_every_import_of_lpik_goes_to_its_own_layer_or_below() -> None:
    wrong = []
    for name in lpik_modules():
        for item in imports(name):
            if item.target.startswith("lpik_bench"):
                continue  # the next test's
            top = max(item.reached(), key=layer)
            if layer(top) > layer(name):
                wrong.append(f"{item} ({LAYERS[layer(name)][0]} imports {LAYERS[layer(top)][0]})")
    assert not wrong, "imports against the layers:\n" + "\n".join(wrong)


def _components(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of ``graph`` (Tarjan's algorithm)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        for nxt in sorted(graph[node]):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while not component or component[-1] != node:
                component.append(stack.pop())
            found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def _graph() -> dict[str, set[str]]:
    """Module -> the modules of ours its imports run."""
    return {
        name: {t for i in imports(name) for t in i.reached() if t in modules() and t != name}
        for name in modules()
    }


def _shortest_cycle(graph: dict[str, set[str]], component: list[str]) -> list[Import]:
    """A shortest cycle within ``component``, as the imports that close it."""
    inside = set(component)
    best: list[str] = []
    for start in component:
        trail = {start: [start]}
        queue = [start]
        while queue:
            node = queue.pop(0)
            if start in graph[node]:  # the shortest cycle through start
                best = trail[node] if not best or len(trail[node]) < len(best) else best
                break
            for nxt in sorted(graph[node] & inside):
                if nxt not in trail:
                    trail[nxt] = [*trail[node], nxt]
                    queue.append(nxt)
    steps = zip(best, [*best[1:], best[0]], strict=True)
    return [next(i for i in imports(a) if b in i.reached()) for a, b in steps]


def test_no_import_cycles() -> None:
    graph = _graph()
    cycles = [c for c in _components(graph) if len(c) > 1]
    lines = [
        f"{', '.join(c)}; for example " + ", ".join(map(str, _shortest_cycle(graph, c)))
        for c in cycles
    ]
    assert not lines, "modules that import each other:\n" + "\n".join(lines)


def test_lpik_never_imports_the_benchmarks_except_the_bench_command() -> None:
    wrong = [
        str(item)
        for name in lpik_modules()
        if name != BENCH_COMMAND
        for item in imports(name)
        if item.target.split(".")[0] == "lpik_bench"
    ]
    assert not wrong, wrong


SAMPLE = """
from typing import TYPE_CHECKING

import numpy as np

from lpik.fast import step
from . import limits
from .types import FloatArray

if TYPE_CHECKING:
    from lpik.control.log import SimulationLog


def run() -> None:
    import lpik_bench.runner
    from lpik.methods.lp2 import lp2
"""


def test_the_import_reader_sees_every_import() -> None:
    found = {(i.target, i.line) for i in read_imports("lpik.problem", SAMPLE)}
    assert found == {
        ("lpik.fast.step", 6),  # a module named by a from-import
        ("lpik.limits", 7),  # relative imports
        ("lpik.types", 8),
        ("lpik.control.log", 11),  # under TYPE_CHECKING
        ("lpik_bench.runner", 15),  # inside a function
        ("lpik.methods.lp2", 16),
    }
    assert Import("lpik.methods.lp2", "lpik.fast.batch", 1).reached() == (
        "lpik.fast",
        "lpik.fast.batch",
    )
    assert Import("lpik.fast", "lpik.fast.batch", 1).reached() == ("lpik.fast.batch",)
    assert Import("lpik.fast.step", "lpik.fast.batch", 1).reached() == ("lpik.fast.batch",)


def test_the_top_level_api_a_user_guesses() -> None:
    import lpik

    for name in ("Problem", "Result", "solve", "build_problem", "load_robot", "load_urdf",
                 "simulate", "Lp2Controller", "EndStops", "VelocityLimits",
                 "AccelerationLimits", "MultiplierBounds", "LinearRows", "planar_arm"):  # fmt: skip
        assert name in lpik.__all__ and getattr(lpik, name) is not None, name


SOURCES = [*PACKAGE.rglob("*.py"), *BENCH.rglob("*.py"), *(ROOT / "tests").rglob("*.py")]


def test_no_noqa_for_a_rule_that_is_not_enabled() -> None:
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    enabled = tuple(meta["tool"]["ruff"]["lint"]["select"])
    pattern = re.compile(r"#\s*noqa:\s*([A-Z]+[0-9]+(?:\s*,\s*[A-Z]+[0-9]+)*)")
    wrong = []
    for path in SOURCES:
        for k, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            for match in pattern.finditer(line):
                for code in re.split(r"\s*,\s*", match.group(1)):
                    if not code.startswith(enabled):
                        wrong.append(f"{path.relative_to(ROOT)}:{k}: {code}")
    assert not wrong, wrong


def test_comments_cite_nothing_outside_the_repository() -> None:
    outside = re.compile(r"DESIGN\.md|STYLE\.md|\bissue #?\d+", re.IGNORECASE)
    wrong = [
        f"{path.relative_to(ROOT)}:{k}"
        for path in [*PACKAGE.rglob("*.py"), *BENCH.rglob("*.py")]
        for k, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
        if outside.search(line)
    ]
    assert not wrong, wrong


def test_docstrings_quote_no_timings() -> None:
    timing = re.compile(r"\b\d+(\.\d+)?\s?(us|ns|ms)\b")
    wrong = []
    for path in PACKAGE.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.FunctionDef | ast.ClassDef | ast.Module | ast.AsyncFunctionDef):
                doc = ast.get_docstring(node) or ""
                if timing.search(doc):
                    wrong.append(f"{path.relative_to(ROOT)}: {getattr(node, 'name', 'module')}")
    assert not wrong, wrong
