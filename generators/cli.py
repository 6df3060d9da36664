"""The `evsim` command line. Each subcommand is a thin layer over the public Python API."""

from __future__ import annotations

import argparse
import sys


def _cmd_demo(args: argparse.Namespace) -> int:
    import numpy as np

    import sim

    # Placeholder until the generators land: a bright bar sweeping over a dark background.
    h, w, n = 120, 160, 200
    times = np.arange(n, dtype=np.int64) * 1000
    xx = np.arange(w)[None, :]
    frames = (0.01 + np.exp(-0.5 * ((xx - 10 - 0.6 * np.arange(n)[:, None, None]) / 4.0) ** 2)).astype(np.float32)
    frames = np.broadcast_to(frames, (n, h, w))
    events = sim.emulate(frames, times, sim.DVSParams.preset("davis346"), seed=args.seed)
    print(f"{events.size} events over {times[-1] / 1e6:.3f} s at {w}x{h}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="evsim", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="run the main job on the built-in default data")
    demo.add_argument("--seed", type=int, default=0, help="root seed (numpy SeedSequence entropy)")
    demo.set_defaults(func=_cmd_demo)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
