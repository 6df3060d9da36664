import json

import numpy as np
import pytest

import sim
from generators import load
from generators.ahdr import AHDRConfig
from generators.scenes import MovingEdge
from generators.sweep import generate_sweep, grid_points


def test_grid_points_cartesian_product():
    pts = grid_points({"threshold_sigma": [0.0, 0.1], "refractory_us": [0, 100, 500]})
    assert len(pts) == 6 and pts[0] == {"threshold_sigma": 0.0, "refractory_us": 0}
    assert pts[-1] == {"threshold_sigma": 0.1, "refractory_us": 500}
    with pytest.raises(sim.InvalidParameterError, match="unknown parameter"):
        grid_points({"gain": [1]})
    with pytest.raises(sim.InvalidParameterError, match="non-empty"):
        grid_points({"leak_hz": []})


def test_sweep_writes_one_sequence_per_point_with_its_parameters(tmp_path):
    scene = MovingEdge(12, 16, 60_000, speed_px_per_s=80.0)
    grid = {"threshold_sigma": [0.0, 0.08], "shot_noise_hz": [0.0, 500.0]}
    cfg = AHDRConfig(dvs=sim.DVSParams.preset("ideal"), camera=sim.CameraParams(fps=50.0, exposure_us=2000),
                     labels=True, compression="lzf")
    index_path = generate_sweep(scene, tmp_path / "sw", grid, cfg, seed=9, progress=False)
    index = json.loads(index_path.read_text())
    assert index["grid"] == grid and index["generator"] == "sweep" and index["seed"]["entropy"] == 9
    assert len(index["sequences"]) == 4
    seeds = set()
    for entry, point in zip(index["sequences"], grid_points(grid)):
        rec = load(tmp_path / "sw" / entry["file"])
        dvs = rec.metadata["config"]["dvs"]
        assert entry["sweep_point"] == point == rec.metadata["sweep_point"]
        assert dvs["threshold_sigma"] == point["threshold_sigma"] and dvs["shot_noise_hz"] == point["shot_noise_hz"]
        assert dvs["refractory_us"] == 0  # the rest of the base configuration is kept
        seeds.add(tuple(rec.metadata["seed"]["spawn_key"]))
        assert rec.metadata["seed"]["entropy"] == 9
        # the parameters act: mismatch shows in the threshold maps, shot noise in the labels
        assert rec.threshold_maps.std() == pytest.approx(point["threshold_sigma"], abs=0.02)
        n_shot = int(np.sum(rec.event_labels == 1))
        expected_shot = point["shot_noise_hz"] * 12 * 16 * 0.06
        assert n_shot == pytest.approx(expected_shot, rel=0.3, abs=3)
    assert seeds == {(0,), (1,), (2,), (3,)}


def test_sweep_refuses_to_overwrite(tmp_path):
    scene = MovingEdge(4, 4, 30_000)
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "keep.txt").write_text("x")
    with pytest.raises(sim.EvsimInputError, match="overwrite"):
        generate_sweep(scene, tmp_path / "out", {"leak_hz": [0.0]}, seed=0, progress=False)
    with pytest.raises(sim.InvalidParameterError):  # bad values are refused before anything is written
        generate_sweep(scene, tmp_path / "new", {"leak_hz": [-1.0]}, seed=0, progress=False)
    assert not (tmp_path / "new").exists()
