"""Outputs users choose (events only, or with LDR frames and HDR reference), `evsim export` from anything evsim
reads, and `evsim info` from recorded summaries and on folders: each checked against the true events, read back
by independent readers (expelliarmus, evlib, aedat, dv-processing)."""

from __future__ import annotations

import json
import warnings

import h5py
import numpy as np
import pytest

import sim
from evsim_app.cli import main
from evsim_app.info import describe, format_description
from evsim_eval.reconstruct import reconstruct_dataset
from generators.ahdr import AHDRConfig, generate_ahdr
from generators.config import parse_config, to_ahdr_config
from generators.convert import convert
from generators.dataset import generate_dataset
from generators.exports import export_path
from generators.formats import DatasetFormatError, ExportDropWarning, export, load
from generators.formats.native import event_summary, read_native_window
from generators.formats.recording import Recording
from generators.scenes import MovingEdge
from sim import EvsimInputError, InvalidParameterError

from recordings import make_recording

SCENE = dict(height=24, width=32, duration_us=150_000)


def _generate(path, outputs, seed=3):
    config = AHDRConfig(outputs=outputs, labels=True, reference_rate_hz=100.0, compression=None)
    generate_ahdr(MovingEdge(**SCENE, speed_px_per_s=60.0), path, config, seed, progress=False)
    return path


@pytest.fixture(scope="module")
def full_and_events_only(tmp_path_factory):
    d = tmp_path_factory.mktemp("outputs")
    return (_generate(d / "full.h5", ("events", "frames", "reference")), _generate(d / "events.h5", ("events",)))


# -- outputs ------------------------------------------------------------------------------------------------------
def test_events_only_output_has_the_full_runs_events_and_no_frames(full_and_events_only):
    full, only = (load(p) for p in full_and_events_only)
    assert full.events.size > 1000 and full.frames.shape[0] == 5 and full.reference.shape[0] > 5
    np.testing.assert_array_equal(only.events, full.events)  # the same seed gives the same events
    np.testing.assert_array_equal(only.event_labels, full.event_labels)
    np.testing.assert_array_equal(only.threshold_maps, full.threshold_maps)
    assert only.frames is None and only.reference is None
    assert only.metadata["config"]["outputs"] == ["events"]
    assert (only.metadata["n_frames"], only.metadata["n_references"]) == (0, 0)
    d = describe(full_and_events_only[1])
    assert d["frames"] is None and d["reference"] is None and d["events"]["count"] == full.events.size
    assert "frames      none (generated with --outputs events)" in format_description(d)


def test_what_needs_frames_or_reference_says_the_file_was_generated_without_them(full_and_events_only, tmp_path):
    # in Python the remedy is named in keywords, on the command line (cli_message) in flags
    only = full_and_events_only[1]
    with pytest.raises(EvsimInputError, match="needs at least 1 LDR frame, the recording has 0 .it was generated "
                                              "with outputs events: .*with outputs events, frames, reference") as e:
        reconstruct_dataset(only, tmp_path / "r")
    assert "--" not in str(e.value)
    assert "(it was generated with --outputs events: generate or convert it again with --outputs " \
           "events,frames,reference)" in e.value.cli_message
    with pytest.raises(EvsimInputError, match="exr export needs reference frames.*with outputs events") as e:
        export(only, tmp_path / "x", "exr")
    assert "--" not in str(e.value) and "--outputs events" in e.value.cli_message
    assert not (tmp_path / "x").exists() and not list(tmp_path.iterdir())


def test_a_recording_without_reference_points_to_the_interleave_protocol_in_each_interfaces_words():
    from evsim_eval.protocols import recording_case

    rec = make_recording()
    rec.reference = rec.reference_t_us = None
    with pytest.raises(sim.OptionError, match="^the recording has no HDR reference frames .use "
                                              "protocol='interleave'.$") as e:
        recording_case(rec, "reference")
    assert e.value.cli_message == "the recording has no HDR reference frames (use --protocol interleave)"
    from evsim_eval.evaluate import split_times
    from evsim_eval.reconstruct import output_times

    for call, api, cli in [(lambda: output_times(rec, "sometimes"), "times='sometimes': one of", "--times 'sometimes'"),
                           (lambda: output_times(rec, "reference"), "times=reference: the recording has no",
                            "--times reference: the recording has no"),
                           (lambda: split_times(1, 0.5), "tuning (tune=True) needs at least 2", "--tune needs")]:
        with pytest.raises(sim.OptionError) as e:
            call()
        assert str(e.value).startswith(api) and "--" not in str(e.value) and e.value.cli_message.startswith(cli)


def test_outputs_are_validated_where_they_are_set():
    def cfg(outputs):
        return parse_config({"defaults": {"output": {"outputs": outputs}},
                             "sequence": [{"scene": {"type": "moving_edge"}}]}, source="c.toml")

    assert to_ahdr_config(cfg(["reference", "events"]).sequences[0].settings).outputs == ("events", "reference")
    assert to_ahdr_config(cfg(["events", "frames", "reference"]).sequences[0].settings).outputs == (
        "events", "frames", "reference")
    with pytest.raises(InvalidParameterError, match=r"c.toml: defaults.output.outputs: unknown output 'frame'; "
                                                    "outputs are events, frames, reference"):
        cfg(["events", "frame"])
    with pytest.raises(InvalidParameterError, match="outputs must include events"):
        cfg(["frames"])
    with pytest.raises(InvalidParameterError, match="must include events"):
        AHDRConfig(outputs=())


def test_convert_writes_the_events_only_by_default(tmp_path):
    rng = np.random.default_rng(0)
    stack = (rng.random((6, 12, 16)) * 200 + 20).astype(np.uint8)
    stack[3:, :, :8] = 240  # a brightness step: events
    np.save(tmp_path / "clip.npy", stack)
    index = convert(tmp_path / "clip.npy", tmp_path / "out", fps=30.0, upsample="none", progress=False)
    rec = load(index.parent / "clip.h5")
    assert rec.events.size > 0 and rec.frames is None and rec.reference is None
    both = convert(tmp_path / "clip.npy", tmp_path / "out2", fps=30.0, upsample="none", progress=False,
                   settings={"output": {"outputs": ["events", "frames"]}})
    rec2 = load(both.parent / "clip.h5")
    assert rec2.frames.shape[0] > 0 and rec2.reference is None
    np.testing.assert_array_equal(rec2.events, rec.events)


# -- info from the recorded summary -------------------------------------------------------------------------------
def test_info_counts_equal_the_true_counts_without_reading_the_events(tmp_path, monkeypatch):
    rec = make_recording()
    export(rec, tmp_path / "a.h5", "native")
    s = event_summary(tmp_path / "a.h5")
    ev = rec.events
    assert s == {"count": ev.size, "on": int((ev["p"] > 0).sum()), "t_first_us": int(ev["t"][0]),
                 "t_last_us": int(ev["t"][-1]),
                 "labels": np.bincount(rec.event_labels, minlength=4).tolist()}
    import evsim_app.info

    def no_streaming(*a, **k):
        raise AssertionError("info streamed the events")

    monkeypatch.setattr(evsim_app.info, "iter_native_events", no_streaming)
    d = describe(tmp_path / "a.h5")
    assert (d["events"]["count"], d["events"]["on"]) == (ev.size, int((ev["p"] > 0).sum()))
    assert d["events"]["labels"] == dict(zip(("signal", "shot", "leak", "hot"),
                                             np.bincount(rec.event_labels, minlength=4).tolist()))
    monkeypatch.undo()
    # a summary that disagrees with the file is not believed: the events are counted
    with h5py.File(tmp_path / "a.h5", "r+") as f:
        bad = json.loads(f["events"].attrs["summary"])
        bad["t_last_us"] += 1
        f["events"].attrs["summary"] = json.dumps(bad)
    assert event_summary(tmp_path / "a.h5") is None
    assert describe(tmp_path / "a.h5")["events"]["t_last_us"] == int(ev["t"][-1])


def test_native_window_reads_equal_slices_of_the_whole_stream(full_and_events_only):
    path = full_and_events_only[0]
    ev = load(path).events
    t0, t1 = int(ev["t"][0]), int(ev["t"][-1])
    for a, b in [(t0, t1 + 1), (t0 - 5000, t0), (t0 + 1, t0 + 2), (t0 + 1234, t0 + 56_789), (t1, t1 + 10),
                 (t1 + 1, t1 + 5000), (-10**6, 10**9), (t0 + 999, t0 + 1001)]:
        np.testing.assert_array_equal(read_native_window(path, a, b), sim.slice_time(ev, a, b))


def test_plot_events_streamed_from_a_native_file_draws_what_the_loaded_recording_gives(full_and_events_only,
                                                                                      tmp_path):
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        pytest.skip("matplotlib is not installed")
    from evsim_app.plots.events import plot_events
    from generators.formats.streaming import open_event_stream

    path = full_and_events_only[1]
    a = plot_events(load(path), tmp_path / "a.png", window_ms=7, bin_ms=3)
    b = plot_events(open_event_stream(path), tmp_path / "b.png", window_ms=7, bin_ms=3)
    assert a["times_us"] == b["times_us"]
    for x, y in [*zip(a["frames"], b["frames"]), *zip(a["surfaces"], b["surfaces"]), *zip(a["rate"], b["rate"])]:
        np.testing.assert_array_equal(x, y)
    assert sum(int(f.sum()) for f in a["frames"]) > 0


# -- export -------------------------------------------------------------------------------------------------------
def _independent(path, fmt):
    """(t, x, y, p in -1/+1) as an independent reader decodes the file."""
    if fmt == "evt3":  # (expelliarmus's EVT 3.0 decoder disagrees with the spec: see test_formats_interchange)
        df = pytest.importorskip("evlib").load_events(str(path)).collect()
        return (df["t"].dt.total_microseconds().to_numpy(), df["x"].to_numpy(), df["y"].to_numpy(),
                df["polarity"].to_numpy())
    if fmt == "aedat2":  # tonic's DAVIS346 AEDAT 2.0 reader (masks taken from jAER)
        _, _, xytp = pytest.importorskip("tonic.io").read_davis_346(str(path))
        return xytp["t"], xytp["x"], xytp["y"], np.where(xytp["p"] > 0, 1, -1)
    if fmt == "dat":  # faery: Prophesee's own DAT layout (it refuses other event types)
        a = pytest.importorskip("faery").events_stream_from_file(path).to_array()
        return a["t"], a["x"], a["y"], np.where(a["on"], 1, -1)
    if fmt == "evt2":
        a = pytest.importorskip("expelliarmus").Wizard(encoding=fmt).read(str(path))
        return a["t"], a["x"], a["y"], np.where(a["p"] > 0, 1, -1)
    aedat = pytest.importorskip("aedat")
    got = np.concatenate([p["events"] for p in aedat.Decoder(str(path)) if "events" in p])
    return got["t"], got["x"], got["y"], np.where(got["on"], 1, -1)


def _assert_events(cols, ev):
    t, x, y, p = cols
    np.testing.assert_array_equal(np.asarray(t, np.int64), ev["t"])
    for got, want in zip((x, y, p), (ev["x"], ev["y"], ev["p"])):
        np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("fmt", ["evt3", "evt2", "dat", "aedat4"])
def test_export_of_a_dataset_folder_reads_back_in_independent_readers(tiny_dataset, tmp_path, fmt):
    with pytest.warns(ExportDropWarning) as said:
        done = export_path(tiny_dataset, tmp_path / "out", fmt)
    assert len(said) == 1  # one note for the whole folder
    assert [d.name for d in done] == ["a", "b"]
    for d in done:
        assert d.out.parent == tmp_path / "out" and d.out.exists()
        ev = load(d.source).events
        assert ev.size > 100
        _assert_events(_independent(d.out, fmt), ev)
        np.testing.assert_array_equal(load(d.out).events, ev)  # evsim's own reader agrees


def test_export_to_aedat2_reads_back_in_tonics_davis346_reader(tmp_path):
    # tonic's reader decodes the DAVIS346 address layout (346 x 260: x counted from the right edge)
    rng = np.random.default_rng(5)
    n = 5000
    ev = sim.make_events(np.sort(rng.integers(0, 2_000_000, n)), rng.integers(0, 346, n), rng.integers(0, 260, n),
                         rng.choice([-1, 1], n))
    export(Recording(events=ev, height=260, width=346), tmp_path / "a.h5", "native")
    (done,) = export_path(tmp_path / "a.h5", tmp_path / "a.aedat2", "aedat2")  # (events only: nothing left out)
    assert done.out == tmp_path / "a.aedat2"
    _assert_events(_independent(done.out, "aedat2"), ev)


def test_export_from_a_non_native_layout_and_dv_processing(tmp_path, tiny_recording):
    dv = pytest.importorskip("dv_processing")
    rec = tiny_recording
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExportDropWarning)
        export(rec, tmp_path / "a.raw", "evt3")
        export_path(tmp_path / "a.raw", tmp_path / "a.aedat4", "aedat4")
    r = dv.io.MonoCameraRecording(str(tmp_path / "a.aedat4"))
    got = []
    while (batch := r.getNextEventBatch()) is not None:
        got.append(batch.numpy())
    got = np.concatenate(got)
    _assert_events((got["timestamp"], got["x"], got["y"], np.where(got["polarity"] > 0, 1, -1)), rec.events)


def test_export_refuses_an_existing_output_and_leaves_nothing_on_failure(tiny_dataset, tmp_path):
    (tmp_path / "taken").mkdir()
    with pytest.raises(EvsimInputError, match="taken already exists; pass overwrite=True") as e:
        export_path(tiny_dataset, tmp_path / "taken", "evt3")
    assert "--" not in str(e.value) and "pass --overwrite" in e.value.cli_message
    rec = make_recording()
    rec.reference = rec.reference_t_us = None
    export(rec, tmp_path / "src" / "a.h5", "native")
    export(make_recording(), tmp_path / "src" / "b.h5", "native")
    with pytest.raises(EvsimInputError, match="exr export needs reference frames"):
        export_path(tmp_path / "src", tmp_path / "exr", "exr")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["src", "taken"]  # no half-written folder
    with pytest.raises(DatasetFormatError, match="no dataset evsim reads here"):
        export_path(tmp_path / "taken", tmp_path / "x", "evt3")


def test_info_describes_every_folder_evsim_writes(tmp_path):
    cfg = parse_config({"defaults": {"height": 16, "width": 20, "duration_s": 0.1,
                                     "output": {"outputs": ["events", "frames"]}},
                        "sequence": [{"name": "s1", "scene": {"type": "moving_edge"}},
                                     {"name": "s2", "scene": {"type": "checkerboard"}}]})
    with pytest.warns(ExportDropWarning) as said:  # said once for the run, not once per sequence
        index = generate_dataset(cfg, tmp_path / "ds", fmt="evt3", progress=False)
    assert len(said) == 1 and "leave out frames, threshold_maps, crf, metadata" in str(said[0].message)
    d = describe(index.parent)
    assert d["layout"] == "folder" and d["index"] and len(d["sequences"]) == 2
    for s in d["sequences"]:
        rec = load(s["path"])
        assert s["events"]["count"] == rec.events.size > 0
        assert s["frames"]["count"] == rec.frames.shape[0] and s["reference"] is None
    assert "dataset folder, 2 sequences)" in format_description(d)
    with pytest.warns(ExportDropWarning):
        export_path(index.parent, tmp_path / "exported", "aedat4")
    e = describe(tmp_path / "exported")
    assert [s["events"]["count"] for s in e["sequences"]] == [s["events"]["count"] for s in d["sequences"]]
    assert not e["index"]
    # an EXR folder (what `reconstruct` and `export --format exr` write)
    rec = make_recording()
    with pytest.warns(ExportDropWarning):
        export(rec, tmp_path / "exr", "exr")
    x = describe(tmp_path / "exr")
    assert x["layout"] == "exr" and x["reference"]["count"] == rec.reference.shape[0]
    assert x["events"]["count"] == 0


def test_cli_export_prints_a_note_as_one_line(tiny_dataset, tmp_path, capsys):
    assert main(["export", str(tiny_dataset / "a.h5"), str(tmp_path / "a.raw"), "--format", "evt3",
                 "--no-progress"]) == 0
    out, err = capsys.readouterr()
    assert "a: " in out and "a.raw (evt3)" in out
    assert err.splitlines() == ["evsim: note: evt3 holds events and the sensor size: left out frames, reference, "
                                "threshold_maps, crf, metadata"]
    assert main(["export", str(tiny_dataset / "a.h5"), str(tmp_path / "a.raw"), "--format", "evt3"]) == 2
    assert "already exists; pass --overwrite" in capsys.readouterr().err
    assert main(["info", str(tiny_dataset)]) == 0
    assert "(a folder of sequences, no index.json, 2 sequences)" in capsys.readouterr().out


def test_info_names_an_export_folder_and_an_unfinished_run(tiny_dataset, tmp_path, capsys):
    assert main(["export", str(tiny_dataset), str(tmp_path / "ex"), "--format", "e2vid", "--no-progress"]) == 0
    capsys.readouterr()
    assert main(["info", str(tmp_path / "ex")]) == 0
    assert f"(evsim export to e2vid of {tiny_dataset.resolve()}, 2 sequences)" in capsys.readouterr().out
    (tiny_dataset / "a.manifest.json").write_text("{}")  # a complete sequence of a run without its index
    assert main(["info", str(tiny_dataset)]) == 0
    assert "(a generate/convert run that did not finish (no index.json; the same command with --resume completes " \
           "it), 2 sequences)" in capsys.readouterr().out


@pytest.mark.parametrize("value,message", [("events,frame", "unknown output 'frame'"),
                                           ("frames,reference", "events are always written")])
def test_cli_outputs_flag_names_the_problem(tmp_path, capsys, value, message):
    for command in (["convert", str(tmp_path / "clip.npy")], ["generate", "ahdr"]):
        assert main([*command, "--outputs", value, "--out", str(tmp_path / "o")]) == 2
        err = capsys.readouterr().err
        assert f"argument --outputs: {message}; give events[,frames,reference], got '{value}'" in err
    assert not (tmp_path / "o").exists()
