"""What numba compiles, said while it compiles: the first run's progress line.

The compiled path is compiled on its first use and then cached on disk (numba's
cache): a first controller on an empty cache compiles for tens of seconds
(``docs/benchmarks.md``, "Compile time"), later ones load in well under a
second. :class:`CompileProgress` tells a user, on stderr, that the wait is a
compile and what it is compiling, so that a first run does not look hung:
one line when numba starts, on a terminal the function it is on (the line
rewritten in place), and a last line with the time it took. It says nothing
when everything comes from the cache. ``lpik compile`` pays the compile ahead,
where lpik is deployed.
"""

from __future__ import annotations

import sys
import time
from types import TracebackType
from typing import Any, TextIO

from numba.core import event

#: Seconds between two rewrites of the line on a terminal.
REFRESH_S = 0.25
#: What the first line says besides the label: why the wait, and how to pay it ahead.
FIRST_RUN = "compiling the compiled path with numba (first run only: cached on disk afterwards; "
FIRST_RUN += "`lpik compile` does it ahead)"
#: Back to the start of the line, and clear it.
_CLEAR = "\r\x1b[K"


class CompileProgress(event.Listener):  # type: ignore[misc]
    """While entered: on stderr, what numba compiles (nothing when all comes from the cache).

    Args:
        label: What is compiling, in front of every line (``"lpik console"``).
        stream: Where the lines go; default ``sys.stderr``.
        live: Rewrite one line with the function being compiled; default: when
            ``stream`` is a terminal (else one line at the start, one at the end).
    """

    def __init__(self, label: str, stream: TextIO | None = None, *, live: bool | None = None):
        self.label = label
        self.stream = sys.stderr if stream is None else stream
        self.live = bool(getattr(self.stream, "isatty", lambda: False)()) if live is None else live
        self.started: float | None = None
        #: The functions compiled so far (numba compiles a kernel's callees one by one).
        self.count = 0
        self._shown = 0.0

    def on_start(self, ev: Any) -> None:
        """A function starts compiling: the first line, or the function's name on a terminal."""
        now = time.perf_counter()
        self.count += 1
        if self.started is None:
            self.started = now
            self._write(f"{self.label}: {FIRST_RUN} ...", end="" if self.live else "\n")
            self._shown = now
        elif self.live and now - self._shown >= REFRESH_S:
            name = getattr(ev.data["dispatcher"].py_func, "__name__", "?")
            self._write(f"{_CLEAR}{self.label}: compiling {name} ({self.count} functions, "
                        f"{now - self.started:.0f} s) ...", end="")  # fmt: skip
            self._shown = now

    def on_end(self, ev: Any) -> None:
        """A function is compiled (the line moves on at the next start)."""

    def _write(self, text: str, end: str = "\n") -> None:
        self.stream.write(text + end)
        self.stream.flush()

    def __enter__(self) -> CompileProgress:
        event.register("numba:compile", self)
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        event.unregister("numba:compile", self)
        if self.started is None:
            return
        seconds = time.perf_counter() - self.started
        done = "stopped" if exc_type is not None else "compiled"
        functions = f"{self.count} function" + ("s" if self.count != 1 else "")
        self._write(f"{_CLEAR if self.live else ''}{self.label}: {done} {functions} "
                    f"in {seconds:.1f} s")  # fmt: skip
