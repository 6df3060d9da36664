"""The sim.Sensor a calibration gives: the fitted DVS fields over the preset, the frames' [input] table and the
recording's frame camera. Shared by the sensor file (evsim_eval.calibrate.report) and the conversion that measures
the calibration as its user will see it (evsim_eval.calibrate.verify)."""

from __future__ import annotations

from collections.abc import Mapping

import sim

__all__ = ["calibrated_sensor"]


def calibrated_sensor(name: str, dvs: sim.DVSParams, preset_name: str, *, black_level: float, read_noise_dn: float,
                      offset_dn: float, camera: Mapping, description: str = "",
                      provenance: Mapping | None = None) -> sim.Sensor:
    """The sensor of fitted DVS parameters.

    Parameters
    ----------
    name : str
        The sensor's name.
    dvs : sim.DVSParams
        The fitted parameters; full_illumination is left to the generation's auto illumination (the preset's
        value is written), which resolves it as the calibration did.
    preset_name : str
        The preset the fit started from (the sensor file's base).
    black_level, read_noise_dn, offset_dn : float
        The frames' black level and read noise and the log offset b, in frame DN (the [input] table).
    camera : mapping
        The recording's frame camera as CameraParams fields (the [camera] table).
    description : str
        Its description.
    provenance : mapping, optional
        Where it comes from (recording, window, ...).

    Returns
    -------
    sim.Sensor
        The sensor.
    """
    dvs = dvs.replace(full_illumination=sim.DVSParams.preset(preset_name).full_illumination)
    return sim.Sensor(name=name, dvs=dvs, base=preset_name, camera=dict(camera), description=description,
                      provenance=dict(provenance or {}),
                      tables={"input": {"black_level": float(black_level),
                                        "read_noise_dn": round(float(read_noise_dn), 4),
                                        "offset_dn": round(float(offset_dn), 3)}})
