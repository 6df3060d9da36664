"""The AHDR benchmark suite (generators.builtin.ahdr_suite: the AKF paper's AHDR construction with the davis346 DVS
and the 100..160 window CRF), small: 64x80 pixels, 0.5 s per sequence.

The references are SDR photos (at most 1 x): the causal AKF is scored as the paper's parity rows run it, bounded to
the full well (max_intensity=1; unbounded, its event noise above the flat white costs it raw MSE), the smoother
(aks) at its defaults, unbounded. Both beat the complementary filter (bounded to the full well,
akf.complementary_filter's default since CF was a straw man) and frames-only on MSE and SSIM on every sequence, and
their mean MSE is at least 10 % below CF's."""

import json

import numpy as np
import pytest

import crf_models
from evsim_eval.evaluate import evaluate_dataset
from generators import load
from generators.builtin import AHDR_BLACK, AHDR_SUITE_HDR, AHDR_SUITE_PHOTOS, generate_ahdr_suite, hdr_data_dir

HDR_PRESENT = all((hdr_data_dir() / f).is_file() for _, f, _ in AHDR_SUITE_HDR)


@pytest.fixture(scope="module")
def suite(tmp_path_factory):
    out = tmp_path_factory.mktemp("ahdr_suite")
    generate_ahdr_suite(out, height=64, width=80, duration_s=0.5, seed=0)
    result, notes, _, _ = evaluate_dataset(out, methods=("akf", "aks", "cf", "frames"), metrics=("mse", "ssim"),
                                           method_options={"akf": {"max_intensity": 1.0}})
    print("\nAHDR suite 64x80, 0.5 s (MSE in x units, SSIM):")
    for seq in result["akf"]:
        print(f"  {seq:20s} " + "  ".join(f"{m} {result[m][seq]['mse']:.4g}/{result[m][seq]['ssim']:.3f}"
                                           for m in result))
    return out, result


def test_suite_is_the_paper_construction(suite):
    out, _ = suite
    names = [e["name"] for e in json.loads((out / "index.json").read_text())["sequences"]]
    assert names[:len(AHDR_SUITE_PHOTOS)] == [n for n, _, _ in AHDR_SUITE_PHOTOS]
    clipped = []
    for name in names:
        rec = load(out / f"{name}.h5")
        assert rec.metadata["config"]["dvs"]["threshold_sigma"] == 0.03  # the noisy davis346 preset
        assert rec.metadata["config"]["dvs"]["hot_pixel_fraction"] > 0
        crf = crf_models.get(rec.crf["name"], **rec.crf["params"])
        assert (rec.crf["name"], rec.crf["params"]["low"], rec.crf["params"]["high"]) == ("window", 100.0, 160.0)
        # x = reference radiance (the factor is 1) and the reference is a [1/255, 1] well-exposed linear view
        assert rec.metadata["reference_to_crf_x"] == pytest.approx(1.0)
        assert rec.reference.min() >= AHDR_BLACK * (1 - 1e-6) and rec.reference.max() <= 1 + 1e-6
        # the LDR frame is the window CRF of the reference (up to blur and noise) where it is well exposed
        good = (rec.frames[1] > 5) & (rec.frames[1] < 250)
        assert np.median(np.abs(np.log(crf.inverse(rec.frames[1][good] / 255.0) / rec.reference[1][good]))) < 0.05
        clipped.append(np.mean((rec.frames == 0) | (rec.frames == 255)))
    assert min(clipped) > 0.5  # most of every scene lies outside the window: an HDR problem


def test_real_hdr_photos_are_in_the_suite(suite):
    if not HDR_PRESENT:
        pytest.skip(f"real HDR photos not found in {hdr_data_dir()}")
    _, result = suite
    assert {n for n, _, _ in AHDR_SUITE_HDR} <= set(result["akf"])


@pytest.mark.parametrize("method", ["akf", "aks"])
def test_akf_beats_cf_and_frames_on_every_sequence(suite, method):
    _, result = suite
    sequences = [s for s in result[method] if s != "mean"]
    assert len(sequences) >= 4
    for seq in sequences:
        row = result[method][seq]
        assert row["mse"] < result["cf"][seq]["mse"], seq
        assert row["ssim"] > result["cf"][seq]["ssim"], seq
        assert row["ssim"] > result["frames"][seq]["ssim"], seq
        assert row["mse"] < result["frames"][seq]["mse"], seq
    assert result[method]["mean"]["mse"] < 0.9 * result["cf"]["mean"]["mse"]  # >= 10 % lower mean MSE than CF
