"""Exceptions of lpik: one root, data on the leaves."""

from __future__ import annotations


class LpikError(Exception):
    """Root of every exception lpik raises on purpose."""


class InvalidProblemError(LpikError, ValueError):
    """A field of a problem (or of a model, or of a command) has a bad value.

    Attributes:
        field: Name of the offending field, as the user wrote it (e.g. ``"q_min"``).
        reason: What is wrong with it, in words.
    """

    def __init__(self, field: str, reason: str) -> None:
        self.field = field
        self.reason = reason
        super().__init__(f"{field}: {reason}")


class MissingBackendError(LpikError, ImportError):
    """An optional integration was asked for but its package is not installed.

    The message is the command that fixes it.
    """

    def __init__(self, what: str, extra: str) -> None:
        self.extra = extra
        super().__init__(f'{what} needs an optional package: pip install "lpik[{extra}]"')
