"""`evsim lab [--port N] [--no-browser]`: the teaching lab (evsim_app.lab) as a local web app on 127.0.0.1.

Needs the `lab` extra (Panel); without it the command says how to install it. Ctrl-C stops the server (exit 0).
"""

from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(subparsers: argparse._SubParsersAction, epilog: str) -> argparse.ArgumentParser:
    """Register `lab` on the evsim subparsers; return its parser.

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
        "lab", epilog=epilog,
        help="the teaching lab: interactive panels (one pixel, a sensor over a scene, reconstruction, real data) in "
             "the browser; needs pip install \"evsim[lab]\"")
    p.add_argument("--port", type=int, default=None, help="TCP port on 127.0.0.1 (default: a free one)")
    p.add_argument("--no-browser", action="store_true", help="only serve and print the address; open no browser")
    p.add_argument("--recording", type=Path, default=None,
                   help="a hybrid recording (AEDAT4, IJRR folder, ...): its busiest pixel becomes a signal of the "
                        "one-pixel panel")
    p.add_argument("--image", type=Path, default=None, help="a photo (PNG, JPEG, EXR, ...) offered as a scene")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """The handler: check the extra and the flags, print the address, serve until Ctrl-C.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed flags of `evsim lab`.

    Returns
    -------
    int
        The exit code (0: success; errors are raised, for evsim_app.main to report).
    """
    import sim
    from evsim_app.lab import require_panel

    require_panel()
    if args.port is not None and not 1 <= args.port <= 65535:
        raise sim.EvsimInputError(f"--port must be a TCP port in 1..65535, got {args.port}")
    for flag, path in (("--recording", args.recording), ("--image", args.image)):
        if path is not None and not path.exists():
            raise sim.EvsimInputError(f"{flag}: {path} does not exist")
    from evsim_app.lab.app import free_port, serve

    port = args.port or free_port()
    print(f"evsim lab: serving on http://127.0.0.1:{port}/ (Ctrl-C stops it)", flush=True)
    try:
        serve(port, open_browser=not args.no_browser, recording=args.recording and str(args.recording),
              photo=args.image and str(args.image))
    except KeyboardInterrupt:  # Panel's own SIGINT handler usually stops the server first, and serve returns
        pass
    print("\nevsim lab: stopped", flush=True)
    return 0
