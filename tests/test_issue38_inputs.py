"""Nothing wrong gets in (issue 38): polarity values, the streaming reader, folders where files go, numbers that
break the maths, foreign text on stderr, API parameters, and the arguable cases of docs/guide/bad-input.md."""

from __future__ import annotations

import warnings

import h5py
import numpy as np
import pytest
import scipy.io

from generators.formats import DatasetFormatError, export, load

from recordings import make_recording


def _export(rec, path, fmt: str, **kw) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # parts the format cannot hold
        export(rec, path, fmt, **kw)


# ----- polarity values ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("values", [(4, 2), (0.5, 1.0), (1, 7), (-2, 1)])
def test_e2vid_polarity_outside_its_encodings_is_refused(tmp_path, values):
    path = tmp_path / "e.h5"
    _export(make_recording(), path, "e2vid")
    with h5py.File(path, "a") as f:
        n = f["events/ps"].shape[0]
        del f["events/ps"]
        f["events/ps"] = np.resize(np.array(values, np.float64 if 0.5 in values else np.int64), n)
    with pytest.raises(DatasetFormatError, match=r"e\.h5: event polarity must be 0/1 or -1/\+1 \(0 and -1 are OFF\)"):
        load(path)


@pytest.mark.parametrize("value, found", [(0.5, "-1, 0.5, 1"), (7.0, "-1, 1, 7"), (-3.0, "-3, -1, 1")])
def test_akf_mat_polarity_outside_its_encodings_is_refused_and_zero_one_read(tmp_path, value, found):
    path = tmp_path / "a.mat"
    rec = make_recording()
    _export(rec, path, "akf-mat")
    m = {k: v for k, v in scipy.io.loadmat(path).items() if not k.startswith("__")}
    m["events"][5, 3] = value
    scipy.io.savemat(path, m)
    with pytest.raises(DatasetFormatError, match=rf"a\.mat: event polarity .*found values {found}$"):
        load(path)
    m["events"][:, 3] = (rec.events["p"] > 0).astype(np.float64)  # the 0/1 encoding: read
    scipy.io.savemat(path, m)
    np.testing.assert_array_equal(load(path).events["p"], rec.events["p"])
