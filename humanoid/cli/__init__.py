"""The ``humanoid`` command line: :func:`main` parses the arguments and hands them to the
command's module (one per group of commands: :mod:`~humanoid.cli.body`,
:mod:`~humanoid.cli.simulate`, :mod:`~humanoid.cli.walk`, :mod:`~humanoid.cli.view`,
:mod:`~humanoid.cli.motion`, :mod:`~humanoid.cli.bench`), which prints what it did.

Errors go to stderr as one line, with exit code 2 for bad input and no traceback.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from ..errors import HumanoidError, UsageError
from . import bench, body, motion, simulate, view, walk
from .options import KEYPOINT_LAYOUTS, MARKER_SETS

__all__ = ["KEYPOINT_LAYOUTS", "MARKER_SETS", "build_parser", "check_output", "main"]

# each command: the function that adds its arguments and the one that runs it, in the order
# of the help
COMMANDS = {
    "build": (body.add_build, body.run_build),
    "info": (body.add_info, body.run_info),
    "simulate": (simulate.add_simulate, simulate.run_simulate),
    "walk": (walk.add_walk, walk.run_walk),
    "view": (view.add_view, view.run_view),
    "export": (body.add_export, body.run_export),
    "ik": (motion.add_ik, motion.run),
    "scale": (motion.add_scale, motion.run),
    "track": (motion.add_track, motion.run),
    "id": (motion.add_id, motion.run),
    "loads": (motion.add_loads, motion.run),
    "report": (motion.add_report, motion.run),
    "variants": (body.add_variants, body.run_variants),
    "bench": (bench.add_bench, bench.run_bench),
    "sweep": (bench.add_sweep, bench.run_sweep),
}

OUTPUTS = {  # the options of each command that name a file or folder to write
    "build": ("output",),
    "simulate": ("output",),
    "walk": ("output", "html", "figure", "mot"),
    "view": ("html",),
    "export": ("mjcf",),
    "id": ("output", "figure", "html"),
    "ik": ("output", "figure", "html", "save_markers"),
    "track": ("output", "figure", "html", "mot"),
    "scale": ("output",),
    "loads": ("output",),
    "report": ("output",),
    "bench": ("output",),
    "sweep": ("output",),
}
FOLDERS = ("bench", "sweep")  # the commands whose output is a folder


def build_parser() -> argparse.ArgumentParser:
    """The parser of every command (:data:`COMMANDS`)."""
    from .. import __version__

    p = argparse.ArgumentParser(
        prog="humanoid", description="Physics-based human body models on Pinocchio."
    )
    p.add_argument("--version", action="version", version=f"humanoid {__version__}")
    sub = p.add_subparsers(dest="command", required=True)

    def command(name, **kw):  # every option's help shows its default
        return sub.add_parser(name, formatter_class=argparse.ArgumentDefaultsHelpFormatter, **kw)

    for add, _ in COMMANDS.values():
        add(command)
    return p


def check_output(path: str, option: str, folder: bool = False) -> Path:
    """An output path that can be written, checked before any work starts: not an existing
    directory (or an existing file, for a folder), its parent creatable and writable.

    Raises:
        UsageError: naming the option and what is wrong with the path.
    """
    p = Path(path)
    if folder:
        if p.exists() and not p.is_dir():
            raise UsageError(f"{option} {path}: exists and is not a folder")
        parent = p
    else:
        if p.is_dir():
            raise UsageError(f"{option} {path}: is a folder; give a file name")
        parent = p.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"{option} {path}: cannot create {parent}: {exc.strerror}") from None
    if not os.access(parent, os.W_OK):
        raise UsageError(f"{option} {path}: {parent} is not writable")
    if p.exists() and not folder and not os.access(p, os.W_OK):
        raise UsageError(f"{option} {path}: the file is not writable")
    return p


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit code (0 done, 2 bad input, 3 a run that did
    not complete or failed its checks). A closed output pipe (``| head``) ends it quietly."""
    args = build_parser().parse_args(argv)
    try:
        for name in OUTPUTS.get(args.command, ()):
            value = getattr(args, name, None)
            if value is not None:
                option = "--" + name.replace("_", "-") if name != "output" else "-o"
                check_output(value, option, folder=args.command in FOLDERS)
        return COMMANDS[args.command][1](args)
    except HumanoidError as exc:
        print(f"humanoid {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        # the reader went away (``humanoid info ... | head``): stop writing, no traceback
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
