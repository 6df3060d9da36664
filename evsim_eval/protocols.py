"""The evaluation protocols: what every method gets from a recording and what it is scored against
(evsim_eval.scoring.Case),
for the paper's Table 1 (protocol "reference") and supplementary Table 2 (protocol "interleave").

Units. Every method outputs linear intensity in the CRF's scaled-irradiance units "x" of the first input frame's
exposure (x = 1 is the full well; crf.forward(x) is the normalised response; the AKF and the CF output at most
their max_intensity, default 1: what the camera can represent). Scores are computed in those units:
- protocol "reference" (synthetic data with HDR ground truth): the reference radiance is multiplied by
  reference_to_x(rec) (recorded at generation time as metadata["reference_to_crf_x"], else computed from the
  recorded camera configuration), and the scored times are the reference times strictly between the first and the
  last frame's mid-exposure (the filters need a frame on each side).
- protocol "interleave" (real recordings, paper supplementary Table 2): the even frames 0, 2, 4, ... are the input
  (with the full event stream) and every odd frame between two of them is the ground truth at its mid-exposure
  time, as x = CRF^-1(response) * T_0 / T_k. A frame only measures x inside the CRF's range
  [CRF^-1(0), CRF^-1(1)], so reconstructions are clipped to that range (of the held-out frame's exposure) before
  scoring: what the held-out frame would have recorded. Without a recorded CRF (real DAVIS data) the CRF is
  assumed linear (x = response). The held-out frame integrated the scene over its exposure window, so by default
  (exposure_matched) each reconstruction is averaged over that window before the clip (evsim_eval.exposure,
  Case.windows);
  exposure_matched=False scores the reconstruction at mid-exposure (point-in-time).
Metrics are those of evsim_eval.metrics, per frame, averaged over the frames of a sequence (log_rmse: the root of the
mean square, all the frames' pixels pooled); "mean" averages the sequences (log_rmse: root mean square).
The [0, 1] metrics (mse01, ssim01: the paper's protocol, clipped at the white) map to 1 (reference protocol) a white
the methods can reach, min(scene white, the full well) (evsim_eval.scoring.reachable_white; the scene white is the
recorded reference_white_radiance, else the reference's 98th percentile, with a note), or CRF^-1(1) (interleave: a
held-out frame's white). The full-range log_rmse floors both images at 1e-3 of the frames' top, the largest x the
fed frames can record, CRF^-1(1) T_0 / T_k of the shortest exposure (evsim_eval.scoring.frames_range; a note gives
each sequence's range and floor), in both protocols; the range classes set the truth against that range.
Every method gets the recording's nominal contrast thresholds, or, when it carries none (real recordings), those of
a given sensor file (the camera calibrated by `evsim calibrate`), else the thresholds estimated from its events
and the fed frames by calibrate's own model and first stage (evsim_eval.calibrate.estimate_thresholds: the log
offset and the thresholds fitted by simulation; never the held-out frames); the AKF also gets its DVS
leak rate (the recorded configuration's leak_hz, else 0) for its leak-aware event model (see akf.reconstruct),
unless method_options say otherwise, and the frames' read noise for its frame update: a sensor file's
[input] read_noise_dn, else estimated from the fed frames (akf.frame_noise); a note says which.
Gaps: the spans where the recording's events are missing (dropped packets, an export that keeps only the events
inside the exposures; sim.find_gaps with every frame's exposure, the held-out ones too) go to the methods that read
them as unknown change (GAP_METHODS: the AKF, the smoother and the complementary filters; gaps_us, unless
method_options say otherwise), and a note names them.

References (docs/models/references.md): Wang et al. 2021 [Wang2021], the AKF paper's protocol.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

import akf
import crf_models
import sim
from akf.frame_noise import estimate_read_noise, frame_noise_variance
from generators.formats import detect
from generators.formats.recording import Recording, missing_part_error
from sim import EvsimInputError, OptionError

from . import metrics, scoring
from .choices import KALMAN_METHODS, PROTOCOLS
from .scoring import Case

DEFAULT_CONTRAST = 0.2  # log units, when a recording carries no thresholds and estimation fails
GAP_METHODS = ("akf", "aks", "cf", "cf_adaptive")  # the methods that take gaps_us (see the module)
WHITE = {"reference": " (white = min(the recorded reference_white_radiance in x units, the full well): "
                      "see the notes)",
         "interleave": " (white = CRF^-1(1), the held-out frame's white)"}
#: the frames' top that sets log_rmse's floor, as its table block and the JSON's "scoring" entry state it
FRAMES_TOP = " (the frames' top = CRF^-1(1) T_0 / T_k of the shortest fed exposure: see the notes)"
UNITS = {"reference": "x = CRF scaled irradiance of frame 0's exposure (reference radiance * reference_to_crf_x)",
         "interleave": "x = CRF^-1(held-out frame) of frame 0's exposure; reconstructions clipped to the CRF range"}


# ----- what a dataset holds ------------------------------------------------------------------------------------

def dataset_sequences(path: str | Path) -> list[tuple[str, Path]]:
    """(name, file) of every sequence of DATASET: a readable file or IJRR folder (one sequence), a generated dataset
    folder (its index.json), or a folder of native .h5 files."""
    path = Path(path)
    if not path.exists():
        raise EvsimInputError(f"{path}: no such file or directory")
    if path.is_dir() and (path / "index.json").is_file():
        try:
            entries = json.loads((path / "index.json").read_text())["sequences"]
            return [(e["name"], path / e["file"]) for e in entries]
        except (ValueError, KeyError, TypeError) as e:
            raise EvsimInputError(f"{path / 'index.json'}: not a dataset index ({e})") from None
    if path.is_dir() and not (path / "events.txt").is_file():
        files = sorted(path.glob("*.h5"))
        if not files:
            raise EvsimInputError(f"{path}: a folder with neither index.json, .h5 files nor events.txt")
        return [(f.stem, f) for f in files]
    detect(path)  # raises DatasetFormatError (an EvsimInputError) naming the problem
    return [(path.stem if path.is_file() else path.name, path)]


def recording_crf(rec: Recording) -> tuple[crf_models.CRF, str]:
    """(crf object, note): the recorded CRF, or a linear one (note says so) when the layout carries none."""
    if rec.crf:
        try:
            return crf_models.get(rec.crf["name"], **rec.crf.get("params", {})), ""
        except (crf_models.CRFError, KeyError, TypeError) as e:
            raise EvsimInputError(f"cannot rebuild the recorded CRF {rec.crf!r}: {e}") from None
    return crf_models.get("linear"), "no CRF recorded: assumed linear (x = response)"


def _recorded_contrast(rec: Recording):
    """(ON, OFF) from the recorded DVS configuration, else the AKF .mat's ct, else None."""
    dvs = rec.metadata.get("config", {}).get("dvs", {})
    if "pos_threshold" in dvs and "neg_threshold" in dvs:
        return float(dvs["pos_threshold"]), float(dvs["neg_threshold"])
    ct = rec.metadata.get("akf_mat", {}).get("ct")
    if isinstance(ct, (int, float)) and ct > 0:
        return float(ct), float(ct)
    return None


def recording_contrast(rec: Recording) -> tuple[float, float]:
    """Nominal (ON, OFF) contrast thresholds (log units) from the recorded DVS configuration, else the AKF .mat's
    ct, else estimated from the events and all frames (evsim_eval.calibrate.estimate_thresholds), else
    DEFAULT_CONTRAST. The per-pixel threshold maps are ground truth, not used (a real camera does not know them)."""
    if rec.frames is None or rec.frames.shape[0] < 2:
        return _recorded_contrast(rec) or (DEFAULT_CONTRAST, DEFAULT_CONTRAST)
    return recording_contrast_or_estimate(rec, np.arange(rec.frames.shape[0]))[0]


def recording_leak_rate(rec: Recording) -> float:
    """The DVS's mean leak rate (Hz) from the recorded configuration, else 0 (unknown: the AKF then ignores leak)."""
    leak = rec.metadata.get("config", {}).get("dvs", {}).get("leak_hz", 0.0)
    return float(leak) if isinstance(leak, (int, float)) and math.isfinite(leak) and leak > 0 else 0.0


def method_options_for(rec: Recording, method_options: dict[str, dict[str, Any]] | None = None) -> dict:
    """{method: {keyword: value}}: what the recording tells a method beyond the shared inputs (the AKF's
    leak_rate_hz), overridden by method_options."""
    merged = {name: {"leak_rate_hz": recording_leak_rate(rec)} for name in KALMAN_METHODS}
    for name, options in (method_options or {}).items():
        merged[name] = {**merged.get(name, {}), **options}
    return merged


def reference_to_x(rec: Recording) -> float:
    """The factor from reference radiance to the CRF's x units of frame 0's exposure: metadata
    "reference_to_crf_x" (written by generators.ahdr), else electrons_per_radiance_us * exposure_0 / full_well_e
    of the recorded camera configuration (older files)."""
    factor = rec.metadata.get("reference_to_crf_x")
    if factor is not None:
        return float(factor)
    cam = rec.metadata.get("config", {}).get("camera")
    if cam is None or rec.frames is None:
        raise OptionError("the recording has no reference_to_crf_x nor camera configuration: the reference radiance "
                          "cannot be put in the CRF's units (use protocol='interleave')",
                          "the recording has no reference_to_crf_x nor camera configuration: the reference radiance "
                          "cannot be put in the CRF's units (use --protocol interleave)")
    params = sim.CameraParams(**{k: tuple(v) if isinstance(v, list) else v for k, v in cam.items()})
    exposure = int(rec.frame_t_end_us[0] - rec.frame_t_start_us[0])
    return params.electrons_per_radiance_us * exposure / params.full_well_e


def check_frames(rec: Recording, need: int, what: str) -> None:
    n = 0 if rec.frames is None else rec.frames.shape[0]
    if n < need:
        message = f"{what} needs at least {need} LDR frame{'s' * (need != 1)}, the recording has {n}"
        raise missing_part_error(message, rec, "frames") if n == 0 else EvsimInputError(message)


# ----- the two protocols -----------------------------------------------------------------------------------------

def recording_case(rec: Recording, protocol: str = "reference",
                   method_options: dict[str, dict[str, Any]] | None = None,
                   exposure_matched: bool = True, sensor: str | None = None) -> tuple[Case, list[str]]:
    """The evsim_eval.scoring.Case of a protocol on a recording, and notes on the assumptions it made.

    Parameters
    ----------
    rec : Recording
        The recording.
    protocol : {"reference", "interleave"}, optional
        Score against the HDR reference frames, or feed every second frame and score on the others (default
        "reference").
    method_options : dict, optional
        {method: {keyword: value}} passed to that method.
    exposure_matched : bool, optional
        (interleave) Reconstructions averaged over each held-out frame's exposure window (default True), else taken
        at its mid-exposure time.
    sensor : str, optional
        See recording_contrast_or_estimate.

    Returns
    -------
    case : Case
        The case.
    notes : list of str
        The assumptions made.
    """
    crf, note = recording_crf(rec)
    notes = [note] if note else []
    options = method_options_for(rec, method_options)
    if protocol == "reference":
        check_frames(rec, 2, "protocol 'reference'")
        if rec.reference is None:
            raise missing_part_error("the recording has no HDR reference frames", rec, "reference",
                                     ("use protocol='interleave'", "use --protocol interleave"))
        inside = (rec.reference_t_us > rec.frame_t_mid_us[0]) & (rec.reference_t_us < rec.frame_t_mid_us[-1])
        if not inside.any():
            raise EvsimInputError("no reference frame lies between the first and the last frame")
        to_x = reference_to_x(rec)
        truth = rec.reference[inside] * to_x
        white_radiance = rec.metadata.get("reference_white_radiance")
        if isinstance(white_radiance, (int, float)) and white_radiance > 0:
            scene_white = float(white_radiance) * to_x
        else:
            scene_white = float(np.percentile(truth, 98))
            notes.append("no reference_white_radiance recorded: the scene white is the reference's 98th percentile")
        white, white_note = scoring.reachable_white(scene_white, crf, rec.frame_t_start_us, rec.frame_t_end_us)
        notes.append(white_note)
        fed = np.arange(rec.frames.shape[0])
        times, clip, windows = rec.reference_t_us[inside], None, None
    elif protocol == "interleave":
        check_frames(rec, 3, "protocol 'interleave'")
        nf = rec.frames.shape[0]
        fed = np.arange(0, nf, 2)
        held = np.arange(1, fed[-1], 2)
        gains = scoring.exposure_gains(rec.frame_t_start_us, rec.frame_t_end_us)[held]
        full = float((1 << rec.frame_bit_depth) - 1)
        truth = np.stack([g * np.asarray(crf.inverse(rec.frames[k] / full), np.float64)
                          for g, k in zip(gains, held)])
        x_lo, x_hi = float(crf.inverse(0.0)), float(crf.inverse(1.0))
        white, times, clip = x_hi, rec.frame_t_mid_us[held], np.stack([gains * x_lo, gains * x_hi], axis=1)
        windows = np.stack([rec.frame_t_start_us[held], rec.frame_t_end_us[held]], axis=1).astype(np.int64)
    else:
        raise EvsimInputError(f"unknown protocol {protocol!r}; one of {', '.join(PROTOCOLS)}")
    contrast, c_note = recording_contrast_or_estimate(rec, fed, sensor)
    if c_note:
        notes.append(c_note)
    gaps, g_note = recording_gaps(rec)
    notes += [g_note] if g_note else []
    for name in GAP_METHODS:
        options[name] = {"gaps_us": gaps, **options.get(name, {})}
    for name in KALMAN_METHODS:
        if name in options:
            options[name], n_note = with_read_noise(options[name], rec, crf, fed, sensor)
            if n_note not in notes:
                notes.append(n_note)
    case = Case(rec.events, rec.frames[fed], rec.frame_t_start_us[fed], rec.frame_t_end_us[fed],
                rec.frame_bit_depth, crf, contrast, np.asarray(times, np.int64), truth, white, clip, options,
                windows=windows, exposure_matched=exposure_matched)
    lo, top = case.frames_range
    notes.append(f"frames' range {lo:.4g}..{top:.4g} x (CRF^-1(0), CRF^-1(1) over the fed exposures), log_rmse "
                 f"floor {metrics.LOG_FLOOR_FRACTION * top:.3g} x")
    return case, notes


def recording_gaps(rec: Recording) -> tuple[np.ndarray, str]:
    """(gaps, note): the spans where the recording's events are missing (sim.find_gaps over the events and every
    frame's exposure), and a note naming them ("" when there are none).

    Parameters
    ----------
    rec : Recording
        The recording.

    Returns
    -------
    gaps : numpy.ndarray
        (G, 2) int64 us [start, end) gaps.
    note : str
        Their count, total duration and the first few, or "".
    """
    gaps = sim.find_gaps(rec.events, rec.frame_t_start_us, rec.frame_t_end_us)
    if rec.events.size == 0:
        return gaps, ""
    return gaps, sim.describe_gaps(gaps, (int(rec.events["t"][0]), int(rec.events["t"][-1])))


def with_read_noise(akf_options: dict[str, Any], rec: Recording, crf: crf_models.CRF, fed: np.ndarray,
                    sensor: str | None = None) -> tuple[dict[str, Any], str]:
    """(AKF options, note): the options with params.read_noise_dn, the frames' read noise that sets the AKF's
    frame update variance, and a note saying which and where it comes from: the options' own when set, else the
    [input] read_noise_dn of `sensor` (a sensor file from `evsim calibrate` on this camera) when it has one, else
    estimated from the fed frames (akf.frame_noise.estimate_read_noise; held-out frames are never used)."""
    params = akf_options.get("params", akf.AKFParams())
    if params.read_noise_dn is not None:
        noise, where = params.read_noise_dn, "as given"
    else:
        s = sim.load_sensor(sensor) if sensor is not None else None
        noise = s.tables.get("input", {}).get("read_noise_dn") if s is not None else None
        if noise is not None:
            where = f"from sensor file {Path(s.path).name}" if s.path else f"from preset {s.name}"
        else:
            est = estimate_read_noise(rec.frames[fed], rec.frame_bit_depth)
            noise, where = est.read_noise_dn, f"{est.source} of the fed frames (akf.frame_noise)"
        params = dataclasses.replace(params, read_noise_dn=float(noise))
    sigma2 = frame_noise_variance(float(noise), crf, rec.frame_bit_depth)
    return ({**akf_options, "params": params},
            f"AKF frame update noise: read noise {noise:.3g} DN {where}, frame variance {sigma2:.3g} x^2 "
            f"({sigma2 / params.sigma_im2:.3g} sigma_im2)")


def recording_contrast_or_estimate(rec: Recording, fed: np.ndarray,
                                   sensor: str | None = None) -> tuple[tuple, str]:
    """(ON, OFF) contrast and a note saying where it comes from ("" when recorded): the recorded one (see
    recording_contrast); else the thresholds of `sensor` (a sensor file fitted to this camera by `evsim calibrate`,
    or a preset); else estimated from the events and the fed frames (held-out frames are never used) by the model
    and search of evsim calibrate's first stage (evsim_eval.calibrate.estimate_thresholds: the fed frames simulated,
    the log offset and the thresholds fitted to the event counts); else DEFAULT_CONTRAST."""
    recorded = _recorded_contrast(rec)
    if recorded is not None:
        return recorded, ""
    if sensor is not None:
        s = sim.load_sensor(sensor)
        where = f"sensor file {Path(s.path).name}" if s.path else f"preset {s.name}"
        fitted = s.provenance.get("recording")
        return ((s.dvs.pos_threshold, s.dvs.neg_threshold),
                f"no contrast recorded: the thresholds of {where}" + (f" (fitted to {fitted})" if fitted else "")
                + f", ON {s.dvs.pos_threshold:.3f}, OFF {s.dvs.neg_threshold:.3f}")
    from .calibrate import estimate_thresholds

    try:
        est = estimate_thresholds(rec, fed)
    except EvsimInputError as e:
        return (DEFAULT_CONTRAST, DEFAULT_CONTRAST), f"no contrast recorded, estimation failed ({e}): assumed " \
                                                     f"{DEFAULT_CONTRAST}"
    return est.pair, (f"no contrast recorded: estimated as evsim calibrate's first stage does, ON "
                      f"{est.pos_threshold:.3f}, OFF {est.neg_threshold:.3f} with log offset b = {est.offset_dn:.3g} "
                      f"DN (the fed frames simulated, thresholds matched to the events of {est.window_s[0]:.3g}-"
                      f"{est.window_s[1]:.3g} s; {est.evaluations} simulations, {est.cpu_s:.0f} s CPU; --sensor FILE "
                      "gives a calibrated camera's thresholds)")
