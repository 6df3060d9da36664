"""`evsim evaluate` / `evsim reconstruct` and evsim_eval.evaluate: scores checked against evsim_eval.evaluate_sequence
run directly, the recorded unit factor against its closed form, EXR output read back, the interleave protocol on
the IJRR and AKF .mat layouts, and bad inputs -> exit 2."""

import dataclasses
import json

import numpy as np
import pytest

import akf
import crf_models
import evsim_eval
import sim
from evsim_app.cli import main
from evsim_eval.evaluate import evaluate_dataset
from evsim_eval.exposure import sample_count, sample_times
from evsim_eval.protocols import reference_to_x
from generators import load
from generators.formats import export
from generators.formats.exr import read_exr_sequence

from recordings import generate_tiny

METRICS = ("mse", "ssim")


@pytest.fixture
def dataset(tiny_dataset):
    return tiny_dataset


def _direct(path, methods=("akf", "aks", "cf", "frames"), leak_rate_hz=None):
    """The reference protocol spelled out with evsim_eval.evaluate_sequence and the camera's closed-form exposure; the
    AKF gets the recorded DVS leak rate unless leak_rate_hz is given."""
    rec = load(path)
    cam = sim.CameraParams(**{k: tuple(v) if isinstance(v, list) else v
                              for k, v in rec.metadata["config"]["camera"].items()})
    to_x = cam.electrons_per_radiance_us * cam.exposures[0] / cam.full_well_e
    inside = (rec.reference_t_us > rec.frame_t_mid_us[0]) & (rec.reference_t_us < rec.frame_t_mid_us[-1])
    crf = crf_models.get(rec.crf["name"], **rec.crf["params"])
    dvs = rec.metadata["config"]["dvs"]
    return evsim_eval.evaluate_sequence(rec.events, rec.frames, rec.frame_t_start_us, rec.frame_t_end_us, crf,
                                 rec.reference[inside] * to_x, rec.reference_t_us[inside], methods=methods,
                                 metrics=METRICS, contrast=(dvs["pos_threshold"], dvs["neg_threshold"]),
                                 method_options={m: {"leak_rate_hz": dvs["leak_hz"] if leak_rate_hz is None
                                                     else leak_rate_hz} for m in ("akf", "aks")})


def test_recorded_unit_factor_is_the_cameras_closed_form_and_the_fallback_agrees(dataset):
    rec = load(dataset / "a.h5")
    cam = rec.metadata["config"]["camera"]
    exposure = int(rec.frame_t_end_us[0] - rec.frame_t_start_us[0])
    expected = cam["reference_fill"] * exposure / (cam["reference_radiance"] * exposure)  # reference exposure = T_0
    assert rec.metadata["reference_to_crf_x"] == pytest.approx(expected, rel=1e-12)
    old = dataclasses.replace(rec, metadata={k: v for k, v in rec.metadata.items() if k != "reference_to_crf_x"})
    assert reference_to_x(old) == pytest.approx(expected, rel=1e-12)
    # the factor maps a well-exposed reference pixel to the frame's x: CRF^-1 of the frame agrees within noise
    crf = crf_models.get(rec.crf["name"], **rec.crf["params"])
    x_ref = rec.reference[1] * rec.metadata["reference_to_crf_x"]
    good = (rec.frames[1] > 10) & (rec.frames[1] < 245)
    x_frame = crf.inverse(rec.frames[1] / 255.0)
    assert good.sum() > 20
    assert np.median(np.abs(np.log(x_frame[good] / x_ref[good]))) < 0.05


def test_evaluate_table_and_json_match_akf_evaluate_sequence(dataset, tmp_path, capsys):
    out = tmp_path / "scores.json"
    assert main(["evaluate", str(dataset), "--metrics", "mse,ssim", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    result = json.loads(out.read_text())
    assert set(result) == {"akf", "aks", "cf", "frames", "scoring"}
    assert result.pop("scoring")["mode"].startswith("point-in-time")
    direct = {name: _direct(dataset / f"{name}.h5") for name in ("a", "b")}
    for method in result:
        assert set(result[method]) == {"a", "b", "mean"}
        for name in ("a", "b"):
            for metric in METRICS:
                assert result[method][name][metric] == pytest.approx(direct[name][method][metric], rel=1e-9)
        for metric in METRICS:
            assert result[method]["mean"][metric] == pytest.approx(
                np.mean([direct[n][method][metric] for n in ("a", "b")]), rel=1e-9)
    assert "units: x = CRF scaled irradiance" in text
    mse_block = text.split("\n\nmse: ")[1].split("\n\n")[0].splitlines()
    assert mse_block[0] == evsim_eval.NORMALISATION["mse"]  # every table states its normalisation
    assert mse_block[1].split() == ["mse", "akf", "aks", "cf", "frames"]
    row = dict(zip(("akf", "aks", "cf", "frames"), map(float, mse_block[2].split()[1:])))
    assert mse_block[2].split()[0] == "a"
    for method, value in row.items():
        assert value == pytest.approx(result[method]["a"]["mse"], rel=1e-3)  # printed with 4 significant digits


def test_leak_rate_option_overrides_the_recorded_one(dataset, tmp_path):
    assert load(dataset / "a.h5").metadata["config"]["dvs"]["leak_hz"] == 0.1  # the davis346 preset's
    scores = {}
    for leak in ("0", "0.5"):
        out = tmp_path / f"leak{leak}.json"
        assert main(["evaluate", str(dataset / "a.h5"), "--metrics", "mse,ssim", "--leak-hz", leak,
                     "--json", str(out)]) == 0
        scores[leak] = json.loads(out.read_text())
        direct = _direct(dataset / "a.h5", leak_rate_hz=float(leak))
        for method in ("akf", "cf", "frames"):
            for metric in METRICS:
                assert scores[leak][method]["a"][metric] == pytest.approx(direct[method][metric], rel=1e-9)
    assert scores["0"]["akf"]["a"]["mse"] != scores["0.5"]["akf"]["a"]["mse"]
    assert scores["0"]["cf"] == scores["0.5"]["cf"]  # only the AKF takes it
    out = tmp_path / "rec"
    assert main(["reconstruct", str(dataset / "a.h5"), "--out", str(out), "--times", "frames", "--leak-hz", "0"]) == 0
    rec = load(dataset / "a.h5")
    crf = crf_models.get(rec.crf["name"], **rec.crf["params"])
    dvs = rec.metadata["config"]["dvs"]
    expected = akf.reconstruct(rec.events, rec.frames, rec.frame_t_start_us, rec.frame_t_end_us, crf,
                               rec.frame_t_mid_us, contrast=(dvs["pos_threshold"], dvs["neg_threshold"]))
    np.testing.assert_array_equal(read_exr_sequence(out)[0], expected)


def test_reconstruct_smoother_writes_unbounded_images_and_their_variance(dataset, tmp_path):
    """--method aks --variance: the smoother's images, bit for bit, and its variance P in a `variance` folder;
    --variance of a method without one is refused."""
    out = tmp_path / "aks"
    assert main(["reconstruct", str(dataset / "a.h5"), "--out", str(out), "--method", "aks", "--times", "frames",
                 "--variance"]) == 0
    rec = load(dataset / "a.h5")
    crf = crf_models.get(rec.crf["name"], **rec.crf["params"])
    dvs = rec.metadata["config"]["dvs"]
    images, p = akf.reconstruct_smoothed(rec.events, rec.frames, rec.frame_t_start_us, rec.frame_t_end_us, crf,
                                         rec.frame_t_mid_us, contrast=(dvs["pos_threshold"], dvs["neg_threshold"]),
                                         leak_rate_hz=dvs["leak_hz"], return_variance=True)
    np.testing.assert_array_equal(read_exr_sequence(out)[0], images)
    np.testing.assert_array_equal(read_exr_sequence(out / "variance")[0], p)
    assert np.all(p > 0)
    assert main(["reconstruct", str(dataset / "a.h5"), "--out", str(tmp_path / "cf"), "--method", "cf",
                 "--variance"]) == 2


def test_dataset_index_folder_is_read_in_index_order(tmp_path):
    from generators.dataset import write_index

    generate_tiny(tmp_path / "z.h5", 2)
    generate_tiny(tmp_path / "y.h5", 3)
    write_index(tmp_path, {"sequences": [{"name": "z", "file": "z.h5"}, {"name": "y", "file": "y.h5"}]})
    result, notes, _, _ = evaluate_dataset(tmp_path, methods=("frames",), metrics=("mse",))
    assert list(result["frames"]) == ["z", "y", "mean"]
    assert [n.split(": white ")[0] for n in notes] == ["z", "y"]  # each sequence's white point, nothing else


def test_reconstruct_writes_exr_frames_with_the_same_values(dataset, tmp_path, capsys):
    out = tmp_path / "rec"
    assert main(["reconstruct", str(dataset / "a.h5"), "--out", str(out), "--method", "cf", "--times", "fps:50"]) == 0
    images, t = read_exr_sequence(out)
    rec = load(dataset / "a.h5")
    expected_t = np.arange(rec.frame_t_start_us[0], rec.frame_t_end_us[-1] + 1, 20_000)
    np.testing.assert_array_equal(t, expected_t)
    crf = crf_models.get(rec.crf["name"], **rec.crf["params"])
    dvs = rec.metadata["config"]["dvs"]
    direct = akf.METHODS["cf"](rec.events, rec.frames, rec.frame_t_start_us, rec.frame_t_end_us, crf, expected_t,
                               contrast=(dvs["pos_threshold"], dvs["neg_threshold"]))
    np.testing.assert_array_equal(images, direct)  # float32 EXR: bit-exact
    assert "written to" in capsys.readouterr().out
    # a dataset folder gets one sub-folder per sequence; --times reference uses the reference times
    assert main(["reconstruct", str(dataset), "--out", str(tmp_path / "all"), "--times", "reference"]) == 0
    for name in ("a", "b"):
        _, t = read_exr_sequence(tmp_path / "all" / name)
        np.testing.assert_array_equal(t, load(dataset / f"{name}.h5").reference_t_us)


@pytest.mark.parametrize("layout", ["ijrr", "akf-mat"])
def test_interleave_protocol_on_exported_layouts(dataset, tmp_path, layout):
    rec = load(dataset / "a.h5")
    target = tmp_path / ("seq" if layout == "ijrr" else "seq.mat")
    export(rec, target, layout)
    result, notes, _, _ = evaluate_dataset(target, protocol="interleave", methods=("akf", "frames"), metrics=("mse",),
                                           exposure_matched=False)
    # ground truth by hand: odd frames between even ones, x = CRF^-1(frame), frames-only from the even frames
    crf = crf_models.get(rec.crf["name"], **rec.crf["params"])
    fed = np.arange(0, rec.frames.shape[0], 2)
    held = np.arange(1, fed[-1], 2)
    truth = crf.inverse(rec.frames[held] / 255.0)

    def frames_only(times):
        return akf.frames_only(rec.events, rec.frames[fed], rec.frame_t_start_us[fed], rec.frame_t_end_us[fed], crf,
                               times)

    def mse_clipped(images):
        images = np.clip(images, crf.inverse(0.0), crf.inverse(1.0))
        return np.mean([np.mean((a - b) ** 2) for a, b in zip(images, truth)])

    assert result["frames"]["seq"]["mse"] == pytest.approx(mse_clipped(frames_only(rec.frame_t_mid_us[held])),
                                                           rel=1e-6)
    assert result["akf"]["seq"]["mse"] < result["frames"]["seq"]["mse"]  # the events fill the skipped frame
    assert len(notes) == 1 and notes[0].startswith("seq: AKF frame update noise: read noise ")  # nothing assumed
    # exposure-matched (the default): the mean of the method at the midpoint samples of each held-out exposure
    matched, *_ = evaluate_dataset(target, protocol="interleave", methods=("frames",), metrics=("mse",))
    averaged = []
    for k in held:
        a, b = rec.frame_t_start_us[k], rec.frame_t_end_us[k]
        averaged.append(frames_only(sample_times(a, b, sample_count(rec.events, a, b, truth.shape[1:]))).mean(0))
    assert matched["frames"]["seq"]["mse"] == pytest.approx(mse_clipped(np.stack(averaged)), rel=1e-6)


def test_interleave_without_a_crf_assumes_linear_and_says_so(tmp_path, capsys):
    rec = load(generate_tiny(tmp_path / "lin.h5", 4, crf="linear"))
    export(dataclasses.replace(rec, crf=None), tmp_path / "davis", "ijrr")
    assert main(["evaluate", str(tmp_path / "davis"), "--protocol", "interleave", "--metrics", "mse"]) == 0
    text = capsys.readouterr().out
    assert "assumed linear" in text
    result, *_ = evaluate_dataset(tmp_path / "davis", protocol="interleave", metrics=("mse",))
    with_crf, *_ = evaluate_dataset(tmp_path / "lin.h5", protocol="interleave", metrics=("mse",))
    for m in result:  # the recorded CRF was linear: assuming it changes nothing
        assert result[m]["mean"]["mse"] == pytest.approx(with_crf[m]["mean"]["mse"], rel=1e-9)


@pytest.mark.parametrize("argv, message", [
    (["evaluate", "{missing}"], "no such file"),
    (["evaluate", "{a}", "--methods", "akf,nope"], "nope"),
    (["evaluate", "{a}", "--metrics", ","], "comma-separated"),
    (["evaluate", "{a}", "--protocol", "sideways"], "invalid choice"),
    (["evaluate", "{ijrr_noref}"], "no HDR reference"),
    (["reconstruct", "{a}", "--out", "{out}", "--times", "fps:-3"], "positive rate"),
    (["reconstruct", "{a}", "--out", "{out}", "--times", "sometimes"], "one of reference, frames"),
    (["reconstruct", "{a}", "--out", "{out}", "--method", "magic"], "unknown method"),
    (["reconstruct", "{a}"], "--out"),
    (["evaluate", "{a}", "--leak-hz", "-1"], "--leak-hz"),
    (["reconstruct", "{a}", "--out", "{out}", "--leak-hz", "nan"], "--leak-hz"),
    (["reconstruct", "{a}", "--out", "{out}", "--method", "cf", "--leak-hz", "0.1"], "akf and aks methods only"),
    (["reconstruct", "{ijrr_noframes}", "--out", "{out}", "--times", "fps:10"],
     "at least 1 LDR frame, the recording has 0"),
    (["evaluate", "{ijrr_noframes}", "--protocol", "interleave"], "at least 3 LDR frames, the recording has 0"),
])
def test_bad_inputs_exit_2_with_a_message(dataset, tmp_path, capsys, argv, message):
    rec = load(dataset / "a.h5")
    export(dataclasses.replace(rec, reference=None, reference_t_us=None), tmp_path / "noref", "ijrr")
    export(dataclasses.replace(rec, reference=None, reference_t_us=None, frames=None, frame_t_start_us=None,
                               frame_t_mid_us=None, frame_t_end_us=None), tmp_path / "noframes", "ijrr")
    paths = {"missing": tmp_path / "missing.h5", "a": dataset / "a.h5", "out": tmp_path / "o",
             "ijrr_noref": tmp_path / "noref", "ijrr_noframes": tmp_path / "noframes"}
    assert main([a.format(**paths) for a in argv]) == 2
    err = capsys.readouterr().err
    assert message in err
    assert not (tmp_path / "o").exists()


def test_tune_searches_on_the_tuning_split_and_scores_on_the_rest(dataset, tmp_path, capsys):
    from evsim_eval.evaluate import split_times
    from evsim_eval.protocols import recording_case

    result, notes, tuning, _ = evaluate_dataset(dataset, methods=("cf", "frames"), metrics=("mse01", "ssim01"),
                                                tune=True, progress=False)
    assert set(tuning) == {"cf", "frames"} and tuning["frames"] == {}
    assert any("first 33%" in n for n in notes) and any(n.startswith("tuned cf: alpha=") for n in notes)
    assert any("(mean log_rmse)" in n for n in notes)  # against an HDR reference the tuning minimises log_rmse
    cases = {name: recording_case(load(dataset / f"{name}.h5"))[0] for name in ("a", "b")}
    for case in cases.values():  # the scores are those of the chosen setting on the held-back part only
        tune_sel, score_sel = split_times(case.times.size, 1 / 3)
        assert tune_sel.size and score_sel.size and tune_sel[-1] < score_sel[0]
    for name, case in cases.items():
        score_sel = split_times(case.times.size, 1 / 3)[1]
        direct = case.scores(case.run("cf", score_sel, tuning["cf"]), score_sel, ("mse01",))
        assert result["cf"][name]["mse01"] == pytest.approx(direct["mse01"], rel=1e-12)

    def tuning_objective(setting):  # the tuned setting is no worse than the defaults on the tuning split
        sels = [split_times(case.times.size, 1 / 3)[0] for case in cases.values()]
        return np.mean([c.scores(c.run("cf", sel, setting), sel, ("log_rmse",))["log_rmse"]
                        for c, sel in zip(cases.values(), sels)])
    assert tuning_objective(tuning["cf"]) <= tuning_objective({"alpha": 2 * np.pi * 0.5, "contrast_scale": 1.0})
    out = tmp_path / "t.json"
    assert main(["evaluate", str(dataset), "--methods", "cf", "--metrics", "mse01", "--tune", "--no-progress",
                 "--json", str(out)]) == 0
    assert json.loads(out.read_text())["tuning"]["cf"] == pytest.approx(tuning["cf"])
    assert "tuned cf: alpha=" in capsys.readouterr().out
    assert main(["evaluate", str(dataset), "--tune", "--tune-fraction", "1.5"]) == 2
