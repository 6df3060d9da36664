"""Analytic and colour-science curves, the AHDR window, certainty/weight/variance and the registry."""

import json

import numpy as np
import pytest

import crf_models
from crf_models import CRFError

# Every family with a non-default parameter set; kinks (where the derivative jumps) listed per curve.
CASES = [
    ("linear", {}, []),
    ("linear", {"black_level": 0.0625, "x_clip": 0.8}, []),
    ("gamma", {"gamma": 2.4}, []),
    ("srgb", {}, [0.0031308]),
    ("bt709", {}, [0.018]),
    ("hlg", {}, [1 / 12]),
    ("logc3", {}, [0.010591 / 55.0795766988]),
    ("logc3", {"EI": 400, "in_max": 20.0}, [0.010591 / 20.0]),
    ("slog3", {}, [0.01125 / 38.4209343372]),
    ("sigmoid", {"steepness": 14.0, "midpoint": 0.4}, []),
    ("filmic", {}, []),
    ("window", {}, []),
    ("window", {"low": 60, "high": 200, "base": "srgb"}, [0.0031308]),
]
IDS = [f"{n}-{i}" for i, (n, _, _) in enumerate(CASES)]


@pytest.mark.parametrize("name,params,kinks", CASES, ids=IDS)
def test_inverse_undoes_forward_on_the_invertible_range(name, params, kinks):
    crf = crf_models.get(name, **params)
    x = np.linspace(crf.x_lo, crf.x_hi, 2001)
    y = crf.forward(x)
    assert np.all(np.diff(y) > 0) and y.min() >= 0 and y.max() <= 1
    np.testing.assert_allclose(crf.inverse(y), x, rtol=1e-9, atol=1e-12)
    # and forward(inverse(y)) = y over the reachable responses (BT.709's rounded constants leave a gap
    # (0.081, 0.08125) of responses no irradiance produces: the curve jumps by 2.5e-4 at x = 0.018)
    yy = np.linspace(crf.y_lo, crf.y_hi, 1001)
    if name == "bt709":
        yy = yy[np.abs(yy - 0.0811) > 3e-4]
    np.testing.assert_allclose(crf.forward(crf.inverse(yy)), yy, atol=1e-12)


@pytest.mark.parametrize("name,params,kinks", CASES, ids=IDS)
def test_derivative_matches_finite_differences(name, params, kinks):
    crf = crf_models.get(name, **params)
    x = np.linspace(crf.x_lo, crf.x_hi, 203)[1:-1]
    h = 1e-5 * (crf.x_hi - crf.x_lo)
    x = x[np.all(np.abs(x[:, None] - np.array(kinks + [np.inf])[None]) > 2 * h, axis=1)]
    fd = (crf.forward(x + h) - crf.forward(x - h)) / (2 * h)
    np.testing.assert_allclose(crf.derivative(x), fd, rtol=2e-5)


def test_curves_match_their_published_values():
    # sRGB: 0.18 -> 0.46135613 (1.055 * 0.18^(1/2.4) - 0.055); BT.709: 4.5 x below 0.018.
    assert crf_models.get("srgb").forward(0.18) == pytest.approx(1.055 * 0.18 ** (1 / 2.4) - 0.055, abs=1e-12)
    assert crf_models.get("bt709").forward(0.01) == pytest.approx(0.045, abs=1e-12)
    assert crf_models.get("srgb").derivative(0.5) == pytest.approx(1.055 / 2.4 * 0.5 ** (1 / 2.4 - 1), rel=1e-7)
    # LogC3 (EI 800): 18% grey encodes to 0.391007; normalised with enc(0) = 0.092809 and x = 1 <-> code 1.0.
    logc = crf_models.get("logc3")
    assert logc.forward(0.18 / logc.in_max) == pytest.approx((0.391007 - 0.092809) / (1 - 0.092809), abs=2e-6)
    # S-Log3: 18% grey at code value 420 / 1023.
    slog = crf_models.get("slog3")
    assert slog.forward(0.18 / slog.in_max) == pytest.approx((420 / 1023 - 95 / 1023) / (1 - 95 / 1023), abs=2e-3)
    assert crf_models.get("gamma", gamma=2.0).forward(0.25) == pytest.approx(0.5)
    lin = crf_models.get("linear", black_level=0.1, x_clip=0.5)
    np.testing.assert_allclose(lin.forward([0.0, 0.25, 0.5, 0.9]), [0.1, 0.55, 1.0, 1.0])
    sig = crf_models.get("sigmoid", steepness=10.0, midpoint=0.5)
    assert sig.forward(0.5) == pytest.approx(0.5) and sig.forward(0.0) == 0.0 and sig.forward(1.0) == pytest.approx(1.0)


@pytest.mark.parametrize("name,params,kinks", CASES, ids=IDS)
def test_params_rebuild_the_same_curve_through_json(name, params, kinks):
    crf = crf_models.get(name, **params)
    again = crf_models.get(crf.name, **json.loads(json.dumps(crf.params)))
    y = np.linspace(0, 1, 257)
    x = np.linspace(0, 1.2, 257)
    assert np.array_equal(again.forward(x), crf.forward(x))
    assert np.array_equal(again.weight(y), crf.weight(y))


def test_window_clips_exactly_at_its_band_and_stretches_it_linearly():
    crf = crf_models.get("window", low=100, high=160, base="linear")
    z = np.arange(256.0)
    y = crf.forward(z / 255)
    assert np.all(y[:101] == 0) and np.all(y[160:] == 1)
    np.testing.assert_allclose(y[100:161], (z[100:161] - 100) / 60, atol=1e-12)
    # on the default gamma base the band is the gamma-encoded 100..160
    g = crf_models.get("window")
    x_lo, x_hi = (100 / 255) ** 2.2, (160 / 255) ** 2.2
    assert g.x_lo == pytest.approx(x_lo) and g.x_hi == pytest.approx(x_hi)
    assert g.forward(x_lo * 0.999) == 0 and g.forward(x_hi * 1.001) == 1 and 0 < g.forward((x_lo + x_hi) / 2) < 1
    assert g.derivative(x_lo * 0.99) == 0 and g.derivative(x_hi * 1.01) == 0


def test_window_weight_vanishes_where_clipped_so_rbar_saturates():
    crf = crf_models.get("window", base="linear")
    y = np.arange(256) / 255
    w = crf.weight(y)
    assert w[0] == 0 and w[255] == 0
    np.testing.assert_allclose(w[1:255], 1.0)  # linear base: the stretched band is uniformly certain
    rbar = crf.variance(y, sigma_im2=0.01, max_variance=5.0)
    assert rbar[0] == 5.0 and rbar[255] == 5.0
    np.testing.assert_allclose(rbar[1:255], 0.01)


def test_sigmoid_rbar_is_small_and_flat_mid_range_and_saturates_at_the_ends():
    crf = crf_models.get("sigmoid", steepness=10.0)
    y = np.linspace(0, 1, 1001)
    rbar = crf.variance(y, sigma_im2=1e-3, max_variance=1.0)
    mid = (y > 0.4) & (y < 0.6)
    # near the midpoint f^w = 1 - O(dy^2): Rbar within 5% of sigma_im2
    assert np.all(rbar[mid] <= 1.05e-3) and np.all(rbar[mid] >= 1e-3 * (1 - 1e-9))
    assert rbar[-1] == 1.0  # y = 1: saturated (clipped at full well)
    assert rbar[0] == pytest.approx(1e-3 / crf.weight(0.0))  # x = 0 is not clipped: toe slope, large Rbar
    assert np.all(np.diff(rbar[y >= 0.5]) >= 0) and np.all(np.diff(rbar[y <= 0.5]) <= 0)


def test_certainty_is_normalised_and_weight_is_certainty_of_the_inverse():
    for name in ("sigmoid", "filmic", "srgb", "window", "logc3"):
        crf = crf_models.get(name)
        x = np.linspace(crf.x_lo, crf.x_hi, 4001)[1:-1]
        x = np.sort(np.concatenate([x, crf.inverse(np.linspace(crf.y_lo, crf.y_hi, 4001)[1:-1])]))
        c = crf.certainty(x)
        assert c.max() == pytest.approx(1.0, abs=2e-3) and c.min() >= 0
        y = crf.forward(x)
        np.testing.assert_allclose(crf.weight(y), c, rtol=1e-6, atol=1e-12)


def test_robertson_weighting():
    crf = crf_models.get("linear", weighting="robertson")
    z = np.array([0.0, 63.75, 127.5, 255.0])
    np.testing.assert_allclose(crf.weight(z / 255), np.exp(-4 * (z - 127.5) ** 2 / 127.5**2))
    assert crf.weight(127.5 / 255) == pytest.approx(1.0)
    assert crf.variance(0.0, 2.0, 1e9) == pytest.approx(2.0 * np.exp(4.0))
    assert crf_models.get(crf.name, **crf.params).weighting == "robertson"


def test_registry_lists_names_and_rejects_bad_input():
    names = crf_models.available()
    for n in ("linear", "gamma", "srgb", "bt709", "hlg", "logc3", "slog3", "sigmoid", "filmic", "window", "lut",
              "tabulated"):
        assert n in names
    with pytest.raises(CRFError, match="unknown CRF 'nope'"):
        crf_models.get("nope")
    with pytest.raises(CRFError, match="bad parameters"):
        crf_models.get("gamma", gama=2)
    with pytest.raises(CRFError, match="gamma must be"):
        crf_models.get("gamma", gamma=-1)
    with pytest.raises(CRFError, match="low < high"):
        crf_models.get("window", low=170, high=160)
    with pytest.raises(CRFError, match="weighting"):
        crf_models.get("srgb", weighting="hat")
    crf = crf_models.get("srgb")
    with pytest.raises(CRFError, match="x must be >= 0"):
        crf.forward([0.5, -0.1])
    with pytest.raises(CRFError, match=r"y must lie in \[0, 1\]"):
        crf.inverse([0.5, np.nan])
    with pytest.raises(CRFError, match="sigma_im2"):
        crf.variance(0.5, 0.0, 1.0)
    assert issubclass(CRFError, ValueError)


def test_srgb_is_colour_sciences_curve_without_importing_it():
    import subprocess
    import sys

    colour = pytest.importorskip("colour")
    x = np.concatenate([np.linspace(-0.1, 1.2, 20001), [0.0031308, 0.04045]])
    srgb = crf_models.get("srgb")
    np.testing.assert_array_equal(srgb._encode(x), colour.models.eotf_inverse_sRGB(x))
    np.testing.assert_array_equal(srgb._decode(x), colour.models.eotf_sRGB(x))
    code = "import sys, crf_models; crf_models.get('srgb').inverse(0.5); print('colour' in sys.modules)"
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True).stdout.strip() == "False"
