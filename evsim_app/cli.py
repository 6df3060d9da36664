"""The `evsim` command line. Each subcommand is a thin layer over the public Python API.

Exit codes: 0 success, 2 usage error, bad input or a full disk (message "evsim: error: ..."), 3 some sequences
failed (each listed with its error at the end; the others were written or scored: rerun with --resume), 1 unexpected
failure, 130 interrupted (Ctrl-C), 143 terminated (SIGTERM); temporary files are removed on every exit path.
Units: times in seconds (-s) or microseconds (-us) as the flag names say, sizes in pixels, rates in Hz,
speeds in pixels per second, angles in degrees, contrast thresholds in natural-log units.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import traceback
import warnings

import sim
from generators.runner import TasksFailed

from . import (
    calibrate_command,
    convert_command,
    demo_command,
    evaluate_command,
    export_command,
    generate_command,
    info_command,
    lab_command,
    reconstruct_command,
)
from .flags import EPILOG
from .model_flags import flag_hint
from .paths import check_paths
from .plots.cli import add_plot_parser
from .sigterm import MESSAGE as SIGTERM_MESSAGE
from .sigterm import Terminated, Watchdog, end_now, interrupted_message, on_sigterm
from .suggesting_parser import SuggestingParser


def build_parser() -> argparse.ArgumentParser:
    """The `evsim` parser: one subcommand per module (each registers itself with add_parser).

    Returns
    -------
    argparse.ArgumentParser
        The parser (a SuggestingParser); each subcommand sets func, its handler.
    """
    parser = SuggestingParser(prog="evsim", description=__doc__,
                              formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG)
    parser.flag_hint = flag_hint  # a model field typed as a flag: --dvs FIELD=VALUE
    sub = parser.add_subparsers(dest="command", required=True)
    for command in (demo_command, generate_command, convert_command, info_command, evaluate_command,
                    reconstruct_command):
        command.add_parser(sub)
    add_plot_parser(sub)
    calibrate_command.add_parser(sub)
    export_command.add_parser(sub, EPILOG)
    lab_command.add_parser(sub, EPILOG)
    return parser


def _note(message, category, filename, lineno, file=None, line=None) -> None:
    """Print an evsim note (sim.EvsimNote) as "evsim: note: ...", others as Python does."""
    if issubclass(category, sim.EvsimNote):
        print(f"evsim: note: {getattr(message, 'cli_message', message)}", file=sys.stderr)  # in flags
    else:
        sys.stderr.write(warnings.formatwarning(message, category, filename, lineno, line))


def _run(args: argparse.Namespace) -> int:
    """args.func(args), with Ctrl-C or SIGTERM raised as themselves when the code they interrupted wrapped them in
    another exception (a C extension's import turns the signal handler's exception into "ImportError:
    initialization failed", with it as the cause): the run is interrupted, not failed with a bug.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        The command's exit code.
    """
    try:
        return args.func(args)
    except Exception as e:
        seen, cause = set(), e
        while cause is not None and id(cause) not in seen:  # (a chain can loop)
            if isinstance(cause, (KeyboardInterrupt, Terminated)):
                raise cause from None
            seen.add(id(cause))
            cause = cause.__cause__ or cause.__context__
        raise


def main(argv: list[str] | None = None) -> int:
    """Run the `evsim` command line (see the module docstring).

    Parameters
    ----------
    argv : list of str, optional
        The arguments (default: sys.argv[1:]).

    Returns
    -------
    int
        The exit code: 0 success, 2 usage error, bad input or a full disk, 3 some sequences failed, 1 unexpected
        failure, 130 interrupted, 143 terminated.
    """
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as e:  # argparse: --help (0) or a usage error (2), message already printed
        return int(e.code or 0)
    previous = signal.signal(signal.SIGTERM, on_sigterm)
    watchdog = Watchdog()  # ends the process 0.7 s after SIGTERM if the main thread has not by then
    if hasattr(signal, "SIGXFSZ"):  # a file size limit (ulimit -f): writes fail with EFBIG (exit 2), not a core dump
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    try:
        check_paths(args)
        with warnings.catch_warnings():
            warnings.showwarning = _note  # the library's notes (an export leaving parts out) as one line each
            return _run(args)
    except sim.EvsimInputError as e:
        print(f"evsim: error: {getattr(e, 'cli_message', e)}", file=sys.stderr)  # in flags (sim.OptionError)
        return 2
    except TasksFailed as e:
        for f in e.failures:
            if f.kind == "bug":  # show where
                print(f"{f.name}:\n{f.traceback}", file=sys.stderr)
        print(f"evsim: error: {e.cli_message}", file=sys.stderr)
        return 3
    except KeyboardInterrupt:
        print(interrupted_message(getattr(args, "out", None), hasattr(args, "resume")), file=sys.stderr)
        return 130
    except Terminated:  # the temporary files are removed (the writers' cleanup has run)
        watchdog.reported = True
        print(SIGTERM_MESSAGE, file=sys.stderr)
        end_now(reported=True)  # exits 143 now: the interpreter's teardown would take up to a second more

    except BrokenPipeError:  # the reader of our output went away (e.g. `evsim info f | head`): not a failure
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except Exception as e:
        from generators.formats.atomic import DiskFullError, is_disk_full

        if isinstance(e, DiskFullError):  # names the output; its temporary files are removed
            print(f"evsim: error: {e}", file=sys.stderr)
            return 2
        if is_disk_full(e):
            print(f"evsim: error: disk full or file too large, nothing written in its place: {e}", file=sys.stderr)
            return 2
        traceback.print_exc()
        print("evsim: unexpected error (a bug: please report it with the traceback above)", file=sys.stderr)
        return 1
    finally:
        signal.signal(signal.SIGTERM, previous)
        watchdog.stop()


if __name__ == "__main__":
    sys.exit(main())
