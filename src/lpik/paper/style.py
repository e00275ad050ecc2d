"""What every figure of lpik shares: style, canvas, saving, and the arm's outline.

matplotlib is optional (``pip install "lpik[plot]"``) and imported only inside
the functions of the figure modules, so that the rest of lpik starts fast
without it. Figures are drawn with the object-oriented API on an Agg canvas:
no pyplot state, no display needed.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from lpik.exceptions import MissingBackendError
from lpik.robots.base import TaskModel
from lpik.types import FloatArray

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: Resolution of saved figures [dots per inch]; 7 in wide -> 1050 px.
DPI = 150
#: Arm outlines drawn on an x-y figure.
ARM_POSES = 9
LAMBDA_LABEL = r"max$_i\,|\lambda_i|$ [rad$^2$/m]"
#: matplotlib settings of every figure: text readable when a figure is shown at README width.
STYLE: dict[str, Any] = {
    "font.size": 11,
    "axes.titlesize": 11,
    "axes.labelsize": 11,
    "legend.fontsize": 9,
    "legend.framealpha": 0.9,
    "lines.solid_capstyle": "butt",
}

F = TypeVar("F", bound=Callable[..., Path])


def styled(fn: F) -> F:
    """Run a figure function inside ``matplotlib.rc_context(STYLE)``."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Path:
        try:
            import matplotlib
        except ImportError:
            raise MissingBackendError("figures", "plot") from None
        with matplotlib.rc_context(STYLE):
            return fn(*args, **kwargs)

    return wrapper  # type: ignore[return-value]


def require_backend(*, animation: bool = False) -> None:
    """Raise :class:`~lpik.exceptions.MissingBackendError` unless figures can be drawn.

    Args:
        animation: Also require pillow (GIFs).
    """
    try:
        import matplotlib  # noqa: F401 - only whether it imports

        if animation:
            import PIL  # noqa: F401 - only whether it imports
    except ImportError:
        raise MissingBackendError("animations" if animation else "figures", "plot") from None


def new_figure(width: float, height: float) -> Figure:
    """A figure on an Agg canvas; ``MissingBackendError`` when matplotlib is absent."""
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:
        raise MissingBackendError("figures", "plot") from None
    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def save(fig: Figure, path: str | Path) -> Path:
    """Write ``fig`` as a PNG; ``ValueError`` naming the file when it cannot be written."""
    out = Path(path)
    try:
        fig.savefig(out, dpi=DPI)
    except OSError as exc:
        raise ValueError(f"cannot write figure {str(out)!r}: {exc.strerror or exc}") from None
    return out


def arm_points(model: TaskModel, q: FloatArray) -> FloatArray | None:
    """The base, every joint and the task point of a serial-chain model, (k, 2 or 3) [m].

    Points in the model's position coordinates (x, y for a planar arm);
    ``None`` for a model whose kinematics is not a :class:`~lpik.robots.chain.SerialChain`.
    """
    chain = getattr(model, "kinematics", None)
    if chain is None or not hasattr(chain, "joint_frames"):
        return None
    dims = getattr(model, "position_dims", 3)
    points = np.vstack([np.zeros(3), chain.joint_frames(q)[:, :3, 3], chain.fk(q)[:3, 3]])
    keep = np.ones(len(points), dtype=bool)
    keep[1:] = np.abs(np.diff(points, axis=0)).max(axis=1) > 1e-12  # a joint at the base
    return points[keep, :dims]
