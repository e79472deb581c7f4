"""``python -m sdcomp COMMAND ...``: the ``sdcomp`` command (see :mod:`sdcomp.cli`)."""

from .cli import run

run()
