"""The automatic multiplier bound (sec. 3.2), compiled for the fused step.

:func:`lpik.methods.autobound.automatic_bound` is the rule; :data:`automatic_bound`
(and :data:`singular_steps`, the floor as a stop ahead under acceleration limits,
and :data:`floor_row`, the floor as a row on the stall stage's progress step)
is that very function compiled (:func:`lpik.fast.twins.compiled_twin`), with
the one-sided Jacobi SVD of :mod:`lpik.fast.jacobi` for its singular values
and the chain's kinematics from the state buffer (:func:`state_jacobian`) for
the Jacobian at its probe. :func:`bound_in_state` runs it on the step a state
holds; the fused step (:func:`lpik.fast.step.task_step`) calls it after an
unbounded step with ``p < 1`` and solves LP2 again under the bound it finds.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from lpik.fast import layout as L
from lpik.fast.jacobi import jacobi_svd, singular_values
from lpik.fast.kinematics import chain_fk_jacobian
from lpik.fast.twins import compiled_twin, inlined_twin
from lpik.limits import AutomaticMultiplierBounds
from lpik.methods import autobound

__all__ = [
    "automatic_bound",
    "bound_in_state",
    "clearly_regular",
    "floor_in_state",
    "floor_row",
    "settings",
    "singular_steps",
    "state_jacobian",
]


@njit(cache=True)
def state_jacobian(state, q):
    """The task rows of the Jacobian at ``q`` (m, n), by the chain of the state buffer."""
    n, m = int(state[L.N]), int(state[L.M])
    T, J6, joints = np.empty((4, 4)), np.empty((6, n)), np.empty((2, n, 3))
    chain_fk_jacobian(L.tensor_at(state, L.ORIGINS, n, 4, 4), L.matrix_at(state, L.AXES, n, 3),
                      L.vector(state, L.REVOLUTE), L.matrix_at(state, L.TIP, 4, 4), q, T, J6,
                      joints)  # fmt: skip
    rows = L.vector(state, L.ROW_INDEX)
    J = np.empty((m, n))
    for k in range(m):
        for i in range(n):
            J[k, i] = J6[int(rows[k]), i]
    return J


#: The Gram matrix and its shifted Cholesky test (:func:`lpik.methods.autobound.clearly_regular`).
_cholesky = {
    "_gram": inlined_twin(autobound._gram),
    "_positive_definite": inlined_twin(autobound._positive_definite),
}
#: :func:`lpik.methods.autobound.clearly_regular`, compiled as it is (step 1's test; the
#: stall stage's :func:`lpik.methods.progress.at_speed`).
clearly_regular = inlined_twin(autobound.clearly_regular, **_cholesky)
_memo = {
    "extreme_singular_values": inlined_twin(
        autobound.extreme_singular_values,
        _singular_values=singular_values,
        clearly_regular=clearly_regular,
    ),
    "smallest_singular_value_before": inlined_twin(
        autobound.smallest_singular_value_before, _singular_values=singular_values
    ),
}

#: :func:`lpik.methods.autobound.automatic_bound`, compiled as it is.
automatic_bound = compiled_twin(
    autobound.automatic_bound,
    _task_jacobian=state_jacobian,
    _singular_values=singular_values,
    smallest_singular_value_grows=inlined_twin(
        autobound.smallest_singular_value_grows, _singular_values=singular_values, **_cholesky
    ),
    **_memo,
)


#: :func:`lpik.methods.autobound.singular_steps`, compiled as it is.
singular_steps = compiled_twin(autobound.singular_steps, **_memo)


#: :func:`lpik.methods.autobound.floor_row`, compiled as it is.
floor_row = compiled_twin(
    autobound.floor_row,
    _svd=jacobi_svd,
    _task_jacobian=state_jacobian,
    clearly_regular=clearly_regular,
)


@njit(cache=True)
def floor_in_state(state, q0, row):
    """:func:`floor_row` on the step ``state`` holds (its ``J`` and parameters): ``rhs``.

    The chain's kinematics in the state give the Jacobian at the probes.
    """
    n, m = int(state[L.N]), int(state[L.M])
    settings = L.vector(state, L.AUTO_BOUND)  # (on, approach time, activation, floor, probe)
    return floor_row(L.matrix_at(state, L.JACOBIAN, m, n), state, q0, settings[2], settings[3],
                     settings[4], state[L.DT], row)  # fmt: skip


@njit(cache=True)
def bound_in_state(state, q0, dq):
    """The rule on the step ``state`` holds (its ``J``, task rows, ``dt`` and parameters).

    ``q0`` and ``dq`` are the unbounded step's. Writes ``B_k`` into the
    ``bound`` block and returns True where the step is to be bounded. The
    singular values of ``J`` go to the ``sigma`` block, the step's memo.
    """
    n, m = int(state[L.N]), int(state[L.M])
    return automatic_bound(L.vector(state, L.AUTO_BOUND)[1:], L.matrix_at(state, L.JACOBIAN, m, n),
                           L.vector(state, L.ROW_INDEX), state[L.DT], q0, dq, state,
                           L.vector(state, L.BOUND), L.vector(state, L.SIGMA))  # fmt: skip


def settings(limit: AutomaticMultiplierBounds | None, fused: bool) -> np.ndarray:
    """The ``auto_bound`` block of :func:`lpik.fast.layout.pack` for ``limit`` (None: off).

    ``fused``: whether the step applies the rule itself (a chain whose
    kinematics it compiles, so that it can take the probe); else 0, and the
    caller applies it (:func:`lpik.methods.autobound.bound_for_step`).
    """
    if limit is None:
        return np.zeros(5)
    return np.concatenate([[1.0 if fused else 0.0], autobound.parameters(limit)])
