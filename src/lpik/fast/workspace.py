"""The LP2 kernel's float workspace: its blocks named and sized once.

:func:`lpik.fast.lp2_kernel.lp2_core` allocates nothing: it works in one float
array ``ws``, :func:`workspace_size` long, that its caller passes. :data:`BLOCKS`
lists its blocks in order, each with its shape in ``n`` (joints), ``m`` (task
rows) and ``t = n + m + r`` (the ratio test's entries: the joints, the
multipliers and ``r`` extra rows); a block starts where the one before it ends.
A kernel takes a block through :func:`vector` or :func:`matrix_at` with the
block's constant. Each is compiled for one signature when the module is
imported, and LLVM inlines them into the kernel: inlined at numba's level
instead, the few dozen views of :func:`~lpik.fast.lp2_kernel.lp2_core` took
seconds of its compile time.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from lpik.fast.views import matrix

# the signatures of the accessors below: an index; a block's view
_INDEX = "int64(int64, int64, int64, int64)"
_VECTOR = "float64[::1](float64[::1], int64, int64, int64, int64)"
_MATRIX = "float64[:, :](float64[::1], int64, int64, int64, int64)"

# the blocks, by their place in BLOCKS
HINV_JT, H_FACTOR, HINV_C, COL, OUT, A_Q, B_Q = range(7)
SCHUR, SCHUR_FACTOR, RHS, A_L, B_L, RHS2, E_L, RHS3 = range(7, 15)
HINV_R, E_Q, AV, BV, LO, HI = range(15, 21)
PULL_SCALE = 21


@dataclass(frozen=True)
class Block:
    """One block of the workspace.

    Attributes:
        index: Its place in :data:`BLOCKS`, the block's module constant.
        name: The name the kernel gives it.
        shape: No axis (one number), or one or two, each ``"n"``, ``"m"`` or ``"t"``.
        doc: What it holds.
    """

    index: int
    name: str
    shape: tuple[str, ...]
    doc: str


#: Every block, in the order of the workspace.
BLOCKS = (
    Block(HINV_JT, "HinvJt", ("n", "m"), "H'^-1 J^T over the free joints"),
    Block(H_FACTOR, "LH", ("n", "n"), "the Cholesky factor of H' (unused when H is diagonal)"),
    Block(HINV_C, "Hinvc", ("n",), "H'^-1 c', the step at p = 0 before the multipliers"),
    Block(COL, "col", ("n",), "scratch: a right-hand side over the joints"),
    Block(OUT, "out", ("n",), "scratch: a solution over the joints"),
    Block(A_Q, "a_q", ("n",), "dq = a_q + p b_q: the step at p = 0"),
    Block(B_Q, "b_q", ("n",), "dq = a_q + p b_q: the step's rate in p"),
    Block(SCHUR, "S", ("m", "m"), "the Schur complement J H'^-1 J^T"),
    Block(SCHUR_FACTOR, "LS", ("m", "m"), "its Cholesky factor"),
    Block(RHS, "rhs", ("m",), "scratch: J H'^-1 c', a right-hand side over the task rows"),
    Block(A_L, "a_l", ("m",), "lam = a_l + p b_l: the multipliers at p = 0"),
    Block(B_L, "b_l", ("m",), "lam = a_l + p b_l: their rate in p"),
    Block(RHS2, "rhs2", ("m",), "scratch: -dw, a second right-hand side over the task rows"),
    Block(E_L, "e_l", ("m",), "the pull's share of the multipliers (sec. 3.1)"),
    Block(RHS3, "rhs3", ("m",), "scratch of the pull: J H'^-1 c_ref"),
    Block(HINV_R, "Hinvr", ("n",), "H'^-1 c_ref, the pull (sec. 3.1)"),
    Block(E_Q, "e_q", ("n",), "the pull's share of the step"),
    Block(AV, "av", ("t",), "the ratio test's entries a + p b: a"),
    Block(BV, "bv", ("t",), "the ratio test's entries a + p b: b"),
    Block(LO, "lo", ("t",), "the entries' lower bounds"),
    Block(HI, "hi", ("t",), "the entries' upper bounds"),
    Block(PULL_SCALE, "pull_scale", (), "the share of sec. 3.1's pull the step took (1: whole)"),
)
assert [b.index for b in BLOCKS] == list(range(len(BLOCKS))), "BLOCKS out of their constants' order"
#: The number of blocks.
COUNT = len(BLOCKS)

#: The terms a block's start is counted in: 1, ``n``, ``m``, ``t`` and their
#: products of two (a block's size is one of them).
_TERMS = ("", "n", "m", "t", "nn", "mn", "nt", "mm", "mt", "tt")


def _starts() -> np.ndarray:
    """Each block's start, and last the workspace's length, as counts of :data:`_TERMS`."""
    rows, count = [], [0] * len(_TERMS)
    for block in BLOCKS:
        rows.append(list(count))
        count[_TERMS.index("".join(sorted(block.shape)))] += 1
    return np.array([*rows, count], dtype=np.int64)


#: Each block's start (row ``k``) and the workspace's length (the last row), in
#: :data:`_TERMS`: a closed form, which the compiler folds to a few operations
#: for a block known at compile time.
_STARTS = _starts()
#: The code of each axis: 0 ``n``, 1 ``m``, 2 ``t``; -1: no second axis.
_AXES = {"n": 0, "m": 1, "t": 2}
#: Each block's two axes as codes.
_SHAPES = np.array(
    [[_AXES[a] for a in b.shape] + [-1] * (2 - len(b.shape)) for b in BLOCKS], dtype=np.int64
)


@njit(_INDEX, cache=True)
def _extent(code, n, m, r):
    """The length of an axis of code ``code`` (see :data:`_AXES`); 1 for none."""
    if code == 0:
        return n
    if code == 1:
        return m
    if code == 2:
        return n + m + r
    return 1


@njit(_INDEX, cache=True)
def start(block, n, m, r):
    """Where ``block`` starts (:data:`COUNT`: the workspace's length)."""
    t = n + m + r
    c = _STARTS[block]
    return (c[0] + c[1] * n + c[2] * m + c[3] * t + c[4] * n * n + c[5] * m * n
            + c[6] * n * t + c[7] * m * m + c[8] * m * t + c[9] * t * t)  # fmt: skip


@njit(_VECTOR, cache=True)
def vector(ws, block, n, m, r):
    """The 1-D ``block`` of the workspace ``ws``."""
    offset = start(block, n, m, r)
    return ws[offset : offset + _extent(_SHAPES[block, 0], n, m, r)]


@njit(_MATRIX, cache=True)
def matrix_at(ws, block, n, m, r):
    """The 2-D ``block`` of the workspace ``ws``, C-ordered."""
    rows, cols = _extent(_SHAPES[block, 0], n, m, r), _extent(_SHAPES[block, 1], n, m, r)
    return matrix(ws, start(block, n, m, r), rows, cols)


@njit(cache=True)
def workspace_size(n, m, r):
    """Length of the workspace for ``n`` joints, ``m`` task rows and ``r`` extra rows."""
    return start(COUNT, n, m, r)
