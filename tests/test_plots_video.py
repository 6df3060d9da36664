"""DVS video (`evsim plot events --video`): the written file, decoded back (Pillow for GIF, OpenCV for MP4), has
one frame per interval of the events' span, and each frame's pixel colours are those of the events in its window,
counted here independently; rendering streams (memory does not grow with the number of frames)."""

from __future__ import annotations

import functools
import tracemalloc

import numpy as np
import pytest

from evsim_app.cli import main
from evsim_app.plots.common import OFF_COLOUR, ON_COLOUR
from evsim_app.plots.video import event_frames, write_video
from generators.formats import streaming
from generators.formats.native import write_native
from generators.formats.recording import Recording
from sim import EVENT_DTYPE, EvsimInputError

H, W = 12, 16
FRAME_US = 10_000
FULL = 3


def events(seed=0, n=3000, span_us=1_000_000, t0=5_000_123):
    """Events over 1 s starting at t0 (not a frame multiple), with a 300 ms silence in the middle."""
    rng = np.random.default_rng(seed)
    ev = np.zeros(n, EVENT_DTYPE)
    ev["t"] = t0 + np.sort(rng.integers(0, span_us, n))
    ev["t"][n // 2 :] += 300_000
    ev["t"][-1] = ev["t"][-2] + 1
    ev["x"], ev["y"] = rng.integers(0, W, n), rng.integers(0, H, n)
    ev["p"] = rng.choice(np.array([-1, 1], np.int8), n)
    return ev


def expected_rgb(ev, k, frame_us=FRAME_US):
    """Colours of frame k, from the events with t0 + k dt <= t < t0 + (k + 1) dt: white, moving towards the ON
    colour by min(on, FULL) / FULL and towards the OFF colour by min(off, FULL) / FULL (uint8, rounded)."""
    t0 = int(ev["t"][0])
    sel = ev[(ev["t"] >= t0 + k * frame_us) & (ev["t"] < t0 + (k + 1) * frame_us)]
    on = np.zeros((H, W))
    off = np.zeros((H, W))
    np.add.at(on, (sel["y"][sel["p"] > 0], sel["x"][sel["p"] > 0]), 1)
    np.add.at(off, (sel["y"][sel["p"] < 0], sel["x"][sel["p"] < 0]), 1)
    a, b = np.minimum(on / FULL, 1)[..., None], np.minimum(off / FULL, 1)[..., None]
    rgb = 1 + a * (np.array(ON_COLOUR) - 1) + b * (np.array(OFF_COLOUR) - 1)
    return np.round(np.clip(rgb, 0, 1) * 255).astype(np.uint8)


@pytest.fixture
def native(tmp_path):
    ev = events()
    path = tmp_path / "seq.h5"
    write_native(Recording(events=ev, height=H, width=W), path)
    return path, ev


def test_gif_has_one_frame_per_interval_and_the_colours_of_its_events(native, tmp_path):
    from PIL import Image, ImageSequence

    path, ev = native
    r = write_video(path, tmp_path / "v.gif", frame_ms=FRAME_US / 1e3, full_scale=FULL, progress=False)
    n = (int(ev["t"][-1]) - int(ev["t"][0])) // FRAME_US + 1
    assert r["frames"] == n and n >= 125 and r["events"] == ev.size
    frames = [np.asarray(f.convert("RGB")) for f in ImageSequence.Iterator(Image.open(tmp_path / "v.gif"))]
    assert len(frames) == n
    for k in (0, 1, 40, 70, 100, n - 1):  # 70: in the silence, blank
        np.testing.assert_array_equal(frames[k], expected_rgb(ev, k), err_msg=f"frame {k}")
    assert (frames[70] == 255).all() and not (frames[100] == 255).all()


@pytest.mark.parametrize("fmt,name", [("dat", "e.dat"), ("aedat2", "e.aedat2"), ("e2vid-txt", "e.txt")])
def test_every_readable_layout_gives_the_same_video(native, tmp_path, fmt, name):
    # .dat and .aedat2 are streamed chunk by chunk like native files; E2VID text is loaded whole
    from generators.formats import export
    from generators.formats.streaming import open_event_stream

    path, ev = native
    export(path, tmp_path / name, fmt)
    assert open_event_stream(tmp_path / name).streamed == (fmt != "e2vid-txt")
    write_video(path, tmp_path / "a.gif", frame_ms=7, progress=False)
    write_video(tmp_path / name, tmp_path / "b.gif", frame_ms=7, progress=False)
    assert (tmp_path / "a.gif").read_bytes() == (tmp_path / "b.gif").read_bytes()


def test_mp4_has_one_frame_per_interval_and_near_colours(native, tmp_path):
    cv2 = pytest.importorskip("cv2")
    path, ev = native
    scale = 8  # 4:2:0 blurs colour across 2x2 pixels: compare block centres
    r = write_video(path, tmp_path / "v.mp4", frame_ms=20, full_scale=FULL, scale=scale, progress=False)
    n = (int(ev["t"][-1]) - int(ev["t"][0])) // 20_000 + 1
    cap = cv2.VideoCapture(str(tmp_path / "v.mp4"))
    frames = []
    while True:
        ok, bgr = cap.read()
        if not ok:
            break
        frames.append(bgr[scale // 2 :: scale, scale // 2 :: scale, ::-1].astype(int))
    assert r["frames"] == len(frames) == n
    for k in (0, 10, 60):
        want = expected_rgb(ev, k, 20_000).astype(int)
        err = np.abs(frames[k] - want)
        assert np.median(err) <= 4 and err.max() <= 40, (k, np.median(err), err.max())


def test_mp4_is_h264_which_browsers_play(native, tmp_path):
    av = pytest.importorskip("av")
    path, _ = native
    write_video(path, tmp_path / "v.mp4", frame_ms=20, progress=False)
    with av.open(str(tmp_path / "v.mp4")) as f:
        stream = f.streams.video[0]
        assert stream.codec_context.name == "h264" and stream.codec_context.pix_fmt == "yuv420p"


def test_mp4_of_an_odd_sized_sensor_keeps_its_last_row_and_column(tmp_path):
    cv2 = pytest.importorskip("cv2")
    ev = np.zeros(2, EVENT_DTYPE)
    ev["t"], ev["x"], ev["y"], ev["p"] = [0, 1], [32, 0], [24, 0], [1, -1]  # the far corner, then the near one
    write_native(Recording(events=ev, height=25, width=33), tmp_path / "odd.h5")
    write_video(tmp_path / "odd.h5", tmp_path / "odd.mp4", full_scale=1, scale=3, progress=False)  # 99 x 75
    ok, bgr = cv2.VideoCapture(str(tmp_path / "odd.mp4")).read()
    assert ok and bgr.shape == (76, 100, 3)  # one blank row and column added: MPEG-4 frames have even sides
    rgb = bgr[..., ::-1].astype(int)
    assert rgb[73, 97, 0] > rgb[73, 97, 2] + 60  # the ON event at the far corner (its 3x3 block's centre) is red
    assert rgb[1, 1, 2] > rgb[1, 1, 0] + 60  # the OFF event is blue
    assert (rgb[75, :90] > 200).all() and (rgb[:66, 99] > 200).all()  # the padding is blank


def test_frames_stream_memory_does_not_grow_with_the_number_of_frames():
    def peak(n_frames):
        def chunks():
            for i in range(n_frames // 100):  # chunks of 100 frames, 2000 events each
                ev = np.zeros(2000, EVENT_DTYPE)
                ev["t"] = i * 100 * FRAME_US + np.linspace(0, 100 * FRAME_US - 1, 2000).astype(np.int64)
                ev["x"], ev["y"], ev["p"] = 3, 4, 1
                yield ev

        tracemalloc.start()
        count = sum(1 for _ in event_frames(chunks(), H, W, FRAME_US))
        _, top = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        assert count == n_frames
        return top

    short, long = peak(1000), peak(8000)
    assert long < 1.2 * short, (short, long)


def test_cli_writes_the_video_and_refuses_bad_options(native, tmp_path, capsys):
    path, ev = native
    out = tmp_path / "cli.gif"
    assert main(["plot", "events", str(path), "--video", str(out), "--frame-ms", "50", "--no-progress"]) == 0
    assert "wrote" in capsys.readouterr().out and out.is_file()
    assert not (tmp_path / "seq_events.png").exists()  # --video alone writes the video only
    for argv, message in [(["--video", str(tmp_path / "v.avi")], ".mp4 or .gif"),
                          (["--video", str(out), "--frame-ms", "0"], "--frame-ms must be"),
                          (["--video", str(out), "--full-scale", "16"], "--full-scale must be 1..15")]:
        assert main(["plot", "events", str(path), *argv]) == 2, argv
        err = capsys.readouterr().err
        assert err.startswith("evsim: error:") and message in err and "Traceback" not in err
    empty = tmp_path / "empty.h5"
    write_native(Recording(events=np.zeros(0, EVENT_DTYPE), height=H, width=W), empty)
    with pytest.raises(EvsimInputError, match="no events to draw"):
        write_video(empty, tmp_path / "e.gif", progress=False)
    assert not (tmp_path / "e.gif").exists()


def test_a_chunk_where_every_event_starts_a_frame_costs_a_few_times_the_chunk():
    # working arrays of 8 bytes or less per event (frame number, pixel index, polarity, run ends) beside the
    # 13-byte events; a Python int per run (72 bytes) would cost 8.6 times the chunk
    ev = np.zeros(20_000, EVENT_DTYPE)
    ev["t"], ev["p"] = np.arange(ev.size) * 10, 1
    tracemalloc.start()
    n = sum(1 for _ in event_frames([ev], 1, 1, 10))
    _, top = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert n == ev.size and top < 3 * ev.nbytes, top / ev.nbytes


def test_writing_a_gif_keeps_memory_flat_in_the_number_of_frames(tmp_path, monkeypatch):
    # Pillow's own multi-frame GIF writer keeps every frame; evsim's joins one-frame files as it goes. Events are
    # processed a chunk at a time, so memory may grow with the events of a chunk, never with the number of frames:
    # the file is read in chunks of 100 events, many chunks in both runs (with the default chunk, a million
    # events, both streams would be one chunk). A first run, not measured, makes the one-off allocations.
    monkeypatch.setattr(streaming, "open_event_stream", functools.partial(streaming.open_event_stream, size=100))

    def peak(n_frames):
        ev = np.zeros(n_frames, EVENT_DTYPE)  # one event a frame
        ev["t"] = np.arange(n_frames) * 1000
        ev["x"], ev["y"], ev["p"] = np.arange(n_frames) % W, np.arange(n_frames) % H, 1
        write_native(Recording(events=ev, height=H * 4, width=W * 4), tmp_path / f"s{n_frames}.h5")
        tracemalloc.start()
        r = write_video(tmp_path / f"s{n_frames}.h5", tmp_path / f"v{n_frames}.gif", frame_ms=1, scale=4,
                        progress=False)
        _, top = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        assert r["frames"] == n_frames
        return top

    peak(50)
    short, long = peak(500), peak(2000)
    assert long < 1.3 * short, (short, long)  # holding the frames would add 1500 x 3072 bytes
