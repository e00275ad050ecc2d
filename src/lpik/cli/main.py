"""Entry point of the ``lpik`` command.

Each subcommand lives in its own module exposing ``add_parser(subparsers)``
and ``run(args) -> int``. Input errors print one line on stderr and exit with
status 2; nothing is printed on stdout and no traceback is shown.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Sequence
from typing import NoReturn

from lpik.version import __version__

#: Subcommand modules under ``lpik.cli``, in the order ``--help`` lists them.
SUBCOMMANDS = ("solve", "simulate", "reproduce", "robots", "console", "map", "bench", "compile")

EXIT_BAD_INPUT = 2
EXIT_INTERNAL = 1
#: A reader that closed the pipe early, as a shell reports a process killed by SIGPIPE.
EXIT_BROKEN_PIPE = 128 + 13


class UsageError(Exception):
    """Bad command-line input: printed as one line, exit status 2."""


class OneLineParser(argparse.ArgumentParser):
    """An argparse parser whose errors are one line on stderr and exit status 2."""

    def error(self, message: str) -> NoReturn:
        """Report a usage error in one line."""
        raise UsageError(f"{self.prog}: {message}")


def build_parser() -> OneLineParser:
    """The ``lpik`` parser with every subcommand registered."""
    parser = OneLineParser(
        prog="lpik",
        description="Inverse kinematics of redundant manipulators as small linear programs.",
    )
    parser.add_argument("--version", action="version", version=f"lpik {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=OneLineParser)
    sub.required = True
    for name in SUBCOMMANDS:
        module = importlib.import_module(f"lpik.cli.{name}")
        module.add_parser(sub)
    return parser


def fail(message: str) -> int:
    """Print one line on stderr and return the bad-input exit status."""
    print(f"lpik: error: {message}", file=sys.stderr)
    return EXIT_BAD_INPUT


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``lpik`` with ``argv`` (default: the process arguments); return the exit status."""
    try:
        args = build_parser().parse_args(argv)
        return int(args.handler(args))
    except UsageError as exc:
        return fail(str(exc).removeprefix("lpik: "))
    except BrokenPipeError:  # the reader went away (lpik robots --json | head): stop quietly
        try:  # and keep the interpreter's flush at exit quiet too
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        except (AttributeError, OSError, ValueError):  # a stdout without a file descriptor
            pass
        return EXIT_BROKEN_PIPE
    except ValueError as exc:  # InvalidProblemError and every other input error
        return fail(str(exc))
    except (OSError, ImportError) as exc:
        return fail(str(exc))
    except KeyboardInterrupt:
        print("lpik: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # the contract is: never a traceback
        if os.environ.get("LPIK_DEBUG"):
            raise
        print(
            f"lpik: internal error: {type(exc).__name__}: {exc} (set LPIK_DEBUG=1 for the "
            "traceback)",
            file=sys.stderr,
        )
        return EXIT_INTERNAL


def entry() -> NoReturn:
    """Console-script entry point."""
    sys.exit(main())


if __name__ == "__main__":
    entry()
