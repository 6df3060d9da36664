"""`evsim demo`: generate the built-in demo sequence, reconstruct it and print the scores (evsim_eval.demo)."""

from __future__ import annotations

import argparse
from pathlib import Path

from evsim_eval.choices import DEMO_SIZE

from .flags import EPILOG, SENSOR_HELP, non_negative, positive
from .model_flags import add_model_flags, camera_overrides, dvs_overrides, sensor_size


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register `demo` on the evsim subparsers.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The evsim subparsers.
    """
    demo = sub.add_parser("demo", help="generate a short built-in AHDR sequence, reconstruct it and print metrics",
                          epilog=EPILOG)
    demo.add_argument("--out", default="evsim_demo", help="output folder (default ./evsim_demo); demo.h5 and "
                                                          "metrics.txt in it are replaced")
    demo.add_argument("--seed", type=non_negative(int), default=0, help="root seed (non-negative integer; default 0)")
    demo.add_argument("--duration-s", type=positive(float), default=1.0, help="duration in seconds (default 1.0)")
    demo.add_argument("--height", type=positive(int), help=f"height in pixels (default {DEMO_SIZE[0]})")
    demo.add_argument("--width", type=positive(int), help=f"width in pixels (default {DEMO_SIZE[1]})")
    demo.add_argument("--sensor", metavar="NAME|FILE", default="davis346", help=f"{SENSOR_HELP} (default davis346)")
    add_model_flags(demo)
    demo.add_argument("--no-reconstruct", action="store_true", help="only generate, do not run AKF and baselines")
    demo.add_argument("--no-progress", action="store_true", help="no progress bars")
    demo.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """`evsim demo`: the sequence, what it holds, then the scores (compiling the filters meanwhile).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed flags of `evsim demo`.

    Returns
    -------
    int
        The exit code (0: success; errors are raised, for evsim_app.main to report).
    """
    from evsim_eval.demo import score_demo, write_demo_sequence
    from evsim_eval.protocols import UNITS
    from generators.config import resolve_sensor

    from .info import describe, format_description
    from .precompile import start_background_compile, wait

    height, width = sensor_size(args)
    sensor = resolve_sensor("--sensor", args.sensor)
    compiling = None if args.no_reconstruct else start_background_compile()  # on the other core meanwhile
    demo = write_demo_sequence(args.out, height=height, width=width, duration_s=args.duration_s, sensor=sensor,
                               dvs=dvs_overrides(args), camera=camera_overrides(args), seed=args.seed,
                               progress=not args.no_progress)
    print(f"evsim demo: {demo.name} ({demo.image}), written to {demo.path}")
    print(format_description(describe(demo.path)))
    if args.no_reconstruct:
        return 0
    wait(compiling)
    text = score_demo(demo.path)
    print()
    print(text)
    print(f"(units: {UNITS['reference']})")
    print(f"\nmetrics written to {Path(args.out) / 'metrics.txt'}")
    return 0
