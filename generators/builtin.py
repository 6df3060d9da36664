"""The built-in default dataset: needs no files (procedural scenes and a photo that ships with scikit-image).

BUILTIN_SEQUENCES is the default dataset in the configuration-file schema; its photo scenes are
generators.scenes.builtin_images (a scikit-image photo made HDR).

ahdr_suite() is the benchmark of the AKF paper's AHDR construction (section 4.2): the HDR reference is what a
well-exposed linear camera sees (ahdr_reference_image: white at the 98th percentile of the radiance, black at 1/255
of white, as the paper's original 8-bit frames), and the LDR camera sees it through the 100..160 window CRF
(x = reference radiance; the window keeps x in about [0.13, 0.36]), with the davis346 DVS.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import sim
from sim import InvalidParameterError
from sim.seeding import seed_record

from .ahdr import AHDRConfig
from .builtin_sequences import BUILTIN_SEQUENCES
from .config import DEFAULTS, DatasetConfig, parse_config, to_ahdr_config
from .dataset import SequenceTask, run_sequences
from .scenes import ImageMotionScene, Trajectory, linearise_ldr, load_image, to_luminance


def builtin_dataset(*, duration_s: float = 1.0, height: int = 180, width: int = 240, seed: int = 0,
                    names: list[str] | None = None) -> DatasetConfig:
    """The default dataset (all BUILTIN_SEQUENCES, or those named) as a validated DatasetConfig."""
    seqs = BUILTIN_SEQUENCES
    if names is not None:
        known = {s["name"] for s in seqs}
        bad = [n for n in names if n not in known]
        if bad:
            raise InvalidParameterError(f"unknown built-in sequence {bad[0]!r}; one of {', '.join(sorted(known))}")
        seqs = [s for s in seqs if s["name"] in names]
    data = {"seed": seed, "defaults": {"duration_s": duration_s, "height": height, "width": width},
            "sequence": [dict(s) for s in seqs]}
    return parse_config(data, source="<built-in dataset>")


# ----- the AHDR benchmark suite ------------------------------------------------------------------------------

AHDR_WHITE_PERCENTILE, AHDR_BLACK = 98.0, 1.0 / 255.0
#: (sequence name, skimage.data image or file name in the HDR data folder, trajectory)
AHDR_SUITE_PHOTOS = (
    ("astronaut_pan", "astronaut", {"pan_px_per_s": [30.0, 8.0], "shake_px": 1.0, "shake_hz": 2.0}),
    ("camera_zoom_rotate", "camera", {"zoom_per_s": 0.2, "rotation_deg_per_s": 8.0}),
    ("coffee_pan", "coffee", {"pan_px_per_s": [-25.0, 10.0]}),
    ("chelsea_pan", "chelsea", {"pan_px_per_s": [20.0, -15.0], "shake_px": 1.0, "shake_hz": 3.0}),
)
AHDR_SUITE_HDR = (
    ("desk_pan", "Desk.exr", {"pan_px_per_s": [30.0, 8.0]}),
    ("mttamwest_pan", "MtTamWest.exr", {"pan_px_per_s": [-30.0, 5.0], "zoom_per_s": 0.1}),
)


def hdr_data_dir() -> Path:
    """The shared real-data folder of HDR photos (../shared/data/hdr next to the project; may be absent)."""
    return Path(__file__).resolve().parents[2] / "shared" / "data" / "hdr"


def ahdr_reference_image(radiance: np.ndarray) -> np.ndarray:
    """float32 (H, W) AHDR reference: radiance / its 98th percentile, clipped to [1/255, 1] (a well-exposed linear
    8-bit-range view of the scene, as the paper's original frames; x = this value with ahdr_suite_config)."""
    y = np.asarray(radiance, np.float32)
    white = float(np.percentile(y, AHDR_WHITE_PERCENTILE))
    if not white > 0:
        raise InvalidParameterError("ahdr_reference_image: the image is black")
    return np.clip(y / white, AHDR_BLACK, 1.0)


def ahdr_suite(height: int = 180, width: int = 240, duration_s: float = 1.0, *, hdr_dir: str | Path | None = None,
               include_hdr: bool = True) -> list[tuple[str, ImageMotionScene]]:
    """The AHDR benchmark scenes as (name, scene): four scikit-image photos, plus the real HDR photos Desk.exr
    and MtTamWest.exr from hdr_dir (default hdr_data_dir()) when they are there and include_hdr."""
    duration_us = int(round(duration_s * 1e6))
    hdr_dir = hdr_data_dir() if hdr_dir is None else Path(hdr_dir)
    import skimage.data

    out = []
    for name, image, traj in AHDR_SUITE_PHOTOS:
        radiance = to_luminance(linearise_ldr(getattr(skimage.data, image)(), "srgb"))
        out.append((name, ImageMotionScene(ahdr_reference_image(radiance), duration_us, Trajectory(**traj),
                                           height=height, width=width, name=f"skimage.data.{image} (AHDR)")))
    for name, file, traj in AHDR_SUITE_HDR if include_hdr else ():
        if (hdr_dir / file).is_file():
            radiance = to_luminance(load_image(hdr_dir / file))
            out.append((name, ImageMotionScene(ahdr_reference_image(radiance), duration_us, Trajectory(**traj),
                                               height=height, width=width, name=f"{file} (AHDR)")))
    return out


def ahdr_suite_config(sensor: str | Path | sim.Sensor = "davis346", *, dvs: dict | None = None,
                      camera: dict | None = None) -> AHDRConfig:
    """The configuration of the suite: the sensor with the overrides over it, the window CRF, x = reference
    radiance (reference_fill = reference_radiance = 1, no auto exposure, unless camera sets them), one reference
    per frame.

    Parameters
    ----------
    sensor : str, Path or sim.Sensor, optional
        A preset name or a sensor file, see sim.load_sensor (default "davis346").
    dvs, camera : dict, optional
        sim.DVSParams / sim.CameraParams field overrides (the fields' units).

    Returns
    -------
    AHDRConfig
        The configuration.
    """
    sensor = sim.load_sensor(sensor)
    settings = {**DEFAULTS, "sensor": sensor, "dvs": dict(dvs or {}),
                "camera": {"reference_radiance": 1.0, "reference_fill": 1.0, **(camera or {})}}
    return to_ahdr_config(settings, where="ahdr suite")


def generate_ahdr_suite(out_dir: str | Path, *, height: int = 180, width: int = 240, duration_s: float = 1.0,
                        seed: int = 0, sensor: str | Path | sim.Sensor = "davis346", overwrite: bool = False,
                        progress: bool = False, include_hdr: bool = True, workers: int | None = None,
                        scheduler: str | None = None, resume: bool = False) -> Path:
    """Generate ahdr_suite() into a dataset folder (native files and index.json, as generate_dataset). Sequence i
    is seeded with child i of SeedSequence(seed).

    Parameters
    ----------
    out_dir : str or Path
        The dataset folder.
    height, width : int, optional
        Sensor size (pixels; default 180 x 240).
    duration_s : float, optional
        Duration of each sequence (s; default 1).
    seed : int, optional
        The root seed (default 0).
    sensor : str, Path or sim.Sensor, optional
        As ahdr_suite_config's.
    overwrite, progress, workers, scheduler, resume
        As generate_dataset's.
    include_hdr : bool, optional
        As ahdr_suite's (default True).

    Returns
    -------
    Path
        The index.json written.
    """
    scenes = ahdr_suite(height, width, duration_s, include_hdr=include_hdr)
    root = np.random.SeedSequence(seed)
    config = ahdr_suite_config(sensor)
    jobs = [(SequenceTask(name, config, child), scene) for (name, scene), child in zip(scenes, root.spawn(len(scenes)))]
    header = {"generator": "ahdr", "seed": seed_record(root), "format": "native",
              "config_source": "generators.builtin.ahdr_suite"}
    return run_sequences(out_dir, jobs, header, overwrite=overwrite, resume=resume, workers=workers,
                         scheduler=scheduler, progress=progress)
