"""The documentation site builds with every warning an error (broken links and references fail)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


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


def test_every_page_is_in_the_navigation() -> None:
    nav = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    for page in sorted((ROOT / "docs").glob("*.md")):
        assert page.name in nav, page.name


def test_every_qualified_reference_in_a_docstring_resolves() -> None:
    """The site shows Sphinx roles as code (tools/griffe_sphinx_roles.py); the names they
    give must still name objects of lpik."""
    import importlib
    import re

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
