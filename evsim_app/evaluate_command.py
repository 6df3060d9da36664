"""`evsim evaluate DATASET`: score HDR reconstructions per sequence (evsim_eval.evaluate), event denoisers
(--task denoise, evsim_eval.denoisers) or the realism of simulated events (--task realism)."""

from __future__ import annotations

import argparse
from pathlib import Path

import sim
from evsim_eval.choices import DEFAULT_METHODS, DEFAULT_METRICS, PROTOCOLS, TUNE_FRACTION, TUNE_METRIC
from generators.runner import raise_failures

from .flags import EPILOG, add_akf_flags, add_run_flags, akf_options, names, run_options
from .realism_command import add_realism_flags


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register `evaluate` on the evsim subparsers.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The evsim subparsers.
    """
    ev = sub.add_parser("evaluate", help="score HDR reconstructions per sequence (AKF, baselines) and print a table",
                        epilog=EPILOG)
    ev.add_argument("dataset", type=Path, help="a file evsim reads with frames (native .h5, AEDAT4, AKF .mat, ...), an "
                                               "IJRR folder, a dataset folder (index.json) or a folder of native .h5 "
                                               "files")
    ev.add_argument("--methods", default=",".join(DEFAULT_METHODS),
                    help=f"comma-separated methods (akf.METHODS; default {','.join(DEFAULT_METHODS)})")
    ev.add_argument("--metrics",
                    help="comma-separated metrics (evsim_eval.METRICS; each table states its normalisation); default, "
                         f"--protocol reference: {','.join(DEFAULT_METRICS['reference'])} (full-range log RMSE and "
                         "PU21 over the whole HDR reference first, then the paper's [0, 1] metrics, clipped at the "
                         "white); --protocol interleave: "
                         f"{','.join(DEFAULT_METRICS['interleave'])}"),
    ev.add_argument("--protocol", choices=PROTOCOLS, default=PROTOCOLS[0],
                    help="reference: against the HDR reference frames; interleave: feed every second frame and "
                         "score on the frames in between (real data; paper supplementary Table 2)")
    ev.add_argument("--json", type=Path, help="also write {method: {sequence: {metric: value}, mean: {...}}} (with "
                                              "per-class scores metric@class, share@class; scoring: what the "
                                              "scores compare; tuning: {method: setting} with --tune)")
    ev.add_argument("--point-scoring", action="store_true",
                    help="interleave: score each reconstruction at the held-out frame's mid-exposure time instead "
                         "of averaged over its exposure window (exposure-matched, the default)")
    ev.add_argument("--tune", action="store_true",
                    help="tune every method by one protocol (evsim_eval.tuning): a coordinate search over its main "
                         "parameters (CF gain, contrast scale, AKF noise scales and smoothing, output bound; "
                         "evsim_eval.tuning.SEARCH_SPACES) on the first --tune-fraction of every sequence's scored "
                         "frames; "
                         "all methods are then scored on the rest")
    ev.add_argument("--tune-fraction", type=float, default=TUNE_FRACTION,
                    help=f"fraction of each sequence's scored frames that tunes (default {TUNE_FRACTION:.3g})")
    ev.add_argument("--tune-metric",
                    help="metric the tuning minimises (maximises for SSIM/PSNR; default "
                         f"{TUNE_METRIC['reference']} with --protocol reference, {TUNE_METRIC['interleave']} with "
                         "--protocol interleave)")
    ev.add_argument("--no-progress", action="store_true", help="no progress messages (tuning, denoising; on stderr)")
    ev.add_argument("--sensor", help="sensor file (from evsim calibrate on this camera) or preset whose thresholds a "
                                     "recording without recorded ones gets (default: estimated from the data)")
    add_akf_flags(ev)
    dn = ev.add_argument_group("--task denoise: event filters scored against the per-event labels")
    dn.add_argument("--task", choices=("reconstruction", "denoise", "realism"), default="reconstruction",
                    help="reconstruction (default): score HDR reconstructions; denoise: TPR on signal and FPR per "
                         "noise type (shot, leak, hot) of each filter over its main parameter, ROC AUCs, and the "
                         "methods on events denoised at each filter's default (needs files written with --labels; "
                         "--json then writes the result of evsim_eval.denoisers); realism: how real the events of "
                         "--against SIM are against those of DATASET (see below)")
    dn.add_argument("--filters", help="comma-separated filters (sim.denoise.FILTERS: correlation, hot_pixel, dv_ba, "
                                      "dv_knoise, dv_fast_decay, tonic_denoise; default: all whose library is "
                                      "installed)")
    dn.add_argument("--no-reconstruct", action="store_true", help="score the filters only")
    add_realism_flags(ev)
    add_run_flags(ev, resume=False)
    ev.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """`evsim evaluate DATASET`: the table of scores (or the denoise or realism task), and --json.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed flags of `evsim evaluate`.

    Returns
    -------
    int
        The exit code (0: success; errors are raised, for evsim_app.main to report).
    """
    from evsim_eval.evaluate import evaluate_dataset
    from evsim_eval.tables import format_table, scoring_record, write_json

    if args.task == "denoise":
        return evaluate_denoise(args)
    if args.task == "realism":
        from .realism_command import evaluate_realism

        return evaluate_realism(args)
    matched = not args.point_scoring
    scores = evaluate_dataset(args.dataset, protocol=args.protocol, methods=names(args.methods),
                              metrics=metrics_of(args), method_options=akf_options(args), tune=args.tune,
                              tune_fraction=args.tune_fraction, tune_metric=args.tune_metric,
                              progress=False if args.no_progress else None, strict=False, exposure_matched=matched,
                              sensor=args.sensor,
                              **run_options(args))
    scored = [s for s in next(iter(scores.table.values()), {}) if s != "mean"]
    if scored:
        print(format_table(scores.table, args.protocol, scores.notes, matched))
    raise_failures("sequences", scores.failures, len(scores.failures) + len(scored),
                   "the table above is over the others" + (f"; {args.json} not written" if args.json else ""))
    if args.json is not None:
        write_json(scores.table, args.json, scores.tuning, scoring_record(args.protocol, matched, scores.notes))
        print(f"\nscores written to {args.json}")
    return 0


def evaluate_denoise(args: argparse.Namespace) -> int:
    """`evsim evaluate DATASET --task denoise`: the filters' table, and --json.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command-line flags.

    Returns
    -------
    int
        The exit code (0: success; errors are raised, for evsim_app.main to report).
    """
    from evsim_eval.denoisers import evaluate_denoise_dataset, format_denoise_table, write_denoise_json

    refuse_run_flags(args, "--task denoise runs in this process")
    filters = None if args.filters is None else names(args.filters)
    result, notes = evaluate_denoise_dataset(args.dataset, filters=filters, reconstruct=not args.no_reconstruct,
                                             protocol=args.protocol, methods=names(args.methods),
                                             metrics=metrics_of(args), method_options=akf_options(args),
                                             progress=not args.no_progress)
    print(format_denoise_table(result, notes))
    if args.json is not None:
        write_denoise_json(result, args.json)
        print(f"\nscores written to {args.json}")
    return 0


def refuse_run_flags(args: argparse.Namespace, why: str) -> None:
    """EvsimInputError when --workers or --scheduler is given to a task that runs in this process.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed flags.
    why : str
        The task, for the message.
    """
    if args.workers is not None or args.scheduler is not None:
        raise sim.EvsimInputError(f"{why}: drop --workers/--scheduler")


def metrics_of(args: argparse.Namespace) -> tuple[str, ...]:
    """The metrics to score.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed flags.

    Returns
    -------
    tuple of str
        --metrics, or the --protocol's default metrics (evsim_eval.choices.DEFAULT_METRICS) when not given.
    """
    return DEFAULT_METRICS[args.protocol] if args.metrics is None else names(args.metrics)
