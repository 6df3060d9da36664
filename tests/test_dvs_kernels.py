"""The emulator's vectorisable log and expm1 against numpy, over the whole range the pixels can meet."""

import numpy as np

from sim import kernel_math as K


def test_log_row_matches_numpy_over_full_float_range():
    rng = np.random.default_rng(0)
    a = np.concatenate([10.0 ** rng.uniform(-307, 308, 5000), [1.0, 2.0, 0.5, np.sqrt(0.5), np.sqrt(2.0)],
                        np.nextafter(1.0, [0.0, 2.0]), 1 + rng.uniform(-0.3, 0.3, 2000)])
    out = np.empty_like(a)
    K.log_row(a, np.empty(a.size, dtype=np.int64), out)
    np.testing.assert_allclose(out, np.log(a), rtol=1e-15, atol=2e-16)


def test_expm1_row_matches_numpy_and_saturates():
    rng = np.random.default_rng(1)
    a = -np.concatenate([10.0 ** rng.uniform(-300, 1.6, 5000), [0.0, np.log(2) / 2, 1e-310]])
    out = np.empty_like(a)
    K.expm1_row(a, np.empty(a.size, dtype=np.int64), out)
    np.testing.assert_allclose(out, np.expm1(a), rtol=2e-15, atol=0)
    deep = -np.array([40.0, 41.0, 700.0, 1e6, np.inf])
    out = np.empty_like(deep)
    K.expm1_row(deep, np.empty(deep.size, dtype=np.int64), out)
    assert np.all(out == -1.0)
