"""Tabulated curves, the DoRF and EMoR loaders (real files when present, synthetic files always)."""

import json
from pathlib import Path

import numpy as np
import pytest

import crf_models
from crf_models import CRFError, TabulatedCRF

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "crf"


def test_lut_is_piecewise_linear_with_exact_inverse_and_segment_slopes():
    x = np.array([0.0, 0.1, 0.3, 0.7, 1.0])
    y = np.array([0.0, 0.3, 0.6, 0.9, 1.0])
    crf = crf_models.get("lut", y=y, x=x)
    xq = np.linspace(0, 1, 1001)
    np.testing.assert_allclose(crf.forward(xq), np.interp(xq, x, y))
    np.testing.assert_allclose(crf.inverse(crf.forward(xq)), xq, atol=1e-12)
    mids = (x[:-1] + x[1:]) / 2
    slopes = np.diff(y) / np.diff(x)
    np.testing.assert_allclose(crf.derivative(mids), slopes)
    h = 1e-6
    np.testing.assert_allclose((crf.forward(mids + h) - crf.forward(mids - h)) / (2 * h), slopes, rtol=1e-6)
    np.testing.assert_allclose(crf.certainty(mids), slopes / slopes.max())
    assert crf.weight(1.0) == 0 and crf.weight(0.0) == pytest.approx(1.0)  # x = 0 is not clipped
    again = crf_models.get(crf.name, **json.loads(json.dumps(crf.params)))
    assert np.array_equal(again.forward(xq), crf.forward(xq))


def test_flat_ends_are_clipped_ranges():
    crf = TabulatedCRF([0.0, 0.0, 0.5, 1.0, 1.0], x=[0.0, 0.2, 0.5, 0.8, 1.0])
    assert (crf.x_lo, crf.x_hi) == (0.2, 0.8) and crf.clip_low
    assert crf.forward(0.1) == 0 and crf.derivative(0.1) == 0 and crf.derivative(0.9) == 0
    assert crf.inverse(0.0) == 0.2 and crf.inverse(1.0) == 0.8
    assert crf.weight(0.0) == 0 and crf.weight(1.0) == 0 and crf.weight(0.5) > 0
    assert crf.variance([0.0, 1.0], 0.1, 7.0).tolist() == [7.0, 7.0]


def test_bad_tables_are_rejected():
    with pytest.raises(CRFError, match="non-decreasing"):
        TabulatedCRF([0.0, 0.5, 0.4, 1.0])
    with pytest.raises(CRFError, match="interior flat run at index 1"):
        TabulatedCRF([0.0, 0.5, 0.5, 1.0])
    with pytest.raises(CRFError, match="strictly increasing"):
        TabulatedCRF([0.0, 0.5, 1.0], x=[0.0, 0.5, 0.5])
    with pytest.raises(CRFError, match="NaN"):
        TabulatedCRF([0.0, np.nan, 1.0])
    with pytest.raises(CRFError, match="constant"):
        TabulatedCRF([0.5, 0.5])


def test_break_ties_only_touches_interior_runs():
    y = crf_models.break_ties([0, 0, 0.1, 0.2, 0.2, 0.2, 0.5, 1, 1])
    np.testing.assert_allclose(y, [0, 0, 0.1, 0.2, 0.3, 0.4, 0.5, 1, 1])


def _write_dorf_txt(path, curves):
    """The original dorfCurves.txt layout: name, channel, 'I =' and 'B =' blocks (values wrapped)."""
    lines = []
    for name, I, B in curves:
        lines += [name, "Red", "I ="]
        lines += ["  ".join(f"{v:.6e}" for v in I[i : i + 6]) for i in range(0, I.size, 6)]
        lines += ["B ="]
        lines += ["  ".join(f"{v:.6e}" for v in B[i : i + 6]) for i in range(0, B.size, 6)]
    path.write_text("\n".join(lines) + "\n")


def test_dorf_text_layout_synthetic(tmp_path):
    I = np.linspace(0, 1, 64)
    curves = [("film-a", I, I**0.5), ("film-b", I, I ** (1 / 2.2))]
    _write_dorf_txt(tmp_path / "dorfCurves.txt", curves)
    crf = crf_models.load_dorf(tmp_path / "dorfCurves.txt", 1)
    assert "film-b Red" in crf.source
    np.testing.assert_allclose(crf.forward(I), I ** (1 / 2.2), atol=1e-6)
    with pytest.raises(CRFError, match="out of range.*2 curves"):
        crf_models.load_dorf(tmp_path / "dorfCurves.txt", 2)
    with pytest.raises(CRFError, match="not found"):
        crf_models.load_dorf(tmp_path / "missing.txt", 0)


def test_dorf_mat_and_text_layouts_of_the_real_database(tmp_path):
    mat = DATA / "dorf" / "201_CRF_data.mat"
    if not mat.is_file():
        pytest.skip(f"{mat} absent")
    import scipy.io

    raw = scipy.io.loadmat(mat)
    for index in (0, 118, 200):  # 118 has float32 ties in its shoulder
        crf = crf_models.load_dorf(mat, index)
        assert crf.x.size == 1024 and crf.x_lo == 0 and crf.x_hi == 1
        np.testing.assert_allclose(crf.y, raw["B"][index], atol=2e-6)  # ties broken by < the tie gap
        np.testing.assert_allclose(crf.inverse(crf.forward(crf.x)), crf.x, atol=1e-9)
    _write_dorf_txt(tmp_path / "dorfCurves.txt", [(f"c{i}", raw["I"][i], raw["B"][i]) for i in (117, 118)])
    from_txt = crf_models.load_dorf(tmp_path / "dorfCurves.txt", 1)
    np.testing.assert_allclose(from_txt.y, crf_models.load_dorf(mat, 118).y, atol=1e-6)


def _write_emor(path, E, f0, hs):
    blocks = [("E =", E), ("f0 =", f0)] + [(f"h({n + 1})=", h) for n, h in enumerate(hs)]
    lines = []
    for head, v in blocks:
        lines.append(head)
        lines += ["   ".join(f"{a:.6e}" for a in v[i : i + 4]) for i in range(0, v.size, 4)]
    path.write_text("\n".join(lines) + "\n")


def test_emor_synthetic(tmp_path):
    E = np.linspace(0, 1, 1024)
    f0 = E**0.6
    hs = [np.sin(np.pi * E) * 0.1, np.sin(2 * np.pi * E) * 0.05]
    _write_emor(tmp_path / "emor.txt", E, f0, hs)
    crf = crf_models.load_emor(tmp_path / "emor.txt", [0.5, -0.3])
    np.testing.assert_allclose(crf.forward(E), f0 + 0.5 * hs[0] - 0.3 * hs[1], atol=2e-6)
    with pytest.raises(CRFError, match="2 basis curves, 3 coefficients"):
        crf_models.load_emor(tmp_path / "emor.txt", [0.1, 0.1, 0.1])


def test_emor_real_model():
    path = DATA / "emor" / "emor.txt"
    if not path.is_file():
        pytest.skip(f"{path} absent")
    mean = crf_models.load_emor(path)
    assert mean.forward(0.0) == 0 and mean.forward(1.0) == pytest.approx(1.0, abs=1e-6)
    # the mean curve of real cameras is concave: responses above the identity in the mid-tones
    assert mean.forward(0.25) > 0.4
    crf = crf_models.load_emor(path, [0.5, 0.1, -0.05])
    x = np.linspace(0.01, 0.99, 99)
    np.testing.assert_allclose(crf.inverse(crf.forward(x)), x, atol=1e-9)
    assert not np.allclose(crf.forward(x), mean.forward(x), atol=1e-3)
