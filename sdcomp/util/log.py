"""Command-line logging: ``--quiet`` / ``--verbose`` and where messages go.

Results and notes (INFO, DEBUG) go to stdout, warnings and errors to stderr. ``--quiet`` keeps
only warnings and errors (and switches progress lines off); ``--verbose`` adds DEBUG details.
Progress lines themselves (:mod:`sdcomp.progress`) appear only on a terminal.
"""

from __future__ import annotations

import argparse
import logging
import sys

LOGGER = "sdcomp"


def add_verbosity_flags(parser: argparse.ArgumentParser | argparse._ArgumentGroup) -> None:
    """Add ``-q/--quiet`` and ``-v/--verbose`` (mutually exclusive) to ``parser``."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument("-q", "--quiet", action="store_true",
                       help="only warnings and errors; no progress line (default: off)")
    group.add_argument("-v", "--verbose", action="store_true",
                       help="also debug details (default: off)")


class _Below(logging.Filter):
    def __init__(self, level: int):
        super().__init__()
        self.level = level

    def filter(self, record: logging.LogRecord) -> bool:
        return record.levelno < self.level


def setup_logging(quiet: bool = False, verbose: bool = False) -> logging.Logger:
    """Configure the ``sdcomp`` logger for a command-line run; returns it.

    Replaces the handlers of an earlier call (a process may run several commands), binds to
    the current ``sys.stdout``/``sys.stderr``, and does not propagate to the root logger.
    """
    logger = logging.getLogger(LOGGER)
    for h in list(logger.handlers):
        if getattr(h, "_sdcomp", False):
            logger.removeHandler(h)
    out = logging.StreamHandler(sys.stdout)
    out.addFilter(_Below(logging.WARNING))
    err = logging.StreamHandler(sys.stderr)
    err.setLevel(logging.WARNING)
    err.setFormatter(logging.Formatter("%(levelname)s: %(message)s"))
    for h in (out, err):
        h._sdcomp = True  # type: ignore[attr-defined]
        logger.addHandler(h)
    logger.setLevel(logging.WARNING if quiet else logging.DEBUG if verbose else logging.INFO)
    logger.propagate = False
    return logger


def get_logger(name: str) -> logging.Logger:
    """The logger of module ``name`` (under ``sdcomp``)."""
    return logging.getLogger(name if name.startswith(LOGGER) else f"{LOGGER}.{name}")
