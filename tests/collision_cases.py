"""Shared scenes and arms of the collision tests."""

from __future__ import annotations

import numpy as np

from lpik.collision import scene_from_dict
from lpik.robots.planar import planar_arm

Q0 = np.radians([60.0, -30.0, -30.0, -30.0])
PULL_IN = np.array([0.2, 0.8660254, 0.0])


def arm():  # type: ignore[no-untyped-def]
    return planar_arm([1.0] * 4, q_min=-np.pi, q_max=np.pi, qd_max=1.0)


def circle_scene(center, radius, d_s=0.05, d_i=0.3):  # type: ignore[no-untyped-def]
    return scene_from_dict(
        {
            "obstacles": [
                {"name": "ball", "type": "sphere", "center": list(center), "radius": radius}
            ],
            "safety_distance": d_s,
            "influence_distance": d_i,
        }
    )


def lp_paths():  # type: ignore[no-untyped-def]
    """The recovery's two LPs on each path, by name: the least-error LP and the
    largest-share LP through HiGHS (numpy) and the compiled simplex (call it after
    ``pytest.importorskip("lpik.fast.progress")``: the compiled path needs numba)."""
    from lpik.collision.recovery import highs_largest_share
    from lpik.control.controller import compiled_largest_share, compiled_least_error
    from lpik.methods.progress import least_error_lp

    return {
        "numpy": (least_error_lp, highs_largest_share),
        "compiled": (compiled_least_error, compiled_largest_share),
    }
