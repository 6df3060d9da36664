"""The emulator's vectorisable log (float64) and expm1 (float32) against numpy, over the whole range the pixels
can meet."""

import numpy as np

from sim import kernel_math as K


def test_log_row_matches_numpy_over_full_float_range():
    rng = np.random.default_rng(0)
    a = np.concatenate([10.0 ** rng.uniform(-307, 308, 5000), [1.0, 2.0, 0.5, np.sqrt(0.5), np.sqrt(2.0)],
                        np.nextafter(1.0, [0.0, 2.0]), 1 + rng.uniform(-0.3, 0.3, 2000)])
    out = np.empty_like(a)
    K.log_row(a, np.empty(a.size, dtype=np.int64), out)
    np.testing.assert_allclose(out, np.log(a), rtol=1e-15, atol=2e-16)


def test_expm1_row_f32_is_within_one_float32_ulp_and_saturates():
    rng = np.random.default_rng(1)
    a = -np.concatenate([10.0 ** rng.uniform(-30, 1.6, 20000), [0.0, np.log(2) / 2, 1e-38]]).astype(np.float32)
    out = np.empty_like(a)
    K.expm1_row_f32(a, np.empty(a.size, dtype=np.int32), out)
    exact = np.expm1(a.astype(np.float64))
    assert np.all(out[exact == 0] == 0)
    rel = np.abs(out[exact != 0] / exact[exact != 0] - 1)
    assert rel.max() <= 1.2e-7, rel.max()  # about one float32 ulp (2**-23 = 1.19e-7)
    deep = -np.array([40.0, 41.0, 87.0, 1e6, np.inf], dtype=np.float32)
    out = np.empty_like(deep)
    K.expm1_row_f32(deep, np.empty(deep.size, dtype=np.int32), out)
    assert np.all(out == -1.0)


def test_stable_argsort_matches_numpy_stable_sort():
    rng = np.random.default_rng(2)
    cases = [np.zeros(0, np.int64), np.array([7]), rng.integers(0, 3, 500), rng.integers(-40_000, 40_000, 3000),
             rng.integers(-2**62, 2**62, 3000), np.array([2**62, -2**62, 0, 2**62, -2**62, 0])]
    for keys in cases:
        keys = np.asarray(keys, dtype=np.int64)
        assert np.array_equal(K.stable_argsort(keys), np.argsort(keys, kind="stable"))  # ties keep their order
