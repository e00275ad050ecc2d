"""The ``lpik`` command line: one module per subcommand, registered in :mod:`lpik.cli.main`."""

from __future__ import annotations

from collections.abc import Mapping, Sequence


def as_option(message: str, names: Sequence[str], spelled: Mapping[str, str] | None = None) -> str:
    """An API error ``"<argument>: ..."`` as the command line says it, ``"--<option>: ..."``.

    ``names``: the arguments the command passes on as options of the same name;
    ``spelled``: an argument whose option has another name (``task`` -> ``place``).
    Any other message is returned as it is.
    """
    head, sep, rest = message.partition(": ")
    if not (sep and head in names):
        return message
    return f"--{(spelled or {}).get(head, head)}: {rest}"
