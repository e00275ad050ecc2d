"""The compiled LP2 controller with collision avoidance: distance rows written in per step.

:class:`AvoidingLp2Controller` wraps :class:`~lpik.control.controller.Lp2Controller`.
The controller's fused step takes its extra rows ``G q <= h`` from a block of
its state buffer (:mod:`lpik.fast.layout`, ``ROWS_G`` and ``ROWS_H``); this
wrapper reserves one row per pair of bodies it watches (robot-obstacle pairs,
then the self-collision pairs) and, before each compiled call, writes the
velocity damper's rows (Faverjon and Tournassoud 1987,
:class:`lpik.collision.DistanceRows`) of the pairs within the influence
distance, the others as ``0 q <= INACTIVE_RHS``, which never binds. With the
potential field (the paper's eq. 3, after Khatib 1986) it writes the step's
``f`` into the criterion's block as well. Distances come from coal in Python
(:mod:`lpik.collision.distance`); the LP2 step itself is the compiled one.
Tests hold each step equal to :func:`lpik.methods.lp2.lp2` on the problem that
:func:`lpik.limits.build_problem` builds with the same rows and force.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from lpik.collision import CollisionAvoidance, DistanceRows
from lpik.collision.model import as_avoidance
from lpik.control.controller import Lp2Controller
from lpik.fast import layout
from lpik.limits import LinearRows
from lpik.problem import Problem
from lpik.result import Result
from lpik.robots.base import TaskModel

#: Right-hand side of a reserved row whose pair is beyond the influence distance: ``0 <= 1e9``.
INACTIVE_RHS = 1e9


class AvoidingLp2Controller:
    """Compiled LP2 steps that keep a scene's distances (and, optionally, its field).

    Args:
        model: A task over a :class:`~lpik.robots.chain.SerialChain` (as for
            :class:`~lpik.control.controller.Lp2Controller`).
        scene: A :class:`~lpik.collision.Scene` (the damper's rows) or a
            :class:`~lpik.collision.CollisionAvoidance` (rows, field or both).
        home: Configuration at which touching self-collision pairs are dropped
            (used when ``scene`` is a Scene); None: none dropped.
        dt: Control period [s].
        **options: The other arguments of :class:`~lpik.control.controller.Lp2Controller`
            (not ``G``, ``h``, ``row_labels``: the rows are the scene's).

    Raises:
        ValueError: For a model or options the compiled path does not take.
    """

    def __init__(
        self, model: TaskModel, scene: Any, home: ArrayLike | None = None, *, dt: float,
        **options: Any,
    ) -> None:  # fmt: skip
        for key in ("G", "h", "row_labels"):
            if key in options:
                raise ValueError(f"{key}: the rows of an AvoidingLp2Controller are its scene's")
        avoid = as_avoidance(model, scene, None if home is None else np.asarray(home, float))
        if not isinstance(avoid, CollisionAvoidance):
            raise ValueError("scene: expected a Scene or a CollisionAvoidance, got None")
        self.avoidance = avoid
        self._rows = DistanceRows(avoid.proximities, avoid.approach_speed)
        probe = avoid.proximities.at(np.clip(np.zeros(model.n_joints), model.q_min, model.q_max))
        self.pair_labels = tuple(p.label for p in probe)
        n, r = model.n_joints, len(self.pair_labels)
        self._index = {label: k for k, label in enumerate(self.pair_labels)}
        self._G, self._h = np.zeros((r, n)), np.full(r, INACTIVE_RHS)
        self.controller = Lp2Controller(
            model, dt=dt, G=self._G, h=self._h, row_labels=self.pair_labels, **options
        )
        self._base_limits = self.controller.limits[:-1]
        self._f0 = np.zeros(n) if options.get("f") is None else np.asarray(options["f"], float)
        state = self.controller._state  # the fused step's buffer (lpik.fast.layout)
        g0, h0 = int(state[layout.ROWS_G]), int(state[layout.ROWS_H])
        self._G_view = state[g0 : g0 + r * n].reshape(r, n)
        self._h_view = state[h0 : h0 + r]
        self._f_view = state[int(state[layout.F_REF]) : int(state[layout.F_REF]) + n]

    def _write(self, q0: np.ndarray) -> None:
        """This step's rows (and force) into the state buffer and the numpy path's limits."""
        dt = self.controller.dt
        G, h, names = self._rows.rows(q0, dt) if self.avoidance.mechanism != "field" else (
            np.zeros((0, q0.size)), np.zeros(0), ())  # fmt: skip
        self._G[:] = 0.0
        self._h[:] = INACTIVE_RHS
        for row, rhs, name in zip(G, h, names):
            k = self._index[name]
            self._G[k], self._h[k] = row, rhs
        self._G_view[:] = self._G
        self._h_view[:] = self._h
        weights = self.avoidance.weights(
            {"f": self._f0}, q0, dt, self.controller.model.jacobian(q0)
        )
        self._f_view[:] = weights["f"]
        self.controller._weights["f"] = weights["f"]
        self.controller.limits = (
            *self._base_limits,
            LinearRows(self._G.copy(), self._h.copy(), self.pair_labels),
        )

    def step(self, q0: ArrayLike, target: Any, q_prev: ArrayLike | None = None) -> Result:
        """One compiled LP2 step from ``q0`` towards ``target`` keeping the scene's distances."""
        q = np.ascontiguousarray(q0, dtype=np.float64)
        if q.shape != (self.controller.model.n_joints,) or not np.isfinite(q).all():
            raise ValueError(f"q0: must be {self.controller.model.n_joints} finite coordinates")
        self._write(q)
        return self.controller.step(q, target, q_prev)

    def problem(self, q0: ArrayLike, target: Any, q_prev: ArrayLike | None = None) -> Problem:
        """The step's problem as the numpy layers build it, with the same rows and force."""
        q = np.asarray(q0, dtype=np.float64)
        self._write(q)
        return self.controller.problem(q, target, q_prev)
