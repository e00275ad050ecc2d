"""Fixtures of the 3-D robot tests."""

from __future__ import annotations

import pytest
from robot_cases import ROBOT_NAMES


@pytest.fixture(params=ROBOT_NAMES)
def robot_name(request: pytest.FixtureRequest) -> str:
    """Each bundled robot in turn."""
    return request.param
