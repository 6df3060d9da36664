"""`evsim evaluate REAL --task realism --against SIM`: how real a simulation's events are (evsim_eval.realism).

add_realism_flags(evaluate_parser) adds --against and --window; evaluate_realism(args) prints the realism table
(real, simulated, score) and writes --json.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import sim


def add_realism_flags(parser: argparse.ArgumentParser) -> None:
    """The --task realism flags of the evaluate parser.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The parser to add the flags to.
    """
    g = parser.add_argument_group("--task realism: how real a simulation's events are (DATASET is the real "
                                  "recording: AEDAT4, IJRR folder, native HDF5, ...)")
    g.add_argument("--against", type=Path, metavar="SIM",
                   help="the simulated recording to score against DATASET (any layout evsim reads; a dataset folder "
                        "of one sequence), simulated at the real sensor's size on the same time axis")
    g.add_argument("--window", type=float, nargs=2, metavar=("START_S", "END_S"),
                   help="score [START_S, END_S) seconds from each recording's origin (its first frame's "
                        "exposure start, else its first event; default: the real recording's whole event stream)")


def check_realism_args(args: argparse.Namespace) -> None:
    """EvsimInputError for flags of the other tasks, a missing --against or a bad --window.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command-line flags.
    """
    if args.against is None:
        raise sim.EvsimInputError("--task realism needs --against SIM, the simulated recording to score")
    if args.workers is not None or args.scheduler is not None or args.tune:
        raise sim.EvsimInputError("--task realism runs in this process on one pair of recordings: drop --workers, "
                                  "--scheduler and --tune")
    if args.window is not None and not (0 <= args.window[0] < args.window[1]):
        raise sim.EvsimInputError(f"--window needs 0 <= START_S < END_S, got {args.window[0]:g} {args.window[1]:g}")


def evaluate_realism(args: argparse.Namespace) -> int:
    """Print the realism table of --against against DATASET and write --json.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command-line flags.

    Returns
    -------
    int
        The exit code (0: success; errors are raised, for evsim_app.main to report).
    """
    from evsim_eval.realism import format_comparison, load_one, score_recordings, write_comparison_json

    check_realism_args(args)
    real = load_one(args.dataset, "DATASET")
    simulated = load_one(args.against, "--against")
    comparison = score_recordings(real, simulated, None if args.window is None else tuple(args.window))
    print(format_comparison(comparison, "real", "simulated"))
    if args.json is not None:
        write_comparison_json(comparison, args.json)
        print(f"\nscores written to {args.json}")
    return 0
