"""`evsim info` on a native file imports only what it needs: no numba, OpenCV, OpenEXR or tqdm (each costs 0.1 to
0.5 s of CPU at start-up; see CHANGELOG for the measured command times)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from generators.formats import export

from recordings import make_recording

HEAVY = ("numba", "cv2", "OpenEXR", "tqdm", "scipy", "matplotlib", "distributed")

_CHILD = """
import contextlib, io, json, sys
from evsim_app.cli import main
with contextlib.redirect_stdout(io.StringIO()) as out:
    code = main(["info", sys.argv[1]])
print(json.dumps({"code": code, "out": out.getvalue(), "loaded": [m for m in sys.argv[2:] if m in sys.modules]}))
"""


@pytest.mark.slow
def test_info_on_a_native_file_loads_no_kernel_or_image_library(tmp_path):
    rec = make_recording()
    export(rec, tmp_path / "a.h5", "native")
    run = subprocess.run([sys.executable, "-c", _CHILD, str(tmp_path / "a.h5"), *HEAVY], capture_output=True,
                         text=True, check=True)
    r = json.loads(run.stdout.strip().splitlines()[-1])
    assert r["code"] == 0 and f"events      {rec.events.size} " in r["out"]
    assert r["loaded"] == []
