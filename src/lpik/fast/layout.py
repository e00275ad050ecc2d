"""The fused step's state buffer: every block of a controller in one float array, described once.

A fused step is one compiled call of four arguments (``state, q0, q_prev,
target``); ``state`` holds all the rest, so that the step allocates nothing:

- the header: the sizes ``n`` (joints), ``m`` (task rows), ``r`` (extra rows),
  the flag ``h_diag``, the scalars ``dt``, ``v_max``, ``w_max``, the flag
  ``saturate`` (LP2 with saturation in the null space), and then,
  at the slot named by each block's constant, the offset where the block
  starts (slot :data:`END`: the buffer's length);
- the blocks of :data:`BLOCKS`, in that order: the chain's geometry and the
  constants of the step (limits, criterion, rows, the automatic multiplier
  bound, whether the command takes off the second-order term), then
  :data:`OUT_BLOCKS` (what the step reports), then the step's scratch, and
  last the kinematics of the last step's ``q0`` (kept from one step to the
  next, so that the next step, whose ``q_prev`` it is, need not compute them).

:func:`pack` builds a buffer; a kernel reads a block through :func:`vector`,
:func:`matrix_at` or :func:`tensor_at` with the block's constant; Python reads
the out blocks by name through :func:`out_fields`. Blocks lie in the order of
their slots, so a block ends where the next begins.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numba import njit

from lpik.fast.kinematics import POSE_ERROR_SCRATCH
from lpik.fast.lp2_kernel import workspace_size
from lpik.fast.views import matrix, tensor3
from lpik.methods.autobound import MEMO_SIZE
from lpik.types import FloatArray

# ------------------------------------------------------------------ header: sizes and scalars
N, M, R, H_DIAG, DT, V_MAX, W_MAX, SATURATE = range(8)

# ---------------------------------------------- header: one slot per block, holding its offset
# the chain and the constants of the step
REVOLUTE, ROW_INDEX, ORIGINS, AXES, TIP = range(8, 13)
LIMITS, CRITERION, F_REF, LAMBDA, LAM_BOUNDS, ROWS_G, ROWS_H, ROWS_BRAKED = range(13, 21)
AUTO_BOUND, SECOND_ORDER, CONTINUATION, CHAIN = range(21, 25)
# out: what a step reports
Q, DQ, LAM, POSITION, DW, P, LABEL, RESIDUAL, BOUND, BOUNDED, OUTSIDE = range(25, 36)
PULL_SCALE = 36
# scratch of the step
GOAL, FRAME, JACOBIAN6, ERROR6, JACOBIAN, JOINTS, LOG_SCRATCH = range(37, 44)
LOWER, UPPER, KINDS, C, C_REF, G_RHS, LP2_WS, SATURATION = range(44, 52)
STOP, STOP_SCRATCH, LAST, ORIGIN, SAFE = range(52, 57)
# the kinematics at the last step's q0, and the second-order term
PREV_Q, PREV_FRAME, PREV_JACOBIAN6, RHO = range(57, 61)
# the last step's q0 and goal, and the target's motion since (fed forward under acc. limits)
MEMORY, MEMORY_Q, MEMORY_GOAL, TARGET_MOTION = range(61, 65)
# the stop before a singular configuration ahead of the motion (under acceleration limits),
# and the singular values of J at q0 and at prev_q that the automatic bound has read
SINGULAR, SIGMA = 65, 66
# the right-hand sides of the command's brake (lpik.command.braking_scale)
BRAKE = 67
# the potential field's force, written by the step with a scene's distances inside
FIELD = 68
#: The slot holding the buffer's length (where a block after the last would start).
END = 69
#: Length of the header.
HEADER = END + 1

#: A block's axis: a number, ``"n"``, ``"m"``, ``"r"``, or a function of ``(n, m, r)``.
Axis = int | str | Callable[[int, int, int], int]


@dataclass(frozen=True)
class Block:
    """One block of the state buffer.

    Attributes:
        slot: Its header slot (the module constant of the same name, upper case).
        name: What :func:`pack` and :func:`out_fields` call it.
        shape: Its axes (see :data:`Axis`).
        doc: What it holds.
    """

    slot: int
    name: str
    shape: tuple[Axis, ...]
    doc: str


#: Every block, in the order of the buffer (and of the slots).
BLOCKS = (
    Block(REVOLUTE, "revolute", ("n",), "1 for a revolute joint, 0 for a prismatic one"),
    Block(ROW_INDEX, "row_index", ("m",), "each task row's index in x, y, z, rx, ry, rz"),
    Block(ORIGINS, "origins", ("n", 4, 4), "each joint's fixed transform from the previous frame"),
    Block(AXES, "axes", ("n", 3), "unit joint axes"),
    Block(TIP, "tip", (4, 4), "the task frame in the last joint's frame"),
    Block(LIMITS, "limits", (6, "n"), "q_min, q_max, qd_min, qd_max, qdd_min, qdd_max (inf: none)"),
    Block(CRITERION, "criterion", ("n", "n"), "H = M + Lambda"),
    Block(F_REF, "f_ref", (2, "n"), "f and q_ref (NaN: q_ref follows q0 there)"),
    Block(LAMBDA, "Lambda", ("n", "n"), "the smoothing weight of sec. 3.1"),
    Block(LAM_BOUNDS, "lam_bounds", (2, "m"), "lower and upper multiplier bounds"),
    Block(ROWS_G, "G", ("r", "n"), "extra rows G q <= h"),
    Block(ROWS_H, "h", ("r",), "their right-hand side"),
    Block(
        ROWS_BRAKED,
        "rows_braked",
        (1,),
        "1: the rows are limits on q, kept with a stop ahead under acceleration limits "
        "(lpik.bands.braked_room); 0: a scene's rows, which bound the step's approach",
    ),
    Block(AUTO_BOUND, "auto_bound", (5,), "1: the step applies the auto bound (-1: its caller)"),
    Block(
        SECOND_ORDER,
        "second_order",
        (2,),
        "1: the command takes off the second-order term; 1: prev_* hold prev_q's kinematics",
    ),
    Block(
        CONTINUATION,
        "continuation",
        (1,),
        "1: under acceleration limits the step is solved around the motion, the command brakes;"
        " -1: the command as with 1, the step through rest (the through-rest stage)",
    ),
    Block(CHAIN, "chain", (1,), "1: the step computes the chain's kinematics (0: a backend's)"),
    Block(Q, "q", ("n",), "the new joint coordinates q0 + dq"),
    Block(DQ, "dq", ("n",), "the step"),
    Block(LAM, "lam", ("m",), "the multipliers"),
    Block(POSITION, "position", (3,), "the task point at q0"),
    Block(DW, "dw", ("m",), "the commanded displacement, clamped"),
    Block(P, "p", (1,), "the affine dexterity"),
    Block(LABEL, "label", (1,), "the binding limit's index in the label table (-1: none)"),
    Block(RESIDUAL, "residual", (1,), "max |J dq - p dw|"),
    Block(BOUND, "bound", ("m",), "the automatic bound B_k on |lam_k| the step ran under"),
    Block(BOUNDED, "bounded", (1,), "1: LP2 under the auto bound, 0: not, -1: no rule"),
    Block(OUTSIDE, "outside", (1,), "the label index of the limit the state is outside of (-1)"),
    Block(PULL_SCALE, "pull_scale", (1,), "the share of sec. 3.1's pull the step took (1: whole)"),
    Block(GOAL, "goal", (4, 4), "the commanded pose"),
    Block(FRAME, "frame", (4, 4), "the task frame at q0"),
    Block(JACOBIAN6, "jacobian6", (6, "n"), "the world-aligned Jacobian [v; omega]"),
    Block(ERROR6, "error6", (6,), "the pose error [dp; log(R_goal R^T)], then the step's screw"),
    Block(JACOBIAN, "jacobian", ("m", "n"), "the task rows of the Jacobian"),
    Block(JOINTS, "joints", (2, "n", 3), "each joint's position and world axis"),
    Block(LOG_SCRATCH, "log_scratch", (POSE_ERROR_SCRATCH,), "scratch of the pose error"),
    Block(LOWER, "lower", ("n",), "lower bounds on dq"),
    Block(UPPER, "upper", ("n",), "upper bounds on dq"),
    Block(KINDS, "kinds", (2, "n"), "which limit sets each bound: 0 end-stop, 1 velocity, 2 acc."),
    Block(C, "c", ("n",), "f"),
    Block(C_REF, "c_ref", ("n",), "Lambda (q_ref - q0), sec. 3.1's pull"),
    Block(G_RHS, "g", ("r",), "the rows' right-hand side in dq: h - G q0"),
    Block(LP2_WS, "lp2_ws", (workspace_size,), "the LP2 kernel's workspace"),
    Block(SATURATION, "saturation", (lambda n, m, r: n + m,), "the best pass's dq and lam"),
    Block(STOP, "stop", (4, "n"), "least motions of the error and the turn; stop acc., speeds"),
    Block(STOP_SCRATCH, "stop_scratch", (lambda n, m, r: m * (m + 2),), "their work space"),
    Block(LAST, "last", ("n",), "the motion the step is solved around (lpik.continuation)"),
    Block(ORIGIN, "origin", ("n",), "q0 + last, the continued step's origin"),
    Block(SAFE, "safe", ("n",), "the safe step of a step solved around the motion"),
    Block(PREV_Q, "prev_q", ("n",), "the joint coordinates of the kinematics below"),
    Block(PREV_FRAME, "prev_frame", (4, 4), "the task frame at prev_q"),
    Block(PREV_JACOBIAN6, "prev_jacobian6", (6, "n"), "the world-aligned Jacobian at prev_q"),
    Block(RHO, "rho", (2, "m"), "J(q_prev) (q0 - q_prev), and the second-order term"),
    Block(MEMORY, "memory", (1,), "1: memory_q and memory_goal hold the last step's (0: none)"),
    Block(MEMORY_Q, "memory_q", ("n",), "the last step's q0"),
    Block(MEMORY_GOAL, "memory_goal", (4, 4), "the last step's goal"),
    Block(TARGET_MOTION, "target_motion", (13,), "1: the target moved; [dp; log]; its task rows"),
    Block(SINGULAR, "singular", (1,), "steps to the stop before a singular configuration"),
    Block(
        SIGMA,
        "sigma",
        (MEMO_SIZE,),
        "sigma_min, sigma_max of J at q0, sigma_min at prev_q (NaN: not known; autobound's memo)",
    ),
    Block(BRAKE, "brake", (2, "m"), "the error, the last motion's turn: the brake's task motions"),
    Block(FIELD, "field", ("n",), "the potential field's force at q0 (0: none; a scene's step)"),
)
#: The blocks a step reports, in the order of the buffer: they form one range.
OUT_BLOCKS = ("q", "dq", "lam", "position", "dw", "p", "label", "residual", "bound", "bounded",
              "outside", "pull_scale")  # fmt: skip
#: The blocks :func:`pack` fills from its arguments (the others start at zero).
INPUT_BLOCKS = tuple(b.name for b in BLOCKS if b.slot < Q)


def block_shape(block: Block, n: int, m: int, r: int) -> tuple[int, ...]:
    """The block's shape for ``n`` joints, ``m`` task rows and ``r`` extra rows."""
    sizes = {"n": n, "m": m, "r": r}
    return tuple(
        a if isinstance(a, int) else sizes[a] if isinstance(a, str) else a(n, m, r)
        for a in block.shape
    )


def pack(
    n: int, m: int, r: int, *, h_diag: bool, dt: float, v_max: float, w_max: float,
    saturate: bool = False, **arrays: FloatArray,
) -> FloatArray:  # fmt: skip
    """The state buffer of a fused step.

    Args:
        n: Number of joints.
        m: Number of task rows.
        r: Number of extra rows.
        h_diag: Whether ``H`` is diagonal (the LP2 kernel then skips its factorisation).
        dt: Control period [s].
        v_max: Largest commanded linear speed [m/s].
        w_max: Largest commanded angular speed [rad/s].
        saturate: Whether the step is LP2 with saturation in the null space.
        **arrays: One array per name of :data:`INPUT_BLOCKS`, of the block's shape.

    Raises:
        ValueError: For a missing, unknown or misshapen block (a bug of the caller).
    """
    if set(arrays) != set(INPUT_BLOCKS):
        raise ValueError(f"pack: expected the blocks {INPUT_BLOCKS}, got {tuple(arrays)}")
    offsets, offset = [], HEADER
    for block in BLOCKS:
        offsets.append(offset)
        offset += int(np.prod(block_shape(block, n, m, r), dtype=np.int64))
    state = np.zeros(offset)
    state[[N, M, R, H_DIAG, DT, V_MAX, W_MAX, SATURATE]] = (
        n, m, r, float(h_diag), dt, v_max, w_max, float(saturate))  # fmt: skip
    state[REVOLUTE:END] = offsets
    state[END] = offset
    start = int(state[SIGMA])
    state[start : start + MEMO_SIZE] = np.nan  # no singular value known yet
    for block in BLOCKS:
        if block.name in arrays:
            shape = block_shape(block, n, m, r)
            value = np.asarray(arrays[block.name], dtype=np.float64)
            if value.shape != shape:
                raise ValueError(f"pack: block {block.name} must be {shape}, got {value.shape}")
            start = int(state[block.slot])
            state[start : start + value.size] = value.ravel()
    return state


def out_range(state: FloatArray) -> slice:
    """Where :data:`OUT_BLOCKS` lie in ``state``."""
    return slice(int(state[Q]), int(state[PULL_SCALE + 1]))


def out_fields(state: FloatArray) -> dict[str, slice]:
    """Each of :data:`OUT_BLOCKS` by name: its place within :func:`out_range`."""
    start = int(state[Q])
    return {
        block.name: slice(int(state[block.slot]) - start, int(state[block.slot + 1]) - start)
        for block in BLOCKS
        if block.name in OUT_BLOCKS
    }


# ------------------------------------------------------------------------ the kernels' access

#: The one signature each accessor below is compiled for (see :mod:`lpik.fast.views`).
_VECTOR_SIGNATURE = "float64[::1](float64[::1], int64)"
_MATRIX_SIGNATURE = "float64[:, :](float64[::1], int64, int64, int64)"
_TENSOR_SIGNATURE = "float64[:, :, :](float64[::1], int64, int64, int64, int64)"


@njit(_VECTOR_SIGNATURE, cache=True)
def vector(state, slot):
    """The block at header ``slot`` as a 1-D view (a block ends where the next begins)."""
    return state[int(state[slot]) : int(state[slot + 1])]


@njit(_MATRIX_SIGNATURE, cache=True)
def matrix_at(state, slot, rows, cols):
    """The block at header ``slot`` as a (rows, cols) view."""
    return matrix(state, int(state[slot]), rows, cols)


@njit(_TENSOR_SIGNATURE, cache=True)
def tensor_at(state, slot, d0, d1, d2):
    """The block at header ``slot`` as a (d0, d1, d2) view."""
    return tensor3(state, int(state[slot]), d0, d1, d2)


@njit(cache=True)
def copy_out(state, outs, b):
    """Row ``b`` of ``outs`` = the out blocks a step left in ``state``."""
    start = int(state[Q])
    for k in range(int(state[PULL_SCALE + 1]) - start):
        outs[b, k] = state[start + k]
