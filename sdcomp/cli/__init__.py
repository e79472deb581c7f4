"""Stage 8, the command line: argument parsing for every job, and the ``sdcomp`` command.

    sdcomp atlas build|info ...   sprite atlases         (= python -m sdcomp.atlas)
    sdcomp generate ...           a dataset folder       (= python -m sdcomp.generate)
    sdcomp video ...              video sequences        (= python -m sdcomp.video)
    sdcomp show DIR ...           a contact sheet        (= python -m sdcomp.show)
    sdcomp stats DIR ...          dataset statistics     (= python -m sdcomp.stats)
    sdcomp merge DIR... --out D   join shard folders     (= python -m sdcomp.merge)
    sdcomp bench ...              detector benchmarks    (= python -m sdcomp.bench)
    sdcomp realism DIR ...        the realism report     (= python -m sdcomp.realism)
    sdcomp check DIR              check a dataset        (= python -m sdcomp.check)
    sdcomp fit FRAMES --out F     fit to your footage    (= python -m sdcomp.fitting)

Each job's parser and ``main(argv) -> int`` live in a module of this package
(:mod:`sdcomp.cli.generate`, ...); ``python -m sdcomp.<job>`` runs the same ``main``.
``sdcomp COMMAND --help`` lists the command's options with their defaults and units. A
command is imported only when it runs (so ``sdcomp show`` does not import torch); add one by
adding a line to :data:`COMMANDS`. Every command's parser is a :class:`Parser`: options are
never abbreviated, and a mistake is one line naming it (with the nearest option for a
misspelt one), exit status 2.
"""

from __future__ import annotations

import argparse
import difflib
import importlib
import sys
from collections.abc import Callable, Sequence

from .. import __version__
from ..errors import UserError, run_cli

#: command: (module of its main, function, ``python -m`` module, one-line description)
COMMANDS: dict[str, tuple[str, str, str, str]] = {
    "atlas": ("sdcomp.cli.atlas", "main", "sdcomp.atlas",
              "build or inspect a mesh's sprite atlas (atlas build, atlas info)"),
    "generate": ("sdcomp.cli.generate", "main", "sdcomp.generate",
                 "generate a dataset: images, masks, COCO and/or YOLO labels"),
    "video": ("sdcomp.cli.video", "main", "sdcomp.video",
              "generate video sequences with tracked objects (MOTChallenge, COCO-video)"),
    "show": ("sdcomp.cli.show", "main", "sdcomp.show",
             "draw a contact sheet of a generated dataset"),
    "stats": ("sdcomp.cli.stats", "main", "sdcomp.stats",
              "counts, object sizes and metadata histograms of a generated dataset"),
    "merge": ("sdcomp.cli.merge", "main", "sdcomp.merge",
              "join the folders of --shard runs into one dataset"),
    "bench": ("sdcomp.bench.cli", "main", "sdcomp.bench",
              "train and evaluate detectors on generated data (needs torch)"),
    "check": ("sdcomp.cli.check", "main", "sdcomp.check",
              "check a generated dataset's files against each other (exit 1 on a problem)"),
    "realism": ("sdcomp.cli.realism", "main", "sdcomp.realism",
                "how real a dataset looks: water statistics, targets, real-vs-synthetic "
                "classifier"),
    "fit": ("sdcomp.cli.fit", "main", "sdcomp.fitting",
            "fit the scene (water, sky, sun, camera look) to your footage: a config for "
            "generate --config"),
}
#: modules that may be missing from an installation, and what to do about it
OPTIONAL = {"sdcomp.bench.cli": "this installation of sdcomp has no sdcomp.bench package; "
                                "install a version of sdcomp that includes it"}


_RUNNING: list[str] = []  # the subcommands running now through `sdcomp COMMAND`


class DefaultsFormatter(argparse.HelpFormatter):
    """Help that shows each option's default once: "(default: X)" is added only where the
    help text does not already say its default, and never to on/off switches."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        if ("default" in text or action.default in (None, argparse.SUPPRESS)
                or isinstance(action, (argparse._StoreTrueAction, argparse._StoreFalseAction,
                                       argparse.BooleanOptionalAction))
                or not action.option_strings):
            return text
        return text + " (default: %(default)s)"


class Parser(argparse.ArgumentParser):
    """The parser of every command: no prefix matching of long options (``--alt 30`` is not
    ``--altitude 30``), defaults shown once (:class:`DefaultsFormatter`), and errors as one
    line (a :class:`UserError`: exit status 2, no usage dump) that names the bad argument,
    with the nearest option for a misspelt one."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("allow_abbrev", False)
        kwargs.setdefault("formatter_class", DefaultsFormatter)
        super().__init__(*args, **kwargs)

    def parse_args(self, args=None, namespace=None):
        parsed, extras = super().parse_known_args(args, namespace)
        if extras:
            raise UserError(self.unknown_message(extras[0]))
        return parsed

    def unknown_message(self, arg: str) -> str:
        """One line about the unknown argument ``arg``, with the nearest option if any."""
        if arg.startswith("-") and len(arg) > 1:
            name = arg.split("=", 1)[0]
            options = sorted(self.long_options())
            near = [o for o in options if o.startswith(name)][:1] or \
                difflib.get_close_matches(name, options, n=1, cutoff=0.6)
            hint = f"did you mean {near[0]}? " if near else ""
            return f"unknown option {name}; {hint}`{self.prog} --help` lists the options"
        return f"unexpected argument {arg!r}; `{self.prog} --help` lists the arguments"

    def long_options(self) -> set[str]:
        """Every ``--option`` of this parser and its sub-commands' parsers."""
        found = {o for o in self._option_string_actions if o.startswith("--")}
        for action in self._actions:
            if isinstance(action, argparse._SubParsersAction):
                for sub in action.choices.values():
                    found |= sub.long_options() if isinstance(sub, Parser) else set()
        return found

    def error(self, message: str):
        raise UserError(f"{message}; `{self.prog} --help` lists the options")


def prog(name: str) -> str:
    """The program name for the usage line of command ``name``: ``sdcomp NAME`` when it runs
    through the ``sdcomp`` command, else ``python -m MODULE`` (its module in
    :data:`COMMANDS`)."""
    if name in _RUNNING:
        return f"sdcomp {name}"
    return f"python -m {COMMANDS[name][2]}"


def usage() -> str:
    width = max(map(len, COMMANDS))
    lines = ["usage: sdcomp COMMAND [OPTIONS]   (sdcomp COMMAND --help for its options)", "",
             "Synthetic drone-over-water detection datasets with exact masks.", "",
             "commands:"]
    lines += [f"  {name.ljust(width)}  {desc}" for name, (*_, desc) in COMMANDS.items()]
    lines += ["", "options:", "  -h, --help  show this help and exit",
              "  --version   print the sdcomp version and exit"]
    return "\n".join(lines) + "\n"


def command(name: str) -> Callable[[Sequence[str] | None], int | None]:
    """The ``main(argv)`` of command ``name`` (imported now); UserError when it is unknown
    or its module is not installed."""
    if name not in COMMANDS:
        near = difflib.get_close_matches(name, list(COMMANDS), n=1)
        hint = f"did you mean {near[0]!r}? " if near else ""
        raise UserError(f"unknown command {name!r}; {hint}use one of {', '.join(COMMANDS)}")
    module, func, *_ = COMMANDS[name]
    try:
        mod = importlib.import_module(module)
    except ModuleNotFoundError as e:
        parts = module.split(".")
        own = {".".join(parts[:k]) for k in range(2, len(parts) + 1)}
        if e.name in own and module in OPTIONAL:  # the module itself, not one it imports
            raise UserError(f"`sdcomp {name}`: {OPTIONAL[module]}") from None
        raise
    return getattr(mod, func)


def main(argv: Sequence[str] | None = None) -> int:
    """``sdcomp COMMAND ...``: run the command's ``main`` on the rest of the arguments."""
    args = list(sys.argv[1:] if argv is None else argv)
    if not args or args[0] in ("-h", "--help", "help"):
        sys.stdout.write(usage())
        return 0 if args else 2
    if args[0] == "--version":
        print(f"sdcomp {__version__}")
        return 0
    func = command(args[0])
    _RUNNING.append(args[0])
    try:
        return int(func(args[1:]) or 0)
    finally:
        _RUNNING.pop()


def run() -> None:
    """Console-script entry point (``sdcomp`` in setup.cfg): exit with main's status."""
    sys.exit(run_cli(main))


if __name__ == "__main__":
    run()
