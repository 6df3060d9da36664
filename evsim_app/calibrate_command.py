"""`evsim calibrate RECORDING --out sensor.toml`: fit the sensor model to a real hybrid recording
(evsim_eval.calibrate), print the fit table and write a sensor file that generate, convert and the API accept."""

from __future__ import annotations

import argparse
import json
from pathlib import Path


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the `calibrate` subcommand.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The evsim subparsers.
    """
    p = sub.add_parser("calibrate", help="fit the DVS model to a real hybrid recording; write a sensor file",
                       description="Simulate the recording's own frames (as convert does) and fit the DVS "
                                   "parameters (thresholds and spread, log offset, refractory, cutoff, shot, leak "
                                   "and hot-pixel noise) so that the simulated events match the real ones' "
                                   "statistics (the realism score). Prints the fit table; writes a sensor file.")
    p.add_argument("recording", type=Path, metavar="RECORDING",
                   help="a hybrid recording with frames: .aedat4, IJRR folder, native or E2VID HDF5")
    p.add_argument("--out", type=Path, required=True, help="the sensor file to write (.toml)")
    p.add_argument("--window", type=float, nargs=2, default=None, metavar=("START", "END"),
                   help="the part of the recording fitted, seconds from its first frame's exposure start (default: "
                        "the whole recording less its first 0.4 s, at most a fifth of it, while the sensor settles)")
    p.add_argument("--preset", default="davis346", help="the DVS preset the fit starts from and the sensor file "
                                                        "modifies (default davis346)")
    p.add_argument("--name", help="the sensor's name (default: the output file's stem)")
    p.add_argument("--black-level", type=float, help="the frames' value for no light in DN (default: the "
                                                     "recording's darkest 0.01 %% of frame values)")
    p.add_argument("--input-conditioning", choices=("temporal", "off"),
                   help="the frames' input conditioning (default temporal, as convert: a real camera's read noise "
                        "held out of the DVS; off for noise-free simulated frames)")
    p.add_argument("--max-evaluations", type=int, default=120,
                   help="simulations of the Nelder-Mead stage (default 120)")
    p.add_argument("--seed", type=int, default=0, help="seed of the simulations (default 0)")
    p.add_argument("--thresholds", type=float, nargs=2, metavar=("ON", "OFF"),
                   help="for a recording without frames: the ON and OFF contrast thresholds (log units), which its "
                        "events cannot tell (default: the --preset's)")
    p.add_argument("--json", type=Path, help="also write the fit (parameters, scores, timing) as JSON here")
    p.add_argument("--overwrite", action="store_true", help="replace an existing --out (and --json) file")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def check_outputs(args: argparse.Namespace) -> None:
    """Before the minutes of fitting: --out is a .toml file, and neither it nor --json exists unless --overwrite
    (sim.EvsimInputError naming the flag; the CLI checks that they can be written).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command-line flags.
    """
    import sim

    if args.out.suffix.lower() != ".toml":
        raise sim.EvsimInputError(f"--out {args.out}: a sensor file is a .toml file (give e.g. "
                                  f"{args.out.with_suffix('.toml')})")
    for flag, path in (("--out", args.out), ("--json", args.json)):
        if path is not None and path.exists() and not args.overwrite:
            raise sim.EvsimInputError(f"{flag} {path} already exists; pass --overwrite to replace it")


def run(args: argparse.Namespace) -> int:
    """`evsim calibrate`: fit, print the fit table, write the sensor file (and --json).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command-line flags.

    Returns
    -------
    int
        The exit code (0: success; errors are raised, for evsim_app.main to report).
    """
    from evsim_eval.calibrate import calibrate, fit_table, write_calibration

    check_outputs(args)
    window = None if args.window is None else tuple(args.window)
    if args.thresholds is not None:  # a recording without frames (refused with frames)
        from evsim_eval.calibrate.events_only import calibrate_events_only

        cal = calibrate_events_only(args.recording, None, window, preset=args.preset, thresholds=args.thresholds,
                                    seed=args.seed, log=print)
    else:
        cal = calibrate(args.recording, window, preset=args.preset, black_level=args.black_level,
                        conditioning=args.input_conditioning, seed=args.seed, max_evaluations=args.max_evaluations,
                        progress=not args.no_progress, log=print)
    if _events_only(args, cal):
        return 0
    given = "--window" if args.window is not None else "the recording less a settling start (default)"
    print(f"window: {cal.window_s[0]:.4g}-{cal.window_s[1]:.4g} s from the first frame's exposure start ({given})")
    print(fit_table(cal))
    print(f"{cal.evaluations} simulations in {cal.wall_s:.0f} s wall, {cal.cpu_s:.0f} s CPU")
    out = write_calibration(cal, args.out, args.name)
    flag = f" --input-conditioning {args.input_conditioning}" if args.input_conditioning else ""
    print(f"wrote {out}: use it with `evsim convert {args.recording} --sensor {out}{flag}` (the table's fitted column "
          f"is that conversion scored by `evsim evaluate {args.recording} --task realism --against CONVERTED "
          f"--window {cal.window_s[0]:.4g} {cal.window_s[1]:.4g}`)")
    if args.json is not None:
        from generators.formats.atomic import write_text_atomic

        write_text_atomic(args.json, json.dumps(cal.to_dict(), indent=1, default=str))
    return 0


def _events_only(args: argparse.Namespace, cal: object) -> bool:
    """For the fit of a recording without frames (evsim_eval.calibrate.events_only): print its table, write its
    sensor file and --json; True. False for any other fit."""
    from evsim_eval.calibrate.events_only import EventsOnlyCalibration, events_only_table, write_events_only

    if not isinstance(cal, EventsOnlyCalibration):
        return False
    print(events_only_table(cal))
    out = write_events_only(cal, args.out, args.name)
    source = "given" if cal.thresholds_given else f"the preset {cal.preset_name}'s"
    print(f"wrote {out}: noise, hot pixels and refractory fitted; thresholds {source}, not fitted; use it with "
          f"`evsim convert VIDEO --sensor {out}`")
    if args.json is not None:
        from generators.formats.atomic import write_text_atomic

        write_text_atomic(args.json, json.dumps(cal.to_dict(), indent=1, default=str))
    return True
