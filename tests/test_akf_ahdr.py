"""End-to-end synthetic AHDR check (as in the AKF paper's AHDR data): a moving high-dynamic-range pattern seen by a
DAVIS346-like event sensor and by an 8-bit LDR camera whose response is the 100..160 window, so that most of the
scene is clipped in the frames. The AKF must beat the complementary filter and frames only on MSE and SSIM."""

import numpy as np
import pytest

import akf
import crf_models
import evsim_eval
import sim

H, W, DURATION_US = 30, 40, 700_000
FPS, EXPOSURE_US = 30, 10_000


def _scene(seed=3, log_mean=-1.55, log_amp=3.0, speed=(30.0, 8.0)):
    """log radiance = log_mean + a sum of 6 drifting sinusoids (total amplitude log_amp): about e^+-2 around the
    centre of the window's band, so well over half the frame pixels are clipped."""
    rng = np.random.default_rng(seed)
    k = rng.normal(0, 0.25, (6, 2))
    phase = rng.uniform(0, 2 * np.pi, 6)
    amp = rng.uniform(0.5, 1, 6)
    amp *= log_amp / amp.sum()
    yy, xx = np.mgrid[0:H, 0:W].astype(float)

    def radiance(t_us):
        t = t_us * 1e-6
        arg = (k[:, 0, None, None] * (xx - speed[0] * t) + k[:, 1, None, None] * (yy - speed[1] * t)
               + phase[:, None, None])
        return np.exp(log_mean + np.sum(amp[:, None, None] * np.sin(arg), axis=0))

    return radiance


def make_ahdr_sequence(preset="davis346", seed=0):
    radiance = _scene()
    crf = crf_models.get("window")
    times = np.arange(0, DURATION_US + 1, 500)
    events = sim.emulate(np.stack([radiance(t) for t in times]), times, sim.DVSParams.preset(preset), seed=seed)
    ts = np.arange(0, DURATION_US - EXPOSURE_US, 1_000_000 // FPS)
    te = ts + EXPOSURE_US
    frames = np.stack([
        np.round(crf.forward(np.mean([radiance(t) for t in np.linspace(s, e, 10, endpoint=False) + 500], axis=0))
                 * 255).astype(np.uint8)
        for s, e in zip(ts, te)
    ])
    ref_t = np.arange(100_000, DURATION_US - 50_000, 20_000)
    reference = np.stack([radiance(t) for t in ref_t])
    return events, frames, ts, te, crf, reference, ref_t


@pytest.mark.parametrize("preset", ["ideal", "davis346"])
def test_akf_beats_cf_and_frames_on_synthetic_ahdr(preset):
    events, frames, ts, te, crf, reference, ref_t = make_ahdr_sequence(preset)
    clipped = np.mean((frames == 0) | (frames == 255))
    assert clipped > 0.5
    table = evsim_eval.evaluate_sequence(events, frames, ts, te, crf, reference, ref_t,
                                  methods=("akf", "cf", "frames"), metrics=("mse", "ssim"))
    print(f"\nsynthetic AHDR ({preset}, {clipped:.0%} clipped):")
    for method, row in table.items():
        print(f"  {method:8s} MSE {row['mse']:.4g}  SSIM {row['ssim']:.3f}")
    for other in ("cf", "frames"):
        assert table["akf"]["mse"] < table[other]["mse"]
        assert table["akf"]["ssim"] > table[other]["ssim"]
    assert table["akf"]["mse"] < 0.7 * table["cf"]["mse"]  # at least 30 % lower MSE than CF


def test_publishing_is_a_pure_read():
    """Reconstructing at sparse times and at a dense superset (inside and at the edges of exposures, at event
    timestamps) gives bit-identical values at the common times, for the AKF (I, P and K) and for CF: publishing
    neither changes the state nor splits the one-sided clipped-frame propagation in a way that matters."""
    events, frames, ts, te, crf, _, _ = make_ahdr_sequence("davis346")
    assert np.mean((frames == 0) | (frames == 255)) > 0.5
    sparse = np.arange(60_000, 650_000, 45_000)
    dense = np.unique(np.concatenate([sparse, np.arange(1_000, 650_000, 1_733), ts, te, (ts + te) // 2,
                                      events["t"][::4000]]))
    dense = dense[dense < 650_000]
    common = np.searchsorted(dense, sparse)
    a = akf.reconstruct(events, frames, ts, te, crf, sparse, return_variance=True, return_gain=True)
    b = akf.reconstruct(events, frames, ts, te, crf, dense, return_variance=True, return_gain=True)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y[common])
    cf_a = akf.complementary_filter(events, frames, ts, te, crf, sparse)
    cf_b = akf.complementary_filter(events, frames, ts, te, crf, dense)
    np.testing.assert_array_equal(cf_a, cf_b[common])
