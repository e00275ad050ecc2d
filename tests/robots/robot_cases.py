"""Helpers of the 3-D robot tests: small URDFs written inline, random configurations."""

from __future__ import annotations

import numpy as np

from lpik.robots.chain import SerialChain
from lpik.robots.registry import robot_names


def joint(
    name: str,
    parent: str,
    child: str,
    kind: str = "revolute",
    xyz: str = "0 0 0.1",
    rpy: str = "0 0 0",
    axis: str | None = "0 0 1",
    limit: str | None = 'lower="-2" upper="2" velocity="1" effort="1"',
    extra: str = "",
) -> str:
    """One <joint> element."""
    parts = [
        f'<joint name="{name}" type="{kind}">',
        f'<origin xyz="{xyz}" rpy="{rpy}"/>',
        f'<parent link="{parent}"/><child link="{child}"/>',
    ]
    if axis is not None:
        parts.append(f'<axis xyz="{axis}"/>')
    if limit is not None:
        parts.append(f"<limit {limit}/>")
    parts.append(extra + "</joint>")
    return "".join(parts)


def robot(links: list[str], joints: list[str], name: str = "test") -> str:
    """A <robot> with the given link names and joint elements."""
    body = "".join(f'<link name="{n}"/>' for n in links) + "".join(joints)
    return f'<?xml version="1.0"?><robot name="{name}">{body}</robot>'


#: Every joint type on one chain, odd axes and rotations, plus an off-chain branch.
MIXED_URDF = robot(
    ["base", "l1", "l2", "l3", "l4", "l5", "flange", "tool", "branch"],
    [
        joint("fix0", "base", "l1", "fixed", xyz="0.1 0 0.2", rpy="0.3 0 0.5", limit=None),
        joint("rev", "l1", "l2", xyz="0 0.1 0.3", rpy="0.2 -0.4 0.1", axis="1 1 1"),
        joint(
            "pri",
            "l2",
            "l3",
            "prismatic",
            xyz="0.2 0 0",
            rpy="0 0.5 0",
            axis="0 -1 0",
            limit='lower="-0.3" upper="0.3" velocity="0.5" effort="1"',
        ),
        joint(
            "cont",
            "l3",
            "l4",
            "continuous",
            xyz="0 0 0.25",
            rpy="1.2 0 -0.3",
            axis="0 0.6 0.8",
            limit=None,
        ),
        joint("rev2", "l4", "l5", xyz="0.15 0.05 0", rpy="0 0 0", axis="0 0 -1"),
        joint("fix1", "l5", "flange", "fixed", xyz="0 0 0.1", rpy="3.0 0.1 0.2", limit=None),
        joint("fix2", "flange", "tool", "fixed", xyz="0.05 0 0.02", limit=None),
        joint("float", "l2", "branch", "floating", limit=None),
    ],
    name="mixed",
)

ROBOT_NAMES = robot_names()


def random_configurations(chain: SerialChain, count: int, seed: int = 0) -> np.ndarray:
    """Configurations drawn uniformly inside the end-stops (within +-pi where unbounded)."""
    rng = np.random.default_rng(seed)
    lo = np.where(np.isfinite(chain.q_min), chain.q_min, -np.pi)
    hi = np.where(np.isfinite(chain.q_max), chain.q_max, np.pi)
    return rng.uniform(lo, hi, size=(count, chain.n_joints))
