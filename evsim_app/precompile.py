"""Compile the demo's later numba kernels in a second process while it compiles and runs the DVS (its cold start).

numba compiles under a process-wide lock, so kernels compiled on first use run one after another: on an empty cache
the demo would compile the DVS kernels, then the camera's, then the reconstruction's. A child process compiles the
camera's (a toy capture) and the reconstruction's (AKF, baselines, metrics on a tiny synthetic recording) into the
numba cache on the other core meanwhile, and the demo loads them from there. Nothing starts when the cache already
holds the AKF's kernels.
"""

from __future__ import annotations

import atexit
import os
import subprocess
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from crf_models import CRF
    from generators.formats.recording import Recording
    from sim.camera import CameraParams


def start_background_compile() -> subprocess.Popen | None:
    """Start the child when the numba cache lacks the AKF's kernels.

    Returns
    -------
    subprocess.Popen or None
        The child process; None when there is nothing to compile.
    """
    if _akf_cached():
        return None
    root = str(Path(__file__).resolve().parents[1])  # the child imports the same evsim as this process
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [root, os.environ.get("PYTHONPATH")]))}
    try:
        proc = subprocess.Popen([sys.executable, "-m", "evsim_app.precompile"], env=env, stdin=subprocess.DEVNULL,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    except OSError:
        return None  # the demo then compiles everything itself
    atexit.register(_stop, proc)  # a demo that ends early (error, interrupt) does not leave it running
    return proc


def wait(proc: subprocess.Popen | None, timeout_s: float = 600.0) -> None:
    """Wait for the child (its kernels are then in the cache; if it failed, the caller compiles them itself).

    Parameters
    ----------
    proc : subprocess.Popen or None
        The child (None: nothing to wait for).
    timeout_s : float, optional
        The longest wait (s; default 600), after which the child is stopped.
    """
    if proc is not None:
        try:
            proc.wait(timeout_s)
        except subprocess.TimeoutExpired:
            _stop(proc)


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:  # numba writes cache files by renaming complete ones: stopping it corrupts nothing
        proc.kill()
        proc.wait()


def _akf_cached() -> bool:
    """True when the numba cache has an entry for the current source of akf.kernels.akf_events, or when there is no
    akf to compile."""
    try:
        from akf import kernels
    except ImportError:
        return True
    try:
        return bool(kernels.akf_events._cache._cache_file._load_index())  # numba internals: guess cold if changed
    except Exception:
        return False


def toy_recording(height: int = 16, width: int = 16, n_frames: int = 4, n_events: int = 400,
                  seed: int = 0) -> Recording:
    """A small hybrid recording with the array types of a generated one (events, 8-bit frames, HDR reference,
    threshold maps, window CRF): running the reconstruction on it compiles the kernels a real one uses.

    Parameters
    ----------
    height, width : int, optional
        Sensor size (pixels; default 16 x 16).
    n_frames : int, optional
        Frames (default 4).
    n_events : int, optional
        Events (default 400).
    seed : int, optional
        Seed of the random events (default 0).

    Returns
    -------
    Recording
        The recording.
    """
    import sim
    from generators.formats.recording import Recording

    rng = np.random.default_rng(seed)
    period, exposure = 33_333, 10_000
    t_start = np.arange(n_frames, dtype=np.int64) * period
    ev = sim.empty_events(n_events)
    ev["t"] = np.sort(rng.integers(0, int(t_start[-1]) + exposure, n_events))
    ev["x"] = rng.integers(0, width, n_events)
    ev["y"] = rng.integers(0, height, n_events)
    ev["p"] = rng.choice(np.array([-1, 1], np.int8), n_events)
    reference = rng.uniform(0.1, 2.0, (n_frames, height, width)).astype(np.float32)
    return Recording(
        events=ev, height=height, width=width,
        frames=rng.integers(0, 256, (n_frames, height, width)).astype(np.uint8),
        frame_t_start_us=t_start, frame_t_mid_us=t_start + exposure // 2, frame_t_end_us=t_start + exposure,
        frame_bit_depth=8, reference=reference, reference_t_us=t_start + period // 2,
        crf={"name": "window", "params": {}}, threshold_maps=np.full((2, height, width), 0.2, np.float32),
        metadata={"reference_white_radiance": 1.0, "reference_to_crf_x": 0.5},
    )


class _FlatSource:
    """A RadianceSource of constant radiance (for toy_capture)."""

    def __init__(self, height: int, width: int, duration_us: int):
        self.height, self.width, self.duration_us = height, width, duration_us
        self._image = np.full((height, width), 0.5, np.float32)

    def radiance(self, t_us: int) -> np.ndarray:
        return self._image

    def max_speed_px_per_s(self) -> float:
        return 0.0


def toy_capture(camera_params: CameraParams, crf: CRF, height: int = 16, width: int = 16) -> list:
    """The frames of 0.1 s of a flat scene through the LDR camera (compiles its kernels for camera_params' bit
    depth).

    Parameters
    ----------
    camera_params : CameraParams
        The camera's parameters.
    crf : CRF
        Its response curve.
    height, width : int, optional
        Image size (pixels; default 16 x 16).

    Returns
    -------
    list
        The captured frames (sim.LDRFrame).
    """
    import sim

    return list(sim.LDRCamera(height, width, camera_params, crf, 0).capture(_FlatSource(height, width, 100_000)))


def main() -> int:
    """The demo's kernels, in the order it needs them after the DVS: the camera's, then the reconstruction's.

    Returns
    -------
    int
        The child's exit code (0).
    """
    import crf_models
    from evsim_eval.evaluate import evaluate_recording
    from generators.builtin import ahdr_suite_config

    toy_capture(ahdr_suite_config().camera, crf_models.get("window"))
    evaluate_recording(toy_recording())
    return 0


if __name__ == "__main__":
    sys.exit(main())
