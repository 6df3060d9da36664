"""A calibration's scores as its user will see them: the recording converted with the sensor (what `evsim convert
RECORDING --sensor FILE` writes, at its defaults) and scored by the realism task (`evsim evaluate RECORDING --task
realism --against CONVERTED --window START END`). The fit itself simulates a cheaper stand-in (the recording's
frames sampled once, evsim_eval.calibrate.simulation) with its own seed; the table and the realism task are one
computation only if the table is measured this way."""

from __future__ import annotations

import tempfile
from pathlib import Path

import sim
from generators.formats.recording import Recording

__all__ = ["converted_scores"]


def converted_scores(path: Path, rec: Recording, sensor: sim.Sensor, window_s: tuple[float, float],
                     seed: int = 0, conditioning: str | None = None) -> dict:
    """The realism scores of the recording converted with `sensor`.

    Parameters
    ----------
    path : Path
        The recording's file or folder (convert's input).
    rec : Recording
        The recording, loaded (the real side of the score).
    sensor : sim.Sensor
        The sensor to convert with (its [input] table gives the frames' black level, as a sensor file does).
    window_s : tuple of float
        The scored window, seconds from each recording's first frame exposure start.
    seed : int
        convert's seed (its default, 0, is what `evsim convert` uses).
    conditioning : str, optional
        convert's input conditioning (`--input-conditioning`; None: its default, temporal for a recording).

    Returns
    -------
    dict
        evsim_eval.realism.Comparison.scores, with "sim_quiet_hz" (ON, OFF quiet static noise of the conversion, Hz).
    """
    from generators.convert import convert

    from ..realism import score_recordings
    from ..realism.score import load_one

    with tempfile.TemporaryDirectory(prefix="evsim-calibrate-") as tmp:
        sensor_file = Path(tmp) / "sensor.toml"
        sim.write_sensor(sensor_file, sensor)
        convert(path, Path(tmp) / "converted", settings={"sensor": str(sensor_file)}, seed=seed, progress=False,
                conditioning=conditioning)
        converted = load_one(Path(tmp) / "converted", "the conversion")
        comparison = score_recordings(rec, converted, window_s)
    return {**comparison.scores, "sim_quiet_hz": list(comparison.sim.quiet_hz)}
