"""`evsim info FILE`: what a file, recording folder or dataset folder holds (evsim_app.info)."""

from __future__ import annotations

import argparse
from pathlib import Path

from .flags import EPILOG


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register `info` on the evsim subparsers.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The evsim subparsers.
    """
    info = sub.add_parser("info", help="what a dataset holds (duration, events, rates, frames, exposure, CRF, seed)",
                          epilog=EPILOG)
    info.add_argument("file", type=Path, help="a file or recording folder evsim reads (native or E2VID HDF5, AEDAT4, "
                                              "Prophesee .raw/.dat, IJRR or EXR folder, AKF .mat, ...) or a folder "
                                              "of them (a dataset folder: each sequence in turn)")
    info.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """`evsim info FILE`: print what the file (or every sequence of a folder) holds.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed flags of `evsim info`.

    Returns
    -------
    int
        The exit code (0: success; errors are raised, for evsim_app.main to report).
    """
    from .info import describe, format_description

    print(format_description(describe(args.file)))
    return 0
