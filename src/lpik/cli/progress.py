"""Progress on stderr: a bar for runs long enough to notice, a line while numba compiles."""

from __future__ import annotations

import sys
import time
from contextlib import AbstractContextManager, nullcontext
from importlib.util import find_spec
from types import TracebackType
from typing import Any

#: Seconds a run must have taken before the bar appears.
SHOW_AFTER_S = 0.5


class LazyProgress:
    """Callable ``(done, total)`` that shows a rich progress bar once a run takes a while.

    Nothing is shown when stderr is not a terminal, and nothing before
    :data:`SHOW_AFTER_S` seconds have passed; the bar disappears when the run ends.

    Args:
        label: Text in front of the bar.
        enabled: Force on or off; default: on when stderr is a terminal.
    """

    def __init__(self, label: str, *, enabled: bool | None = None) -> None:
        self.label = label
        self.enabled = sys.stderr.isatty() if enabled is None else enabled
        self._start = time.perf_counter()
        self._progress: Any = None
        self._task: Any = None

    def __call__(self, done: int, total: int) -> None:
        """Report ``done`` of ``total`` steps."""
        if not self.enabled:
            return
        if self._progress is None:
            if time.perf_counter() - self._start < SHOW_AFTER_S or done >= total:
                return
            from rich.console import Console
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeRemainingColumn

            self._progress = Progress(
                "[progress.description]{task.description}",
                BarColumn(),
                MofNCompleteColumn(),
                TimeRemainingColumn(),
                console=Console(stderr=True),
                transient=True,
            )
            self._progress.start()
            self._task = self._progress.add_task(self.label, total=total)
        self._progress.update(self._task, completed=done)

    def close(self) -> None:
        """Remove the bar (if it was shown)."""
        if self._progress is not None:
            self._progress.stop()
            self._progress = None

    def __enter__(self) -> LazyProgress:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


def compile_progress(label: str) -> AbstractContextManager[Any]:
    """While entered, what numba compiles, on stderr (:class:`lpik.fast.compiling.CompileProgress`).

    For a command whose first call compiles the compiled path: a first run on an
    empty cache then says what it waits for. Nothing without numba, and nothing
    when every kernel comes from numba's disk cache.
    """
    if find_spec("numba") is None:
        return nullcontext()
    from lpik.fast.compiling import CompileProgress

    return CompileProgress(label)
