"""`evsim reconstruct DATASET --out DIR`: HDR frames of a method as EXR folders with timestamps.txt
(evsim_eval.reconstruct)."""

from __future__ import annotations

import argparse
from pathlib import Path

import sim
from evsim_eval.choices import KALMAN_METHODS

from .flags import EPILOG, add_akf_flags, akf_options


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register `reconstruct` on the evsim subparsers.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The evsim subparsers.
    """
    rc = sub.add_parser("reconstruct", help="reconstruct HDR frames and write them as EXR (with timestamps.txt)",
                        epilog=EPILOG)
    rc.add_argument("dataset", type=Path, help="as for evaluate")
    rc.add_argument("--out", required=True, help="output folder (one sub-folder per sequence when the "
                                                            "dataset has several), written atomically: it "
                                                            "appears whole")
    rc.add_argument("--method", default="akf", help="reconstruction method (akf.METHODS; default akf, the causal "
                                                     "filter; aks: the smoother, the filter run forward and "
                                                     "backward and fused). The AKF's and the smoother's output is "
                                                     "unbounded: HDR above the frames' clip")
    rc.add_argument("--variance", action="store_true", help="also write the state variance P (log^2) of akf or aks "
                                                            "as an EXR folder 'variance' in each sequence's folder")
    rc.add_argument("--times", default="reference", help="output times: reference, frames (mid-exposures) or "
                                                         "fps:N (N per second); default reference")
    rc.add_argument("--overwrite", action="store_true", help="replace an existing, non-empty --out (refused "
                                                            "otherwise)")
    add_akf_flags(rc)
    rc.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """`evsim reconstruct DATASET --out DIR`: EXR frames of every sequence, written atomically.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed flags of `evsim reconstruct`.

    Returns
    -------
    int
        The exit code (0: success; errors are raised, for evsim_app.main to report).
    """
    from evsim_eval.reconstruct import reconstruct_dataset

    if args.leak_hz is not None and args.method not in KALMAN_METHODS:
        raise sim.EvsimInputError(f"--leak-hz applies to the akf and aks methods only, not {args.method!r}")
    out = Path(args.out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())) and not args.overwrite:
        raise sim.EvsimInputError(f"output {out} already exists and is not an empty folder; pass --overwrite to "
                                  "replace it")
    options = akf_options(args).get(args.method)
    from generators.formats.atomic import atomic_path

    with atomic_path(out, directory=True) as tmp:  # the whole --out appears at once, replacing the old one
        written = reconstruct_dataset(args.dataset, tmp, method=args.method, times=args.times,
                                      method_options=options, variance=args.variance)
    for name, folder, n in written:
        print(f"{name}: {n} {args.method} frames (linear, CRF x units) written to {out / folder.relative_to(tmp)}")
    return 0
