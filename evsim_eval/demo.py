"""The demo: the first sequence of the built-in AHDR suite (needs no files), generated and then scored by the
reference protocol, as `evsim demo` runs it. Two steps, so that a caller can do other work in between (the command
line compiles the reconstruction kernels on the other core while the sequence is generated)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

import sim

from .choices import DEMO_SIZE

__all__ = ["DemoSequence", "write_demo_sequence", "score_demo"]



@dataclass(frozen=True)
class DemoSequence:
    """What write_demo_sequence wrote: the file, the suite's scene name and what the scene shows."""

    path: Path
    name: str
    image: str


def write_demo_sequence(out: str | Path, *, height: int | None = None, width: int | None = None,
                        duration_s: float = 1.0, sensor: str | Path | sim.Sensor = "davis346", dvs: dict | None = None,
                        camera: dict | None = None, seed: int = 0, progress: bool = True) -> DemoSequence:
    """Generate the demo sequence into out/demo.h5, replacing an earlier one.

    Parameters
    ----------
    out : str or Path
        The output folder, created if needed (and removed again, when it was created, if the run fails).
    height, width : int, optional
        The sensor's size in pixels (default DEMO_SIZE).
    duration_s : float
        The sequence's duration in seconds (> 0).
    sensor : str, Path or sim.Sensor
        A DVS preset name or a sensor file (sim.load_sensor).
    dvs, camera : dict, optional
        DVS and LDR camera field overrides over the sensor's.
    seed : int
        The root seed (numpy SeedSequence entropy), recorded in the file.
    progress : bool
        Show a progress bar.

    Returns
    -------
    DemoSequence
        The written file, the scene's name and the image it shows.
    """
    from generators.builtin import ahdr_suite, ahdr_suite_config
    from generators.dataset import first_missing, remove_if_empty, write_sequence

    height, width = height or DEMO_SIZE[0], width or DEMO_SIZE[1]
    if not duration_s > 0 or height <= 0 or width <= 0:
        raise sim.InvalidParameterError("--duration-s, --height and --width must be positive")
    config = ahdr_suite_config(sensor, dvs=dvs, camera=camera)
    name, scene = ahdr_suite(height, width, duration_s, include_hdr=False)[0]
    out = Path(out)
    created = first_missing(out)
    out.mkdir(parents=True, exist_ok=True)
    try:
        entry = write_sequence(out, "demo", scene, config, np.random.SeedSequence(seed), "native", progress=progress)
    except BaseException:  # failed or interrupted: no empty folder left behind
        remove_if_empty(out, created)
        raise
    return DemoSequence(out / entry["file"], name, scene.describe()["image"])


def score_demo(path: str | Path) -> str:
    """Score the demo sequence by the reference protocol (evsim_eval.evaluate_recording, default methods and
    metrics) and write the table beside it as metrics.txt.

    Parameters
    ----------
    path : str or Path
        The demo's file (DemoSequence.path).

    Returns
    -------
    str
        The method-by-metric table, as written to metrics.txt.
    """
    from generators.formats import load
    from generators.formats.atomic import write_text_atomic

    from .evaluate import evaluate_recording
    from .tables import format_scores

    table, _ = evaluate_recording(load(path))
    text = format_scores(table)
    write_text_atomic(Path(path).parent / "metrics.txt", text + "\n")
    return text
