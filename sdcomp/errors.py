"""Errors that are the user's to fix, and the command-line wrapper that reports them.

A :class:`UserError` carries a one-line message that names the bad value and how to fix it.
A :class:`SettingError` is one about a named setting: its message names the setting as
Python and config files spell it (``altitude``), and :func:`run_cli` reports it as the
command line's flag (``--altitude``). Command-line entry points run through :func:`run_cli`,
which prints such errors as ``error: <message>`` on stderr and exits with status 2, without
a traceback.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence


class UserError(Exception):
    """A mistake in the user's input (flag, file, config), reported without a traceback."""


class SettingError(UserError):
    """A bad value of the setting ``setting``; ``template`` is the message with ``{name}``
    where the setting's name goes."""

    def __init__(self, setting: str, template: str):
        self.setting, self.template = setting, template
        super().__init__(template.replace("{name}", setting))

    def __reduce__(self):  # picklable across worker processes
        return type(self), (self.setting, self.template)

    def as_flag(self) -> str:
        """The message naming the setting as its command-line flag, ``--setting-name``."""
        return self.template.replace("{name}", flag(self.setting))


def flag(setting: str) -> str:
    """The command-line flag of a setting: ``min_visible_px`` -> ``--min-visible-px``."""
    return "--" + setting.replace("_", "-")


def run_cli(main: Callable[[Sequence[str] | None], int | None],
            argv: Sequence[str] | None = None) -> int:
    """Run a command-line ``main(argv)`` and turn user errors into exit status 2.

    Returns the exit status: ``main``'s own (0 when it returns None), 2 for a
    :class:`UserError`, 130 for Ctrl-C.
    """
    try:
        return int(main(argv) or 0)
    except SettingError as exc:
        print(f"error: {exc.as_flag()}", file=sys.stderr)
        return 2
    except UserError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
