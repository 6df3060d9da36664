"""Flags shared by several subcommands: the epilog, number types, where the tasks run (--workers, --scheduler,
--resume), the outputs (--out, --overwrite, --seed, --format), the AKF's --leak-hz and name lists."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable

import sim
from evsim_eval.choices import KALMAN_METHODS
from generators.choices import EXPORT_FORMATS, OUTPUTS

EPILOG = ("Units: times in seconds (-s) or microseconds (-us) as the flag names say, sizes in pixels, rates in Hz, "
          "speeds in pixels per second, angles in degrees, contrast thresholds in natural-log units. "
          "Exit codes: 0 success, 2 usage error, bad input or full disk, 3 some sequences failed (listed at the end; "
          "the others were done), 1 unexpected failure, 130 Ctrl-C, 143 SIGTERM.")


SENSOR_HELP = (f"the sensor model: a DVS preset ({', '.join(sim.DVS_PRESETS)}) or a sensor file (.toml: see "
               "docs/guide/calibrate.md)")


def non_negative(kind: type) -> Callable[[str], float]:
    """argparse type: a finite number >= 0.

    Parameters
    ----------
    kind : type
        The conversion: int for seeds and counts, float for rates.

    Returns
    -------
    callable
        parse(text) -> the number; argparse.ArgumentTypeError otherwise.
    """
    return _number(kind, allow_zero=True)


def positive(kind: type) -> Callable[[str], float]:
    """argparse type: a finite number > 0 (`--duration-s -1` is refused by argparse, naming the flag).

    Parameters
    ----------
    kind : type
        The conversion: int for sizes and exposures, float for durations and rates.

    Returns
    -------
    callable
        parse(text) -> the number; argparse.ArgumentTypeError otherwise.
    """
    return _number(kind, allow_zero=False)


def _number(kind: type, *, allow_zero: bool) -> Callable[[str], float]:
    if kind is int:
        what = "a non-negative integer" if allow_zero else "a positive integer"
    else:
        what = "a finite number >= 0" if allow_zero else "a finite number > 0"

    def parse(text: str):
        try:
            v = kind(text)
        except ValueError:
            v = -1
        if not (math.isfinite(v) and (v >= 0 if allow_zero else v > 0)):
            raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}")
        return v

    return parse


def output_list(text: str) -> list[str]:
    """argparse type of --outputs.

    Parameters
    ----------
    text : str
        Comma-separated names of generators.choices.OUTPUTS, events among them.

    Returns
    -------
    list of str
        The names.
    """
    names = [o.strip() for o in text.split(",") if o.strip()]
    unknown = [o for o in names if o not in OUTPUTS]
    if unknown or "events" not in names:
        why = f"unknown output {unknown[0]!r}" if unknown else "events are always written"
        raise argparse.ArgumentTypeError(f"{why}; give events[,frames,reference], got {text!r}")
    return names


def names(text: str) -> tuple[str, ...]:
    """argparse type of a comma-separated list of names.

    Parameters
    ----------
    text : str
        The list.

    Returns
    -------
    tuple of str
        The names, stripped (at least one).
    """
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    if not names:
        raise sim.EvsimInputError(f"expected a comma-separated list of names, got {text!r}")
    return names


def add_run_flags(p: argparse.ArgumentParser, *, resume: bool = True) -> None:
    """--workers / --scheduler (and --resume): where the per-sequence tasks run (generators.runner).

    Parameters
    ----------
    p : argparse.ArgumentParser
        The parser to add the flags to.
    resume : bool, optional
        Add --resume too (default True).
    """
    g = p.add_argument_group("running the sequences (default: one after the other in this process)")
    where = g.add_mutually_exclusive_group()
    where.add_argument("--workers", type=non_negative(int), metavar="N",
                       help="run them in parallel on a local Dask cluster of N (>= 1) worker processes")
    where.add_argument("--scheduler", metavar="ADDRESS",
                       help="run them on an existing Dask cluster (e.g. tcp://host:8786; its workers need evsim and "
                            "the same input and output paths)")
    if resume:
        g.add_argument("--resume", action="store_true",
                       help="complete an earlier run into --out: keep the sequences whose file is complete and "
                            "records the same configuration and seed (hash), generate the others")


def run_options(args: argparse.Namespace) -> dict:
    """The run keyword arguments from the flags of add_run_flags.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed flags.

    Returns
    -------
    dict
        workers, scheduler (and resume), as generators.dataset.generate_dataset takes them.
    """
    return {k: getattr(args, k) for k in ("workers", "scheduler", "resume") if hasattr(args, k)}


def add_akf_flags(p: argparse.ArgumentParser) -> None:
    """--leak-hz: the AKF's command-line option.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The parser to add the flag to.
    """
    p.add_argument("--leak-hz", type=non_negative(float), default=None,
                   help="the DVS's leak rate (Hz) for the AKF's leak-aware event model (default: the recorded "
                        "one, else 0 = the paper's model)")


def akf_options(args: argparse.Namespace) -> dict:
    """The AKF's options from the command line (only those given: the recording's values otherwise).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed flags of add_akf_flags.

    Returns
    -------
    dict
        {method: {"leak_rate_hz": Hz}} for each Kalman method, or {}.
    """
    return {} if args.leak_hz is None else {m: {"leak_rate_hz": args.leak_hz} for m in KALMAN_METHODS}


def add_output_flags(p: argparse.ArgumentParser, default_out: str) -> None:
    """--out, --overwrite, --seed, --format and --no-progress of the generating subcommands.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The parser to add the flags to.
    default_out : str
        The default output folder.
    """
    p.add_argument("--out", default=default_out, help=f"output folder (default: {default_out})")
    p.add_argument("--overwrite", action="store_true", help="replace the contents of an existing, non-empty --out")
    p.add_argument("--seed", type=non_negative(int), default=None,
                   help="root seed (non-negative integer, numpy SeedSequence entropy; default: the config's, or 0)")
    p.add_argument("--format", choices=EXPORT_FORMATS, default=None,
                   help="also export every sequence to this layout (the native HDF5 file is always written)")
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
