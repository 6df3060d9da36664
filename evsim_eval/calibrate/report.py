"""What a calibration tells its user: the fit table (real, preset, fitted) and the sensor file it writes."""

from __future__ import annotations

import datetime
import math
from pathlib import Path

import sim

from .fit import Calibration
from .sensor import calibrated_sensor

# DVS fields of the table: (field, label, format)
PARAM_ROWS = (
    ("pos_threshold", "ON threshold (log)", "{:.3f}"),
    ("neg_threshold", "OFF threshold (log)", "{:.3f}"),
    ("threshold_sigma", "threshold spread (log)", "{:.3f}"),
    ("refractory_us", "refractory (us)", "{:.0f}"),
    ("cutoff_hz", "photoreceptor cutoff (Hz)", "{:.0f}"),
    ("shot_noise_hz", "shot noise (Hz)", "{:.2g}"),
    ("dark_shot_noise_hz", "dark shot noise (Hz)", "{:.2g}"),
    ("leak_hz", "leak (Hz)", "{:.2g}"),
    ("hot_pixel_fraction", "hot pixels (fraction)", "{:.2g}"),
    ("hot_pixel_hz", "hot pixel rate (Hz)", "{:.3g}"),
)


def _offset_dn(dvs: sim.DVSParams, cal: Calibration) -> float:
    """The log offset of dvs in frame DN (the fitted one scaled by the ratio of dark fractions)."""
    return cal.offset_dn * dvs.dark_fraction / cal.dvs.dark_fraction


def _pair(rates: tuple[float, float]) -> str:
    return f"{rates[0]:.2g} / {rates[1]:.2g}"


def fit_table(cal: Calibration) -> str:
    """The parameters (preset, fitted) and the realism statistics (real, preset, fitted) as a Markdown table.

    Parameters
    ----------
    cal : Calibration
        The calibration.

    Returns
    -------
    str
        The table.
    """
    rows = [("quantity", "real", cal.preset_name, "fitted"), ("---", "---:", "---:", "---:")]
    for name, label, fmt in PARAM_ROWS:
        rows.append((label, "", fmt.format(getattr(cal.preset, name)), fmt.format(getattr(cal.dvs, name))))
    rows.append(("log offset b (DN)", "", f"{_offset_dn(cal.preset, cal):.3g}", f"{cal.offset_dn:.3g}"))
    rows.append(("frames: black level / read noise (DN)", f"{cal.input.black_level:g} / {cal.read_noise_dn:.2f}",
                  "", ""))
    real, pre, fit = cal.real, cal.scores["preset"], cal.scores["fitted"]
    n, n_on, n_off = real["events"], real["on_events"], real["off_events"]

    def count(total, ratio):
        return f"{total * ratio / 1000:.1f} k" if total is not None and math.isfinite(ratio) else "-"

    rows.append((f"events {cal.window_s[0]:.4g}-{cal.window_s[1]:.4g} s", f"{n / 1000:.1f} k",
                 count(n, pre["count_ratio"]), count(n, fit["count_ratio"])))
    rows.append(("ON / OFF events", f"{n_on / 1000:.1f} k / {n_off / 1000:.1f} k",
                 f"{count(n_on, pre['on_ratio'])} / {count(n_off, pre['off_ratio'])}",
                 f"{count(n_on, fit['on_ratio'])} / {count(n_off, fit['off_ratio'])}"))
    rows.append(("quiet static noise ON / OFF (Hz)", _pair((real["quiet_on_hz"], real["quiet_off_hz"])),
                 _pair(pre["sim_quiet_hz"]), _pair(fit["sim_quiet_hz"])))
    for key, label in (("count_corr_blurred", "per-pixel count correlation, 5x5 blurred"),
                       ("rate_rel_rmse", "10 ms rate, relative RMS error"),
                       ("interval_l1", "interval histogram L1")):
        perfect = {"count_corr_blurred": "1", "rate_rel_rmse": "0", "interval_l1": "0"}
        rows.append((label, perfect[key], f"{pre[key]:.3g}", f"{fit[key]:.3g}"))
    rows.append(("events per passage, median", f"{real['passage_median']:g}",
                 f"{real['passage_median'] + pre['passage_median_diff']:g}",
                 f"{real['passage_median'] + fit['passage_median_diff']:g}"))
    widths = [max(len(r[i]) for r in rows) for i in range(4)]
    return "\n".join("| " + " | ".join(c.ljust(w) for c, w in zip(r, widths)) + " |" for r in rows)


def sensor_of(cal: Calibration, name: str, description: str = "") -> object:
    """The sim.Sensor of a calibration: the fitted DVS fields over the preset (full_illumination left to the
    generation's auto illumination, which resolves it as the calibration did), the [input] table (black level,
    read noise, log offset in DN), the recording's frame camera ([camera]: frame rate, exposure, bit depth, read
    noise) and the provenance (recording, its sha256, window, loss, evaluations, time).

    Parameters
    ----------
    cal : Calibration
        The calibration.
    name : str
        The sensor's name.
    description : str, optional
        Its description (default: "fitted to <recording> by evsim calibrate").

    Returns
    -------
    Sensor
        The sensor.
    """
    provenance = {
        "method": "evsim calibrate: the recording's frames simulated and the realism statistics of the events "
                  "matched (evsim_eval.calibrate.fit)",
        "recording": cal.path.name, "sha256": cal.sha256,
        "window_s": [float(cal.window_s[0]), float(cal.window_s[1])], "seed": cal.seed,
        "loss": round(cal.loss, 4), "evaluations": cal.evaluations,
        "wall_s": round(cal.wall_s, 1), "cpu_s": round(cal.cpu_s, 1),
        "date": datetime.date.today(),
    }
    return calibrated_sensor(name, cal.dvs, cal.preset_name, black_level=cal.input.black_level,
                             read_noise_dn=cal.read_noise_dn, offset_dn=cal.offset_dn, camera=cal.camera,
                             description=description or f"fitted to {cal.path.name} by evsim calibrate",
                             provenance=provenance)


def write_calibration(cal: Calibration, path: str | Path, name: str | None = None) -> Path:
    """Write the sensor file of a calibration (sim.write_sensor, atomic); return its path.

    Parameters
    ----------
    cal : Calibration
        The calibration.
    path : str or pathlib.Path
        The sensor file to write (.toml).
    name : str, optional
        The sensor's name (default: the file's stem).

    Returns
    -------
    pathlib.Path
        The path written.
    """
    path = Path(path)
    sensor = sensor_of(cal, name or path.stem)
    sim.write_sensor(path, sensor)
    return path
