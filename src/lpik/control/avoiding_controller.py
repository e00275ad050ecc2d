"""The compiled LP2 controller with a scene: :class:`AvoidingLp2Controller`.

A scene's distance rows are one more limit of :class:`~lpik.control.controller.Lp2Controller`
(its ``scene`` argument, :class:`~lpik.control.controller.SceneRows`); this
class is that controller with the scene as its second argument. With the
damper alone (``mechanism="rows"``) the distances, the rows and the LP2 step
are one compiled call (:mod:`lpik.fast.avoiding_step`, with distance kernels
held equal to coal); with the potential field (the paper's eq. 3, after
Khatib 1986) the distances come from coal in Python
(:mod:`lpik.collision.distance`), which also writes the step's ``f``, and the
LP2 step is the compiled one. :meth:`~lpik.control.controller.Lp2Controller.problem`
always builds the step's problem through coal and the numpy layers; tests
hold each compiled step equal to :func:`lpik.methods.lp2.lp2` on that problem.

From a state with a pair inside the safety distance (or overlapping), every
step is the recovery of :mod:`lpik.collision.recovery` (status ``recovering``,
naming the pair, the distance growing back at the damper's rate): the
compiled step where it keeps the direction and the rows, else the recovery
step on the step's problem, its LP compiled
(:func:`lpik.fast.progress.least_error`); the recovery stage is
:class:`~lpik.control.controller.Lp2Controller`'s, for every controller with a scene.
"""

from __future__ import annotations

from typing import Any

from numpy.typing import ArrayLike

from lpik.collision.avoidance import INACTIVE_RHS
from lpik.control.controller import Lp2Controller, SceneRows, StateRows
from lpik.robots.base import TaskModel

__all__ = ["INACTIVE_RHS", "AvoidingLp2Controller", "SceneRows", "StateRows"]


class AvoidingLp2Controller(Lp2Controller):
    """Compiled LP2 steps that keep a scene's distances (and, optionally, its field).

    Args:
        model: A task over a :class:`~lpik.robots.chain.SerialChain` (as for
            :class:`~lpik.control.controller.Lp2Controller`).
        scene: A :class:`~lpik.collision.Scene` (the damper's rows) or a
            :class:`~lpik.collision.CollisionAvoidance` (rows, field or both).
        home: Configuration at which touching self-collision pairs are dropped
            (used when ``scene`` is a Scene); None: only the pairs that touch
            everywhere are.
        dt: Control period [s].
        compiled_distances: Compute the distances, the damper's rows and the potential
            field's force inside the compiled step (False: through coal in Python).
        **options: The other arguments of :class:`~lpik.control.controller.Lp2Controller`
            (not ``G``, ``h``, ``row_labels``: the rows are the scene's).

    Raises:
        ValueError: For a missing scene, or a model or options the compiled path does not take.
    """

    def __init__(
        self, model: TaskModel, scene: Any, home: ArrayLike | None = None, *, dt: float,
        compiled_distances: bool = True, **options: Any,
    ) -> None:  # fmt: skip
        if scene is None:
            raise ValueError("scene: expected a Scene or a CollisionAvoidance, got None")
        super().__init__(model, dt=dt, scene=scene, home=home,
                         compiled_distances=compiled_distances, **options)  # fmt: skip
