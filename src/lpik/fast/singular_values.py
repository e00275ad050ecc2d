"""The singular values the automatic multiplier bound reads, compiled for the fused step.

:func:`lpik.control.autobound.bound_for_step` needs ``J``'s largest and
smallest singular values and, near a singularity, the smallest one a probe
step along ``dq`` away. :func:`probe_singular_values` computes them from a
controller's state buffer (the step's ``J`` as the kernel left it; the probe
through the compiled chain kinematics), so that the rule itself, which stays
in :mod:`lpik.control.autobound`, costs a few microseconds on the fused path.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from lpik.fast import layout as L
from lpik.fast.jacobi import jacobi_svd
from lpik.fast.kinematics import chain_fk_jacobian


@njit(cache=True)
def probe_singular_values(state, q0, dq, activation, probe, out):
    """``out = (sigma_max, sigma_min, sigma_min at the probe)`` of the task Jacobian.

    The probe's value is NaN where no probe is needed (``sigma_min >
    activation sigma_max``) or ``dq = 0``. ``q0`` and ``dq`` are the step's.
    """
    n, m = int(state[L.N]), int(state[L.M])
    J = L.matrix_at(state, L.JACOBIAN, m, n).copy()
    s = jacobi_svd(J)[1]
    out[0], out[1], out[2] = s[0], s[s.size - 1], np.nan
    size = 0.0
    for i in range(n):
        size += dq[i] * dq[i]
    size = np.sqrt(size)
    if out[1] > activation * out[0] or size == 0.0:
        return
    q = np.empty(n)
    for i in range(n):
        q[i] = q0[i] + probe * dq[i] / size
    T, J6, joints = np.empty((4, 4)), np.empty((6, n)), np.empty((2, n, 3))
    chain_fk_jacobian(L.tensor_at(state, L.ORIGINS, n, 4, 4), L.matrix_at(state, L.AXES, n, 3),
                      L.vector(state, L.REVOLUTE), L.matrix_at(state, L.TIP, 4, 4), q, T, J6,
                      joints)  # fmt: skip
    rows = L.vector(state, L.ROW_INDEX)
    Jp = np.empty((m, n))
    for k in range(m):
        for i in range(n):
            Jp[k, i] = J6[int(rows[k]), i]
    sp = jacobi_svd(Jp)[1]
    out[2] = sp[sp.size - 1]
