"""The layout of the package: layers, no import cycles, small modules, comments that stay true.

``docs/architecture.md`` describes the layers this test holds.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest
import tomllib

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "src" / "lpik"
BENCH = ROOT / "benchmarks" / "lpik_bench"

#: Module-name prefixes by layer, bottom first: a module may import (at module level)
#: only modules of its own layer or below. The longest matching prefix decides.
LAYERS = (
    ("lpik.types", "lpik.tolerances", "lpik.labels", "lpik.exceptions", "lpik.naming",
     "lpik.robots.base", "lpik.version", "lpik.bands"),
    ("lpik.problem", "lpik.result", "lpik.check", "lpik.limits", "lpik.highs", "lpik.methods",
     "lpik.problem_json"),
    ("lpik.robots",),
    ("lpik.command",),
    ("lpik.collision",),
    ("lpik.control",),
    ("lpik.fast",),
    ("lpik.control.controller", "lpik.control.inputs", "lpik.control.backend_step",
     "lpik.control.avoiding_controller", "lpik.control.controller_steps"),
    ("lpik.paper",),
    ("lpik.console",),
    ("lpik.cli",),
    ("lpik",),
)  # fmt: skip
#: The most lines a module of lpik may have.
MAX_LINES = 400


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def modules() -> dict[str, Path]:
    return {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def layer(name: str) -> int:
    best, rank = -1, -1
    for i, prefixes in enumerate(LAYERS):
        for prefix in prefixes:
            if (name == prefix or name.startswith(prefix + ".")) and len(prefix) > best:
                best, rank = len(prefix), i
    assert rank >= 0, f"{name} is in no layer"
    return rank


def imports(path: Path, *, top_level_only: bool) -> set[str]:
    """The lpik(-bench) modules ``path`` imports, resolved to module names."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    nodes = tree.body if top_level_only else list(ast.walk(tree))
    found: set[str] = set()
    known = modules()
    for node in nodes:
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            for alias in node.names:
                sub = f"{node.module}.{alias.name}"
                found.add(sub if sub in known else node.module)
    return {n for n in found if n.split(".")[0] in ("lpik", "lpik_bench")}


def test_every_module_is_in_a_layer_and_imports_only_downward() -> None:
    wrong = []
    for name, path in modules().items():
        for target in imports(path, top_level_only=True):
            if target.startswith("lpik_bench") or layer(target) > layer(name):
                wrong.append(f"{name} -> {target}")
    assert not wrong, "imports against the layers: " + ", ".join(wrong)


def test_no_import_cycles() -> None:
    graph = {name: imports(path, top_level_only=True) for name, path in modules().items()}
    state: dict[str, int] = {}

    def visit(node: str, trail: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                cycle = trail[trail.index(nxt) :] + [nxt] if nxt in trail else [node, nxt]
                pytest.fail("import cycle: " + " -> ".join(cycle))
            if nxt in graph and state.get(nxt) is None:
                visit(nxt, [*trail, nxt])
        state[node] = 2

    for name in graph:
        if state.get(name) is None:
            visit(name, [name])


def test_lpik_never_imports_the_benchmarks_except_lpik_bench_command() -> None:
    for name, path in modules().items():
        if name != "lpik.cli.bench":
            assert not any(
                t.startswith("lpik_bench") for t in imports(path, top_level_only=False)
            ), name


@pytest.mark.parametrize("root", [PACKAGE, BENCH], ids=["lpik", "lpik_bench"])
def test_no_module_is_over_the_size(root: Path) -> None:
    sizes = {p.name: len(p.read_text(encoding="utf-8").splitlines()) for p in root.rglob("*.py")}
    big = {name: n for name, n in sizes.items() if n > MAX_LINES}
    assert not big, f"modules over {MAX_LINES} lines: {big}"


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
