"""The documentation site: it builds strict, names every public object, and its code runs.

Every fenced block of ``docs/*.md`` is one of:

- ``python``: run, page by page, in order, in one namespace per page (in a
  temporary folder). A block under the comment
  ``<!-- peer code: MODULE -->`` is another library's code shown beside lpik's:
  compiled always, run only where ``MODULE`` is installed.
- ``sh``: every command is checked. ``lpik simulate``, ``solve`` and ``robots``
  run in-process; ``lpik`` commands that serve or run for minutes (``console``,
  ``reproduce``, ``bench``, ``compile``) are parsed by lpik's own parser; a
  ``python -m MODULE ARGS`` is parsed by that module's parser; ``pip install``
  must name extras that ``pyproject.toml`` has; ``cd`` a folder of the repository.
- ``json``: a scene document, read by lpik's scene reader.
- ``text`` or no language: output or a diagram, not code. A ``text`` block
  right after a ``python`` or ``sh`` block is what that block prints (``...``
  in a line stands for anything), and is checked.

The reference page must document every name of ``lpik.__all__``, and show
defaults as values (``tools/griffe_default_values.py``).
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import importlib.util
import io
import os
import re
import shlex
import subprocess
import sys
import textwrap
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
#: A fenced block, at any indentation: its language word and its text.
FENCE = re.compile(
    r"^(?P<indent>[ ]*)```(?P<lang>[\w-]*)[^\n]*\n(?P<body>.*?)^(?P=indent)```[ ]*$", re.M | re.S
)
#: The comment that marks the next block as another library's code.
PEER = re.compile(r"<!--\s*peer code:\s*(?P<module>[\w.]+)\s*-->\s*$")
#: Optional dependencies: a page whose code needs a missing one is skipped, not failed.
OPTIONAL = ("numba", "coal", "mujoco", "pinocchio", "matplotlib", "viser", "websockets", "mink")
#: ``lpik`` subcommands the tests run; the others are parsed only.
RUN_LPIK = ("simulate", "solve", "robots")


@dataclass(frozen=True)
class Block:
    """One fenced block of a page."""

    page: str
    line: int
    lang: str
    body: str
    peer: str | None
    output: str | None  # the text block right after a Python or shell block: what it prints


def page_blocks(path: Path) -> list[Block]:
    """The fenced blocks of one page, in order."""
    text = path.read_text(encoding="utf-8")
    found = list(FENCE.finditer(text))
    blocks = []
    for k, match in enumerate(found):
        before = text[: match.start()].rstrip("\n").rsplit("\n", 1)[-1]
        peer = PEER.search(before)
        output = None
        lang = match.group("lang") or "text"
        if lang in ("python", "sh") and k + 1 < len(found):
            following = found[k + 1]
            between = text[match.end() : following.start()]
            if following.group("lang") == "text" and not between.strip():
                output = textwrap.dedent(following.group("body"))
        blocks.append(
            Block(
                page=path.name,
                line=text.count("\n", 0, match.start()) + 1,
                lang=lang,
                body=textwrap.dedent(match.group("body")),
                peer=peer.group("module") if peer else None,
                output=output,
            )
        )
    return blocks


BLOCKS = [block for page in sorted(DOCS.glob("*.md")) for block in page_blocks(page)]
PYTHON_PAGES = sorted({b.page for b in BLOCKS if b.lang == "python"})
SHELL_BLOCKS = [b for b in BLOCKS if b.lang == "sh"]
JSON_BLOCKS = [b for b in BLOCKS if b.lang == "json"]


def assert_prints(printed: str, block: Block, where: str) -> None:
    """What a block printed is the text block below it (``...`` in it stands for anything)."""
    assert block.output is not None
    shown = [line.rstrip() for line in block.output.strip("\n").splitlines()]
    got = [line.rstrip() for line in printed.strip("\n").splitlines()]
    patterns = [re.compile(".*".join(map(re.escape, line.split("...")))) for line in shown]
    matches = len(got) == len(shown) and all(p.fullmatch(g) for p, g in zip(patterns, got))
    assert matches, f"{where} prints\n{printed}\nnot what the page shows below it:\n{block.output}"


def test_every_block_is_of_a_known_kind() -> None:
    kinds = ("python", "sh", "json", "text")
    unknown = [(b.page, b.line, b.lang) for b in BLOCKS if b.lang not in kinds]
    assert unknown == []
    assert sum(b.lang == "python" for b in BLOCKS) >= 10
    assert sum(b.lang == "sh" for b in BLOCKS) >= 6
    peers = [b for b in BLOCKS if b.peer is not None]
    assert all(b.lang == "python" for b in peers)
    coming_from = [b for b in BLOCKS if b.page == "coming-from.md" and b.lang == "python"]
    assert any(b.peer == "mink" for b in coming_from), "the mink loop is marked as mink's code"
    assert any(b.peer is None for b in coming_from), "lpik's side of the migration runs"


def _skip_for_missing(exc: BaseException, page: str) -> None:
    """Skip the page when ``exc`` says an optional dependency is missing; else re-raise."""
    from lpik.exceptions import MissingBackendError

    missing = getattr(exc, "name", None) or ""
    if isinstance(exc, ModuleNotFoundError) and missing.split(".")[0] in OPTIONAL:
        pytest.skip(f"{page} needs {missing}")
    if isinstance(exc, MissingBackendError):
        pytest.skip(f"{page}: {exc}")
    raise exc


@pytest.mark.parametrize("page", PYTHON_PAGES)
def test_the_python_blocks_of_a_page_run(page: str, tmp_path, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.chdir(tmp_path)  # blocks write files (a CSV log): never into the checkout
    namespace: dict = {"__name__": f"docs_{page.removesuffix('.md').replace('-', '_')}"}
    for block in (b for b in BLOCKS if b.page == page and b.lang == "python"):
        where = f"docs/{page}:{block.line}"
        code = compile(block.body, where, "exec")
        if block.peer is not None and importlib.util.find_spec(block.peer) is None:
            continue  # another library's code, compiled above; it runs where that is installed
        printed = io.StringIO()
        try:
            with contextlib.redirect_stdout(printed):
                exec(code, namespace)
        except Exception as exc:
            _skip_for_missing(exc, page)
        if block.output is not None:
            assert_prints(printed.getvalue(), block, where)


class _Parsed(BaseException):
    """Raised by the patched ``parse_args``: the arguments parsed, nothing ran."""


@contextlib.contextmanager
def _parse_only():
    """``argparse`` parses as usual, then stops the program before it does anything."""
    original = argparse.ArgumentParser.parse_args

    def parse_args(self, args=None, namespace=None):  # type: ignore[no-untyped-def]
        original(self, args, namespace)
        raise _Parsed

    argparse.ArgumentParser.parse_args = parse_args  # type: ignore[method-assign]
    try:
        yield
    finally:
        argparse.ArgumentParser.parse_args = original  # type: ignore[method-assign]


def _shell_commands(body: str) -> list[list[str]]:
    """The commands of a shell block: lines joined at ``\\``, comments dropped, split at ``&&``."""
    commands = []
    for line in body.replace("\\\n", " ").splitlines():
        words = shlex.split(line, comments=True)
        while words:
            head = words.index("&&") if "&&" in words else len(words)
            commands.append(words[:head])
            words = words[head + 1 :]
    return [c for c in commands if c]


def _check_lpik(args: list[str], where: str) -> str:
    """Run ``lpik args`` (or parse it only, :data:`RUN_LPIK`); what it printed on stdout."""
    from lpik.cli.main import build_parser, main

    if args and args[0] in RUN_LPIK:
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            status = main(args)
        assert status == 0, f"{where}: lpik {shlex.join(args)} -> {status}: {err.getvalue()}"
        return out.getvalue()
    with _parse_only(), pytest.raises(_Parsed):
        build_parser().parse_args(args)
    return ""


def _check_module(module: str, args: list[str], where: str) -> None:
    """``python -m module args``: the module exists and its parser takes ``args``."""
    assert importlib.util.find_spec(module) is not None, f"{where}: no module {module}"
    try:
        loaded = importlib.import_module(module)
    except ModuleNotFoundError as exc:
        if (exc.name or "").split(".")[0] in OPTIONAL:
            return  # it exists; its parser needs an optional dependency to import
        raise
    assert callable(getattr(loaded, "main", None)), f"{where}: {module} has no main()"
    with _parse_only(), pytest.raises(_Parsed):
        loaded.main(args)


def _extras() -> set[str]:
    """The extras of ``pyproject.toml`` (its ``[project.optional-dependencies]`` keys)."""
    text = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    section = text.split("[project.optional-dependencies]", 1)[1].split("\n[", 1)[0]
    return set(re.findall(r"^([\w-]+)\s*=", section, re.M))


def _check_pip(args: list[str], where: str) -> None:
    assert args[:1] == ["install"], f"{where}: pip {shlex.join(args)}"
    extras = _extras()
    for word in args[1:]:
        named = re.fullmatch(r"\.\[([\w,-]+)\]", word)
        if named:
            unknown = set(named.group(1).split(",")) - extras
            assert not unknown, f"{where}: no extra {unknown} in pyproject.toml"


@pytest.mark.parametrize("block", SHELL_BLOCKS, ids=lambda b: f"{b.page}:{b.line}")
def test_the_commands_of_a_shell_block_are_checked(block: Block, tmp_path, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    where = f"docs/{block.page}:{block.line}"
    monkeypatch.chdir(tmp_path)
    folder = ROOT  # where a `cd` in the block leads, inside the repository
    printed = ""
    for words in _shell_commands(block.body):
        name, args = Path(words[0]).name, words[1:]
        if name == "lpik":
            if args[:1] == ["simulate"] and ({"--scene", "--avoid"} & set(args)):
                pytest.importorskip("coal")  # the distances of a scene
            printed += _check_lpik(args, where)
        elif name.startswith("python") and args[:2] == ["-m", "venv"]:
            pass
        elif name.startswith("python") and args[:1] == ["-m"]:
            _check_module(args[1], args[2:], where)
        elif name.startswith("python"):
            assert (folder / args[0]).is_file(), f"{where}: no script {args[0]}"
        elif name == "pip":
            _check_pip(args, where)
        elif name == "cd":
            folder = (folder / args[0]).resolve()
            assert folder.is_dir() and ROOT in (folder, *folder.parents), f"{where}: cd {args[0]}"
        elif name == "mkdocs":
            assert args[:1] in (["serve"], ["build"]), f"{where}: mkdocs {shlex.join(args)}"
        else:
            raise AssertionError(f"{where}: a command the tests do not know: {shlex.join(words)}")
    if block.output is not None:
        assert_prints(printed, block, where)


@pytest.mark.parametrize("block", JSON_BLOCKS, ids=lambda b: f"{b.page}:{b.line}")
def test_a_json_block_is_what_lpik_reads(block: Block) -> None:
    """A scene document shown on a page is one that lpik reads."""
    import json

    from lpik.collision import scene_from_dict

    document = json.loads(block.body)
    assert "obstacles" in document, f"docs/{block.page}:{block.line}: what does lpik read it as?"
    scene_from_dict(document)


def test_the_site_builds_strict(tmp_path) -> None:  # type: ignore[no-untyped-def]
    for module in ("mkdocs", "mkdocstrings", "mkdocstrings_handlers.python", "material"):
        pytest.importorskip(module, reason=f'{module} is not installed: pip install -e ".[docs]"')
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    done = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
        cwd=ROOT, capture_output=True, text=True, env=env, timeout=300,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    reference = (tmp_path / "site" / "reference" / "index.html").read_text(encoding="utf-8")
    for name in ("lpik.control.controller.Lp2Controller", "lpik.labels.Binding",
                 "lpik.limits.build_problem"):  # fmt: skip
        assert f'id="{name}"' in reference, name
    for path in _documented_paths():
        assert f'id="{path}"' in reference, path
    # defaults are shown as values (tools/griffe_default_values.py), not as constants' names
    cells = re.findall(r"<td>\s*<code>([^<]*)</code>\s*</td>", reference)
    assert "0.5" in cells and "&#39;lp2s&#39;" in cells
    assert not [c for c in cells if re.fullmatch(r"[A-Z][A-Z0-9_]+", c) and c != "None"]
    signatures = re.sub(r"<[^>]+>", "", reference)
    assert "v_max=0.5, w_max=1.0" in signatures  # Lp2Controller's, merged from __init__
    assert re.findall(r"[(,]\s*\w+=[A-Z][A-Z0-9_]+\b", signatures) == []


def _directives() -> dict[str, tuple[str, ...]]:
    """The reference page's ``::: path`` directives and the members each lists."""
    text = (DOCS / "reference.md").read_text(encoding="utf-8")
    found: dict[str, tuple[str, ...]] = {}
    for match in re.finditer(r"^::: ([\w.]+)\n((?:[ ]{4}.*\n|\n(?=[ ]{4}))*)", text, re.M):
        members = re.findall(r"^\s+- (\w+)\s*$", match.group(2), re.M)
        found[match.group(1)] = tuple(members)
    return found


def _documented_paths() -> list[str]:
    """Every object the reference page documents by name (a directive, or one of its members)."""
    paths = []
    for path, members in _directives().items():
        paths += [f"{path}.{m}" for m in members] if members else [path]
    return paths


def _resolve(path: str) -> object:
    parts = path.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for attr in parts[i:]:
            obj = getattr(obj, attr)
        return obj
    raise ImportError(path)


#: Public names beyond ``lpik.__all__`` that the reference must document, where they live.
MORE_PUBLIC = (
    "lpik.control.avoiding_controller.AvoidingLp2Controller",
    "lpik.collision.avoidance.DistanceRows",
    "lpik.collision.avoidance.CollisionAvoidance",
    "lpik.collision.model.collision_avoidance",
    "lpik.collision.shapes.Scene",
    "lpik.collision.shapes.Obstacle",
    "lpik.collision.scene_json.load_scene",
    "lpik.control.stepper.Stepper",
)


def test_every_public_name_is_in_the_reference() -> None:
    """Each name of ``lpik.__all__`` (and the collision and batch classes) has its entry."""
    pytest.importorskip("numba")  # lpik's compiled names are imported on first use
    import lpik

    documented = {path: _resolve(path) for path in _documented_paths()}
    missing = []
    for name in lpik.__all__:
        obj = getattr(lpik, name)
        if not any(p.rsplit(".", 1)[-1] == name and o is obj for p, o in documented.items()):
            missing.append(name)
    assert missing == [], f"docs/reference.md documents no {missing}"
    assert [path for path in MORE_PUBLIC if path not in documented] == []


def test_every_page_is_in_the_navigation() -> None:
    nav = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    for page in sorted((ROOT / "docs").glob("*.md")):
        assert page.name in nav, page.name


def test_every_qualified_reference_in_a_docstring_resolves() -> None:
    """The site shows Sphinx roles as code (tools/griffe_sphinx_roles.py); the names they
    give must still name objects of lpik."""
    role = re.compile(r":(?:class|func|meth|mod|data|attr|exc|obj):`~?(lpik[\w.]*)`")
    names = set()
    for path in (ROOT / "src" / "lpik").rglob("*.py"):
        names |= set(role.findall(path.read_text(encoding="utf-8")))
    assert len(names) > 50

    def resolves(name: str) -> bool:
        parts = name.split(".")
        for i in range(len(parts), 0, -1):
            try:
                obj = importlib.import_module(".".join(parts[:i]))
            except ImportError:
                continue
            for attr in parts[i:]:
                if not hasattr(obj, attr) and attr not in getattr(obj, "__dataclass_fields__", {}):
                    return False
                obj = getattr(obj, attr, None)
            return True
        return False

    assert [name for name in sorted(names) if not resolves(name)] == []


def test_every_test_a_page_names_exists() -> None:
    """A page that cites a test (``test_x.py::test_y``, or a bare ``test_y`` after it in
    the same line) names one that is there: a renamed test leaves no stale citation."""
    defined: dict[str, set[str]] = {}
    for path in (ROOT / "tests").glob("test_*.py"):
        defined[path.name] = set(re.findall(r"^(?:async )?def (test_\w+)", path.read_text(), re.M))
    every = set().union(*defined.values())
    missing = []
    for page in [ROOT / "README.md", *sorted(DOCS.rglob("*.md"))]:
        for number, line in enumerate(page.read_text().splitlines(), 1):
            for file, name in re.findall(r"`(?:tests/)?(test_\w+\.py)::(test_\w+)", line):
                if name not in defined.get(file, set()):
                    missing.append(f"{page.name}:{number}: {file}::{name}")
            for name in re.findall(r"`(test_\w+)`", line):
                if name not in every:
                    missing.append(f"{page.name}:{number}: {name}")
    assert not missing, "\n".join(missing)
