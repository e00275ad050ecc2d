"""The compiled LP2 controller with collision avoidance: distance rows written in per step.

:class:`AvoidingLp2Controller` wraps :class:`~lpik.control.controller.Lp2Controller`.
The controller's fused step takes its extra rows ``G q <= h`` from a block of
its state buffer (:mod:`lpik.fast.layout`, ``ROWS_G`` and ``ROWS_H``); this
wrapper reserves one row per pair of bodies it watches (robot-obstacle pairs,
then the self-collision pairs) and fills them each step with the velocity
damper's rows (Faverjon and Tournassoud 1987, :class:`lpik.collision.DistanceRows`)
of the pairs within the influence distance, the others as ``0 q <= INACTIVE_RHS``,
which never binds.

With the damper alone (``mechanism="rows"``) the distances, the rows and the
LP2 step are one compiled call (:mod:`lpik.fast.avoiding_step`, with distance
kernels held equal to coal). With the potential field (the paper's eq. 3,
after Khatib 1986) the distances come from coal in Python
(:mod:`lpik.collision.distance`), which also writes the step's ``f`` into the
criterion's block, and the LP2 step is the compiled one. :meth:`problem`
always builds the step's problem through coal and the numpy layers; tests hold
each compiled step equal to :func:`lpik.methods.lp2.lp2` on that problem.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from lpik.collision import CollisionAvoidance, DistanceRows
from lpik.collision.avoidance import INACTIVE_RHS
from lpik.collision.model import as_avoidance
from lpik.control.controller import Lp2Controller
from lpik.fast import layout
from lpik.limits import Piece, StepContext
from lpik.problem import Problem
from lpik.result import Result
from lpik.robots.base import TaskModel
from lpik.types import FloatArray

__all__ = ["INACTIVE_RHS", "AvoidingLp2Controller", "StateRows"]


@dataclass(frozen=True, eq=False)
class StateRows:
    """The rows the last step left in the state buffer, as a limit of the numpy layers.

    Attributes:
        G: View of the state's rows block, (r, n).
        h: View of their right-hand side, (r,).
        labels: One label per row.
    """

    G: FloatArray
    h: FloatArray
    labels: tuple[str, ...]

    def apply(self, context: StepContext) -> Piece:
        """The rows as they are now (copies)."""
        return Piece(G=self.G.copy(), h=self.h.copy(), row_labels=self.labels)


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
        compiled_distances: With the damper alone, compute the distances and rows inside
            the compiled step (False: through coal in Python, as with the field).
        **options: The other arguments of :class:`~lpik.control.controller.Lp2Controller`
            (not ``G``, ``h``, ``row_labels``: the rows are the scene's).

    Raises:
        ValueError: For a model or options the compiled path does not take.
    """

    def __init__(
        self, model: TaskModel, scene: Any, home: ArrayLike | None = None, *, dt: float,
        compiled_distances: bool = True, **options: Any,
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
        self.controller = Lp2Controller(
            model, dt=dt, G=np.zeros((r, n)), h=np.full(r, INACTIVE_RHS),
            row_labels=self.pair_labels, **options,
        )  # fmt: skip
        self._f0 = np.zeros(n) if options.get("f") is None else np.asarray(options["f"], float)
        state = self.controller._state  # the fused step's buffer (lpik.fast.layout)
        g0, h0 = int(state[layout.ROWS_G]), int(state[layout.ROWS_H])
        self._G_view = state[g0 : g0 + r * n].reshape(r, n)
        self._h_view = state[h0 : h0 + r]
        self._f_view = state[int(state[layout.F_REF]) : int(state[layout.F_REF]) + n]
        self.controller.limits = (
            *self.controller.limits[:-1],
            StateRows(self._G_view, self._h_view, self.pair_labels),
        )
        #: Whether distances and rows are computed inside the compiled step.
        self.compiled = avoid.mechanism == "rows" and bool(compiled_distances)
        self.found: FloatArray | None = None
        if self.compiled:
            from lpik.fast.avoiding_step import avoiding_kernel, pack_bodies

            arrays = pack_bodies(avoid.proximities, self.controller.dt, avoid.approach_speed)
            #: Each pair's distance, witness points and normal after the last step (P, 10).
            self.found = arrays[6]
            # the fused step it calls (controller.py has no room for a public hook: 400 lines)
            self.controller._kernel = partial(avoiding_kernel(), *arrays)

    def _write(self, q0: np.ndarray) -> None:
        """This step's rows (and force) by coal into the state buffer."""
        dt = self.controller.dt
        self._G_view[:] = 0.0
        self._h_view[:] = INACTIVE_RHS
        if self.avoidance.mechanism != "field":
            pairs, G, h = self._rows.pair_rows(q0, dt)
            self._G_view[pairs] = G
            self._h_view[pairs] = h
        weights = self.avoidance.weights(
            {"f": self._f0}, q0, dt, self.controller.model.jacobian(q0)
        )
        self._f_view[:] = weights["f"]
        self.controller._weights["f"] = weights["f"]

    def step(self, q0: ArrayLike, target: Any, q_prev: ArrayLike | None = None) -> Result:
        """One compiled LP2 step from ``q0`` towards ``target`` keeping the scene's distances."""
        q = np.ascontiguousarray(q0, dtype=np.float64)
        if q.shape != (self.controller.model.n_joints,) or not np.isfinite(q).all():
            raise ValueError(f"q0: must be {self.controller.model.n_joints} finite coordinates")
        if not self.compiled:
            self._write(q)
        return self.controller.step(q, target, q_prev)

    def step_into(
        self, q0: ArrayLike, target: Any, q_prev: ArrayLike | None = None, *, out: FloatArray
    ) -> float:
        """:meth:`step` without a Result: ``q`` into ``out``, ``p`` back.

        As :meth:`~lpik.control.controller.Lp2Controller.step_into` (no allocation
        when the distances are compiled).
        """
        if not self.compiled:
            q0 = np.ascontiguousarray(q0, dtype=np.float64)
            self._write(q0)
        return self.controller.step_into(q0, target, q_prev, out=out)

    @property
    def last_binding(self) -> str | None:
        """The limit that bound the last :meth:`step_into` (None: none, or no step yet)."""
        return self.controller.last_binding

    def problem(self, q0: ArrayLike, target: Any, q_prev: ArrayLike | None = None) -> Problem:
        """The step's problem as the numpy layers build it (coal), with the same rows and force."""
        q = np.asarray(q0, dtype=np.float64)
        self._write(q)
        return self.controller.problem(q, target, q_prev)
