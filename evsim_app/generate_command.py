"""`evsim generate ahdr|sweep`: scenes -> AHDR datasets (generators.dataset) or one scene over a grid of DVS
parameters (generators.sweep)."""

from __future__ import annotations

import argparse

from .dataset_flags import add_scene_flags, dataset_config
from .flags import EPILOG, add_output_flags, add_run_flags, run_options


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register `generate` on the evsim subparsers.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The evsim subparsers.
    """
    gen = sub.add_parser("generate", help="generate datasets (ahdr, sweep)", epilog=EPILOG)
    gsub = gen.add_subparsers(dest="generator", required=True)
    ahdr = gsub.add_parser("ahdr", help="scene(s) -> events + LDR frames + HDR reference, one file per sequence",
                           epilog=EPILOG)
    add_scene_flags(ahdr)
    add_output_flags(ahdr, "evsim_dataset")
    add_run_flags(ahdr)
    ahdr.set_defaults(func=run_ahdr)
    sweep = gsub.add_parser("sweep", help="one scene over a grid of DVS noise/threshold parameters", epilog=EPILOG)
    add_scene_flags(sweep)
    add_output_flags(sweep, "evsim_sweep")
    add_run_flags(sweep)
    grid = sweep.add_argument_group("grid (lists of values, over the configuration's [sweep]; without "
                                     "either: threshold_sigma 0 0.05 x shot_noise_hz 0 2)")
    grid.add_argument("--threshold-sigma", type=float, nargs="+", help="threshold mismatch std (log units)")
    grid.add_argument("--shot-noise-hz", type=float, nargs="+", help="shot-noise rate per pixel (Hz)")
    grid.add_argument("--leak-hz", type=float, nargs="+", help="leak-event rate per pixel (Hz)")
    grid.add_argument("--refractory-us", type=int, nargs="+", help="refractory period (microseconds)")
    grid.add_argument("--hot-pixel-fraction", type=float, nargs="+", help="fraction of hot pixels (0..1)")
    grid.add_argument("--hot-pixel-hz", type=float, nargs="+", help="event rate of a hot pixel (Hz)")
    sweep.set_defaults(func=run_sweep)


def run_ahdr(args: argparse.Namespace) -> int:
    """`evsim generate ahdr`: one file per sequence, then one line naming the folder.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command-line flags.

    Returns
    -------
    int
        The exit code (0: success; errors are raised, for evsim_app.main to report).
    """
    from generators.dataset import generate_dataset

    cfg = dataset_config(args)
    index = generate_dataset(cfg, args.out, overwrite=args.overwrite, progress=not args.no_progress,
                             fmt=args.format, seed=args.seed, **run_options(args))
    print(f"wrote {len(cfg.sequences)} sequence(s) to {index.parent} (index: {index.name})")
    return 0


def run_sweep(args: argparse.Namespace) -> int:
    """`evsim generate sweep`: one scene over a grid of DVS parameters, then one line naming the folder.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command-line flags.

    Returns
    -------
    int
        The exit code (0: success; errors are raised, for evsim_app.main to report).
    """
    from generators.config import build_scene, to_ahdr_config
    from generators.sweep import DEFAULT_GRID, GRID_KEYS, generate_sweep

    cfg = dataset_config(args)
    spec = cfg.sequences[0]
    grid = dict(cfg.sweep)  # the configuration's [sweep], the grid flags over it; DEFAULT_GRID when neither
    for key in GRID_KEYS:
        values = getattr(args, key)
        if values is not None:
            grid[key] = values
    grid = grid or dict(DEFAULT_GRID)
    s = spec.settings
    scene = build_scene(spec.scene, s["height"], s["width"], spec.duration_us, where=f"sequence {spec.name!r}")
    index = generate_sweep(scene, args.out, grid, to_ahdr_config(s), cfg.seed if args.seed is None else args.seed,
                           overwrite=args.overwrite, progress=not args.no_progress, fmt=args.format or cfg.format,
                           **run_options(args))
    print(f"wrote the sweep over {', '.join(grid)} for {spec.name!r} to {index.parent} (index: {index.name})")
    return 0
