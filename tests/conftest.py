"""Shared configuration and fixtures of the test suite.

Hypothesis profiles (select with ``HYPOTHESIS_PROFILE=<name>``):

- ``ci`` (default): hypothesis's default number of examples, no deadline
  (a 2-core CI machine must not make timing flaky);
- ``dev``: a tenth of the examples, for quick local runs;
- ``thorough``: ten times the examples, for a nightly or a pre-release run.

Property tests of the core ask for ``core_strategies.examples(n)``, which
scales ``n`` with the loaded profile.

The suite runs on every core (pytest-xdist, ``-n auto`` in ``pyproject.toml``, at
most :data:`MAX_WORKERS` workers, a file per worker at a time); ``-n 0`` runs it in
one process (for ``pdb``, or a single test).
"""

from __future__ import annotations

import os
from importlib.util import find_spec

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

from lpik.robots.base import TaskModel
from lpik.robots.planar import planar_arm

settings.register_profile("ci", deadline=None, print_blob=True)
settings.register_profile(
    "dev", deadline=None, max_examples=10, suppress_health_check=[HealthCheck.too_slow]
)
settings.register_profile("thorough", deadline=None, max_examples=1000, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

os.environ.setdefault("MPLBACKEND", "Agg")
# Every controller compiles when it is built (lpik.control.warmup): the tests of the
# compiled step must run it, not the numpy engine that steps while a child compiles.
# tests/test_warmup.py builds its background controllers with compile="background".
os.environ["LPIK_COMPILE"] = "now"

#: At most this many pytest-xdist workers for ``-n auto``: each compiles what its tests
#: use on an empty numba cache (a GiB or so of memory at its peak).
MAX_WORKERS = 4


def pytest_xdist_auto_num_workers(config: pytest.Config) -> int:
    """``-n auto``: one worker per core, at most :data:`MAX_WORKERS`."""
    return max(1, min(MAX_WORKERS, os.cpu_count() or 1))


def pytest_configure(config: pytest.Config) -> None:
    """Before the xdist workers start: every kernel compiled once, in as many processes.

    Each worker would otherwise compile the kernels its tests use on an empty
    numba cache, the same kernels in every worker (about 340 s of the suite's
    wall time on 2 cores); ``lpik compile --jobs N`` (the same code) compiles
    each once into the disk cache, where the workers load it. On a warm cache it
    costs a few seconds. Not in a worker, and not in one process (``-n 0``).
    """
    workers = getattr(config.option, "numprocesses", None)
    if hasattr(config, "workerinput") or not isinstance(workers, int) or workers < 2:
        return
    if find_spec("numba") is None:
        return
    from lpik.cli.compile import compile_kernels

    compile_kernels(jobs=workers)


#: The paper's start configuration (sec. 4, Fig. 2) [rad].
PAPER_Q0 = np.radians([60.0, -30.0, -30.0, -30.0])


@pytest.fixture
def paper_arm() -> TaskModel:
    """The paper's planar 4-link arm, links 1 m each, joints within +-180 deg."""
    return planar_arm([1.0, 1.0, 1.0, 1.0], q_min=-np.pi, q_max=np.pi, qd_max=1.0)


@pytest.fixture
def paper_q0() -> np.ndarray:
    """The paper's start configuration (60, -30, -30, -30) deg [rad]."""
    return PAPER_Q0.copy()
