"""`evsim export SRC DST --format F`: any file or folder evsim reads, written in another layout
(generators.exports.export_path: streamed from native files, atomic; a folder of sequences gives a folder)."""

from __future__ import annotations

import argparse
from pathlib import Path

from generators.choices import FORMATS


def add_parser(subparsers: argparse._SubParsersAction, epilog: str) -> argparse.ArgumentParser:
    """Register `export` on the evsim subparsers; return its parser.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The evsim subparsers.
    epilog : str
        The epilog shared by the subcommands' help.

    Returns
    -------
    argparse.ArgumentParser
        The subcommand's parser.
    """
    p = subparsers.add_parser(
        "export", epilog=epilog,
        help="write a dataset evsim reads (a file, a recording folder, or a folder of sequences) in another layout")
    p.add_argument("source", type=Path, metavar="SRC",
                   help="native or E2VID HDF5, IJRR folder, AKF .mat, AEDAT4, EVT 2.0/3.0 .raw, DAT, E2VID text, "
                        "an EXR folder, or a folder of them (a dataset folder with index.json: one export per "
                        "sequence)")
    p.add_argument("dest", type=Path, metavar="DST",
                   help="output file or folder (a folder with one export per sequence when SRC holds several)")
    p.add_argument("--format", required=True, choices=FORMATS, help="output layout")
    p.add_argument("--overwrite", action="store_true", help="replace an existing DST")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """The handler: export, then one line per written sequence.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed flags of `evsim export`.

    Returns
    -------
    int
        The exit code (0: success; errors are raised, for evsim_app.main to report).
    """
    from generators.exports import export_path

    done = export_path(args.source, args.dest, args.format, overwrite=args.overwrite,
                       progress=not args.no_progress)
    for d in done:
        print(f"{d.name}: {d.source} -> {d.out} ({args.format})")
    return 0
