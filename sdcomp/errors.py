"""Errors that are the user's to fix, and the command-line wrapper that reports them.

A :class:`UserError` carries a one-line message that names the bad value and how to fix it.
Command-line entry points run through :func:`run_cli`, which prints such errors as
``error: <message>`` on stderr and exits with status 2, without a traceback.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence


class UserError(Exception):
    """A mistake in the user's input (flag, file, config), reported without a traceback."""


def run_cli(main: Callable[[Sequence[str] | None], int | None],
            argv: Sequence[str] | None = None) -> int:
    """Run a command-line ``main(argv)`` and turn user errors into exit status 2.

    Returns the exit status: ``main``'s own (0 when it returns None), 2 for a
    :class:`UserError`, 130 for Ctrl-C.
    """
    try:
        return int(main(argv) or 0)
    except UserError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
