"""Dataset-level evaluation of HDR reconstructions (the paper's Table 1 and supplementary Table 2).

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
  assumed linear (x = response).
Metrics are those of akf.metrics, per frame, averaged over the frames of a sequence; "mean" averages the sequences.
The [0, 1] metrics (mse01, ssim01: the paper's protocol) map to 1 the recorded reference_white_radiance (reference
protocol; else the reference's 98th percentile, with a note) or CRF^-1(1) (interleave: a held-out frame's white).
Every method gets the recording's nominal contrast thresholds, or, when it carries none (real recordings), the
thresholds estimated from its events and the fed frames (akf.estimate_contrast; never the held-out frames); the
AKF also gets its DVS leak rate (the recorded configuration's leak_hz, else 0) for its leak-aware event model (see
akf.reconstruct), unless method_options say otherwise.
Tuning (evaluate_dataset(tune=True), `evsim evaluate --tune`): see akf.tuning for the search; the tuning split is
the first TUNE_FRACTION of every sequence's scored times, and all methods are scored on the rest.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import akf
import crf_models
import sim
from sim import EvsimInputError

from generators.formats import detect, load
from generators.formats.exr import write_exr_sequence
from generators.formats.atomic import write_text_atomic
from generators.formats.recording import Recording

PROTOCOLS = ("reference", "interleave")
DEFAULT_METHODS = ("akf", "cf", "frames")
DEFAULT_METRICS = ("mse", "mse01", "ssim01", "log_mse", "pu21_ssim")
DEFAULT_CONTRAST = 0.2  # log units, when a recording carries no thresholds and estimation fails
TUNE_FRACTION = 1 / 3  # the tuning split: the first third of every sequence's scored frames
TUNE_METRIC = "mse01"
WHITE = {"reference": " (white = the recorded reference_white_radiance in x units)",
         "interleave": " (white = CRF^-1(1))"}
UNITS = {"reference": "x = CRF scaled irradiance of frame 0's exposure (reference radiance * reference_to_crf_x)",
         "interleave": "x = CRF^-1(held-out frame) of frame 0's exposure; reconstructions clipped to the CRF range"}


# ----- what a dataset holds ------------------------------------------------------------------------------------

def dataset_sequences(path) -> list[tuple[str, Path]]:
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


def recording_crf(rec: Recording):
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


def recording_contrast(rec: Recording):
    """Nominal (ON, OFF) contrast thresholds (log units) from the recorded DVS configuration, else the AKF .mat's
    ct, else estimated from the events and all frames (akf.estimate_contrast), else DEFAULT_CONTRAST. The per-pixel
    threshold maps are ground truth, not used (a real camera does not know them)."""
    if rec.frames is None or rec.frames.shape[0] < 2:
        return _recorded_contrast(rec) or (DEFAULT_CONTRAST, DEFAULT_CONTRAST)
    return recording_contrast_or_estimate(rec, recording_crf(rec)[0], np.arange(rec.frames.shape[0]))[0]


def recording_leak_rate(rec: Recording) -> float:
    """The DVS's mean leak rate (Hz) from the recorded configuration, else 0 (unknown: the AKF then ignores leak)."""
    leak = rec.metadata.get("config", {}).get("dvs", {}).get("leak_hz", 0.0)
    return float(leak) if isinstance(leak, (int, float)) and math.isfinite(leak) and leak > 0 else 0.0


def method_options_for(rec: Recording, method_options=None) -> dict:
    """{method: {keyword: value}}: what the recording tells a method beyond the shared inputs (the AKF's
    leak_rate_hz), overridden by method_options."""
    merged = {"akf": {"leak_rate_hz": recording_leak_rate(rec)}}
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
        raise EvsimInputError("the recording has no reference_to_crf_x nor camera configuration: the reference "
                              "radiance cannot be put in the CRF's units (use --protocol interleave)")
    params = sim.CameraParams(**{k: tuple(v) if isinstance(v, list) else v for k, v in cam.items()})
    exposure = int(rec.frame_t_end_us[0] - rec.frame_t_start_us[0])
    return params.electrons_per_radiance_us * exposure / params.full_well_e


def _check_frames(rec: Recording, need: int, what: str) -> None:
    n = 0 if rec.frames is None else rec.frames.shape[0]
    if n < need:
        raise EvsimInputError(f"{what} needs at least {need} frame{'s' * (need != 1)}, the recording has {n}")


# ----- the two protocols -----------------------------------------------------------------------------------------

@dataclass
class Task:
    """What a protocol asks of every method on one recording: the inputs (frames fed, with their exposure times),
    the scored times, the truth there (x units), the white level of the [0, 1] metrics and, for held-out frames,
    the per-frame range [lo, hi] a frame can measure (reconstructions are clipped to it before scoring)."""

    events: np.ndarray
    frames: np.ndarray
    t_start: np.ndarray
    t_end: np.ndarray
    bit_depth: int
    crf: object
    contrast: tuple
    times: np.ndarray
    truth: np.ndarray
    white: float
    clip: np.ndarray | None  # (T, 2) or None
    options: dict  # {method: {keyword: value}} from the recording (the AKF's leak rate), overridable

    def run(self, method: str, sel, contrast=None, options=None) -> np.ndarray:
        """The method's reconstructions at times[sel] (clipped to the measurable range when the task has one)."""
        opts = self.options.get(method, {}) if options is None else options
        images = akf.METHODS[method](self.events, self.frames, self.t_start, self.t_end, self.crf, self.times[sel],
                                     contrast=self.contrast if contrast is None else contrast,
                                     bit_depth=self.bit_depth, **opts)
        if self.clip is not None:
            images = np.stack([np.clip(img, lo, hi) for img, (lo, hi) in zip(images, self.clip[sel])])
        return images

    def scores(self, images, sel, metrics) -> dict:
        """{metric: mean over the frames} of images (at times[sel]) against the truth."""
        truth = self.truth[sel]
        return {m: float(np.mean([akf.score(m, r, t, self.white) for r, t in zip(images, truth)])) for m in metrics}


def recording_task(rec: Recording, protocol: str = "reference", method_options=None) -> tuple[Task, list[str]]:
    """The Task of a protocol on a recording, and notes on the assumptions it made."""
    crf, note = recording_crf(rec)
    notes = [note] if note else []
    options = method_options_for(rec, method_options)
    if protocol == "reference":
        _check_frames(rec, 2, "protocol 'reference'")
        if rec.reference is None:
            raise EvsimInputError("the recording has no HDR reference frames (use --protocol interleave)")
        inside = (rec.reference_t_us > rec.frame_t_mid_us[0]) & (rec.reference_t_us < rec.frame_t_mid_us[-1])
        if not inside.any():
            raise EvsimInputError("no reference frame lies between the first and the last frame")
        to_x = reference_to_x(rec)
        truth = rec.reference[inside] * to_x
        white_radiance = rec.metadata.get("reference_white_radiance")
        if isinstance(white_radiance, (int, float)) and white_radiance > 0:
            white = float(white_radiance) * to_x
        else:
            white = float(np.percentile(truth, 98))
            notes.append("no reference_white_radiance recorded: [0, 1] metrics map the reference's 98th "
                         "percentile to 1")
        fed = np.arange(rec.frames.shape[0])
        times, clip = rec.reference_t_us[inside], None
    elif protocol == "interleave":
        _check_frames(rec, 3, "protocol 'interleave'")
        nf = rec.frames.shape[0]
        fed = np.arange(0, nf, 2)
        held = np.arange(1, fed[-1], 2)
        t0 = float(rec.frame_t_end_us[0] - rec.frame_t_start_us[0])
        gains = np.ones(held.size)
        for i, k in enumerate(held):
            tk = float(rec.frame_t_end_us[k] - rec.frame_t_start_us[k])
            gains[i] = t0 / tk if t0 > 0 and tk > 0 else 1.0
        full = float((1 << rec.frame_bit_depth) - 1)
        truth = np.stack([g * np.asarray(crf.inverse(rec.frames[k] / full), np.float64)
                          for g, k in zip(gains, held)])
        x_lo, x_hi = float(crf.inverse(0.0)), float(crf.inverse(1.0))
        white, times, clip = x_hi, rec.frame_t_mid_us[held], np.stack([gains * x_lo, gains * x_hi], axis=1)
    else:
        raise EvsimInputError(f"unknown protocol {protocol!r}; one of {', '.join(PROTOCOLS)}")
    contrast, c_note = recording_contrast_or_estimate(rec, crf, fed)
    if c_note:
        notes.append(c_note)
    task = Task(rec.events, rec.frames[fed], rec.frame_t_start_us[fed], rec.frame_t_end_us[fed],
                rec.frame_bit_depth, crf, contrast, np.asarray(times, np.int64), truth, white, clip, options)
    return task, notes


def recording_contrast_or_estimate(rec: Recording, crf, fed) -> tuple[tuple, str]:
    """(ON, OFF) contrast: the recorded one (see recording_contrast), else estimated from the events and the fed
    frames (akf.estimate_contrast; held-out frames are never used), else DEFAULT_CONTRAST; and a note saying
    which ("" when recorded)."""
    recorded = _recorded_contrast(rec)
    if recorded is not None:
        return recorded, ""
    try:
        est = akf.estimate_contrast(rec.events, rec.frames[fed], rec.frame_t_start_us[fed], rec.frame_t_end_us[fed],
                                    crf, bit_depth=rec.frame_bit_depth)
    except EvsimInputError as e:
        return (DEFAULT_CONTRAST, DEFAULT_CONTRAST), f"no contrast recorded, estimation failed ({e}): assumed " \
                                                     f"{DEFAULT_CONTRAST}"
    return est.pair, (f"no contrast recorded: estimated from the data, ON {est.c_on:.3f}, OFF {est.c_off:.3f} "
                      f"({est.n_on} + {est.n_off} unclipped pixel intervals)")


def evaluate_recording(rec: Recording, *, protocol: str = "reference", methods=DEFAULT_METHODS,
                       metrics=DEFAULT_METRICS, method_options=None) -> tuple[dict, str]:
    """Score methods on one recording, every scored time: ({method: {metric: value}}, notes joined by "; ")."""
    check_request(protocol, methods, metrics)
    task, notes = recording_task(rec, protocol, method_options)
    every = np.arange(task.times.size)
    return {name: task.scores(task.run(name, every), every, metrics) for name in methods}, "; ".join(notes)


def check_request(protocol: str, methods, metrics) -> None:
    """EvsimInputError naming an unknown protocol, or the methods or metrics that akf does not have."""
    if protocol not in PROTOCOLS:
        raise EvsimInputError(f"unknown protocol {protocol!r}; one of {', '.join(PROTOCOLS)}")
    unknown = [m for m in methods if m not in akf.METHODS] + [m for m in metrics if m not in akf.METRICS]
    if unknown:
        raise EvsimInputError(f"unknown methods/metrics {unknown}; methods: {sorted(akf.METHODS)}, "
                              f"metrics: {sorted(akf.METRICS)}")


def add_means(result: dict, metrics) -> dict:
    """Add {"mean": {metric: mean over the sequences}} to every method of {method: {sequence: {metric: value}}}
    that scored any sequence; returns result."""
    for rows in result.values():
        if rows:
            rows["mean"] = {k: float(np.mean([r[k] for r in rows.values()])) for k in metrics}
    return result


def split_times(n: int, tune_fraction: float) -> tuple[np.ndarray, np.ndarray]:
    """The declared tuning split of n scored times: the first ceil(tune_fraction * n) (at least 1) tune, the rest
    are scored (at least 1)."""
    if n < 2:
        raise EvsimInputError(f"--tune needs at least 2 scored frames per sequence, one has {n}")
    k = min(max(int(math.ceil(tune_fraction * n)), 1), n - 1)
    return np.arange(k), np.arange(k, n)


def evaluate_dataset(path, *, protocol: str = "reference", methods=DEFAULT_METHODS, metrics=DEFAULT_METRICS,
                     method_options=None, tune: bool = False, tune_fraction: float = TUNE_FRACTION,
                     tune_metric: str = TUNE_METRIC, tuning_out: dict | None = None,
                     progress=None) -> tuple[dict, list[str]]:
    """Score every sequence of a dataset: ({method: {sequence: {metric: value}, "mean": {metric: value}}}, notes).

    tune: the tuning protocol (akf.tuning): each method's parameters are searched once for the whole dataset,
    minimising the mean of tune_metric over the tuning split (the first tune_fraction of every sequence's scored
    times), and every method (tuned or without parameters) is then scored on the rest only. The chosen settings
    are in the notes ("tuned ...") and, when tuning_out is a dict, stored in it as {method: setting}.
    progress(text): optional callback with the progress of the tuning.
    """
    check_request(protocol, methods, metrics)
    if tune and tune_metric not in akf.METRICS:
        raise EvsimInputError(f"unknown tuning metric {tune_metric!r}; one of {', '.join(akf.METRICS)}")
    if not 0 < tune_fraction < 1:
        raise EvsimInputError(f"the tuning fraction must lie in (0, 1), got {tune_fraction}")
    result = {m: {} for m in methods}
    notes = []
    tasks = []
    for name, file in dataset_sequences(path):
        task, task_notes = recording_task(load(file), protocol, method_options)
        notes += [f"{name}: {n}" for n in task_notes]
        tasks.append((name, task))
    settings = {}
    if tune:
        splits = [split_times(task.times.size, tune_fraction) for _, task in tasks]
        sign = -1.0 if tune_metric in akf.metrics.HIGHER_IS_BETTER else 1.0
        for m in methods:
            def objective(setting, m=m):
                values = []
                for (_, task), (tune_sel, _) in zip(tasks, splits):
                    contrast, opts = akf.tuning.setting_options(m, setting, task.contrast, task.options.get(m))
                    images = task.run(m, tune_sel, contrast, opts)
                    values.append(task.scores(images, tune_sel, (tune_metric,))[tune_metric])
                return sign * float(np.mean(values))

            tuned = akf.tune(m, objective)
            settings[m] = tuned.setting
            if progress:
                progress(f"tuned {m}: {akf.tuning.describe_setting(tuned.setting)} ({len(tuned.trials)} trials)")
        notes.append(f"tuning: parameters searched per method on the first {tune_fraction:.0%} of every "
                     f"sequence's scored frames (mean {tune_metric}), scores on the rest")
        notes += [f"tuned {m}: {akf.tuning.describe_setting(s)}" for m, s in settings.items()]
    for name, task in tasks:
        sel = split_times(task.times.size, tune_fraction)[1] if tune else np.arange(task.times.size)
        for m in methods:
            if tune:
                contrast, opts = akf.tuning.setting_options(m, settings[m], task.contrast, task.options.get(m))
            else:
                contrast, opts = None, None
            result[m][name] = task.scores(task.run(m, sel, contrast, opts), sel, metrics)
    add_means(result, metrics)
    if tuning_out is not None:
        tuning_out.update(settings)
    return result, notes


# ----- reconstruction to files ----------------------------------------------------------------------------------

def output_times(rec: Recording, times: str) -> np.ndarray:
    """int64 us output times for --times: "reference" (the reference times from the first exposure start on),
    "frames" (every frame's mid-exposure) or "fps:N" (N per second from the first exposure start to the last
    frame's exposure end)."""
    _check_frames(rec, 1, "reconstruction")
    start, end = int(rec.frame_t_start_us[0]), int(rec.frame_t_end_us[-1])
    if times == "reference":
        if rec.reference_t_us is None:
            raise EvsimInputError("--times reference: the recording has no reference frames (use frames or fps:N)")
        return rec.reference_t_us[rec.reference_t_us >= start].astype(np.int64)
    if times == "frames":
        return rec.frame_t_mid_us.astype(np.int64)
    if times.startswith("fps:"):
        try:
            fps = float(times[4:])
        except ValueError:
            fps = math.nan
        if not (math.isfinite(fps) and fps > 0):
            raise EvsimInputError(f"--times {times!r}: fps:N needs a positive rate in Hz")
        return np.arange(start, end + 1, 1e6 / fps).round().astype(np.int64)
    raise EvsimInputError(f"--times {times!r}: one of reference, frames, fps:N")


def reconstruct_dataset(path, out_dir, *, method: str = "akf", times: str = "reference",
                        method_options=None) -> list[tuple[str, Path, int]]:
    """Reconstruct every sequence of a dataset with `method` and write float32 EXR folders (frame_NNNNNN.exr and
    timestamps.txt, see generators.formats.exr; values in x units as the module docstring says), atomically.
    One sequence: out_dir is its folder; several: out_dir/<name>/. Returns (name, folder, number of frames)."""
    if method not in akf.METHODS:
        raise EvsimInputError(f"unknown method {method!r}; one of {', '.join(sorted(akf.METHODS))}")
    sequences = dataset_sequences(path)
    written = []
    for name, file in sequences:
        rec = load(file)
        t = output_times(rec, times)
        if t.size == 0:
            raise EvsimInputError(f"{name}: no output time at or after the first exposure start")
        crf, _ = recording_crf(rec)
        images = akf.METHODS[method](rec.events, rec.frames, rec.frame_t_start_us, rec.frame_t_end_us, crf, t,
                                     contrast=recording_contrast(rec), bit_depth=rec.frame_bit_depth,
                                     **method_options_for(rec, {method: method_options or {}}).get(method, {}))
        folder = Path(out_dir) if len(sequences) == 1 else Path(out_dir) / name
        write_exr_sequence(folder, images, t)
        written.append((name, folder, int(t.size)))
    return written


# ----- output ------------------------------------------------------------------------------------------------

def format_table(result: dict, protocol: str = "reference", notes=()) -> str:
    """The paper's Table 1 layout: one block per metric, a row per sequence and the mean, a column per method."""
    methods = list(result)
    sequences = list(result[methods[0]])
    metrics = list(result[methods[0]][sequences[0]])
    width = max(12, *(len(s) + 2 for s in sequences))
    lines = [f"units: {UNITS[protocol]}", *(f"note: {n}" for n in notes)]
    for metric in metrics:
        lines += ["", f"{metric}: {akf.NORMALISATION[metric]}{WHITE[protocol] if metric in akf.metrics.NEEDS_WHITE else ''}",
                  f"{metric:<{width}}" + "".join(f"{m:>14}" for m in methods)]
        for seq in sequences:
            lines.append(f"{seq:<{width}}" + "".join(f"{_fmt(result[m][seq][metric]):>14}" for m in methods))
    return "\n".join(lines)


def format_scores(table: dict) -> str:
    """One sequence's {method: {metric: value}} as a method-by-metric table (evsim demo's metrics.txt)."""
    metrics = list(next(iter(table.values())))
    lines = ["method    " + "".join(f"{m:>12}" for m in metrics)]
    for method, row in table.items():
        lines.append(f"{method:<10}" + "".join(f"{_fmt(row[m]):>12}" for m in metrics))
    return "\n".join(lines)


def _fmt(v: float) -> str:
    return "inf" if math.isinf(v) else f"{v:.4g}"


def write_json(result: dict, path, tuning: dict | None = None) -> None:
    """{method: {sequence: {metric: value}, "mean": {...}}} as JSON, atomically (inf as the string "inf"); with
    tuning ({method: setting}, from evaluate_dataset's tuning_out) also a top-level "tuning" entry."""
    clean = {m: {s: {k: (str(v) if math.isinf(v) else v) for k, v in row.items()} for s, row in seqs.items()}
             for m, seqs in result.items()}
    if tuning:
        clean["tuning"] = tuning
    write_text_atomic(path, json.dumps(clean, indent=2) + "\n")
