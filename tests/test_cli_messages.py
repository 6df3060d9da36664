"""Messages a person understands: suggestions for mistyped flags, subcommands, keys and fields (with the allowed
names), each interface naming only its own options, interrupted runs saying how to resume and leaving no empty
folder, progress in frames and events per second."""

import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import generators.dataset
import sim
from evsim_app.cli import main
from generators.builtin_sequences import BUILTIN_SEQUENCES
from generators.config import parse_config
from generators.dataset import generate_dataset
from generators.runner import TaskOutcome, TasksFailed, raise_failures

SMALL = ["--duration-s", "0.05", "--height", "8", "--width", "10", "--no-progress"]
ROOT = Path(__file__).resolve().parents[1]


def _error(capsys, args) -> str:
    assert main(args) == 2
    return capsys.readouterr().err


@pytest.mark.parametrize("args, hint", [
    (["genrate", "ahdr"], "invalid choice: 'genrate' (choose from 'demo', 'generate', 'convert', 'info', "),
    (["genrate", "ahdr"], "(did you mean 'generate'?)"),
    (["generate", "ahd"], "(did you mean 'ahdr'?)"),
    (["generate", "ahdr", "--overwite"], "unrecognized arguments: --overwite ('--overwite': did you mean "
                                         "'--overwrite'?)"),
    (["convert", "x.mp4", "--camra", "fps=3"], "'--camra': did you mean '--camera'?"),
    (["convert", "x.mp4", "--upsample", "flwo"], "(did you mean 'flow'?)"),
    (["demo", "--pos-threshold", "0.3"], "'--pos-threshold': did you mean '--dvs pos_threshold=VALUE'?"),
    (["generate", "ahdr", "--pos_thres", "0.3", "--dvs346"],  # v2e's flags
     "'--pos_thres': did you mean '--dvs pos_threshold=VALUE'?; '--dvs346': did you mean '--sensor-size davis346'?"),
    (["convert", "x.mp4", "--shot-noise", "2"], "'--shot-noise': did you mean '--dvs shot_noise_hz=VALUE'?"),
])
def test_mistyped_flags_and_subcommands_get_a_suggestion(capsys, args, hint):
    err = _error(capsys, args)
    assert hint in err, err


def test_an_unrecognised_flag_shows_the_usage_of_the_subcommand_typed(capsys):
    err = _error(capsys, ["generate", "ahdr", "--overwite"])
    assert err.startswith("usage: evsim generate ahdr [-h]"), err
    assert "evsim generate ahdr: error: unrecognized arguments: --overwite" in err
    assert _error(capsys, ["--bogus"]).startswith("usage: evsim [-h]")  # no subcommand: the top-level usage


def test_a_subcommands_flags_are_suggested_only_when_it_is_the_one_typed(capsys):
    err = _error(capsys, ["info", "f.h5", "--overwite"])  # info has no --overwrite: no suggestion of another's
    assert "unrecognized arguments: --overwite" in err and "did you mean" not in err


@pytest.mark.parametrize("args, says", [
    (["--dvs", "pos_threshhold=0.2"], r"--dvs pos_threshhold: unknown DVS field 'pos_threshhold' \(did you mean "
                                      r"'pos_threshold'\?\); allowed: pos_threshold, neg_threshold, threshold_sigma"),
    (["--camera", "read_noise=2"], r"--camera read_noise: unknown camera field 'read_noise' \(did you mean "
                                   r"'read_noise_e'\?\); allowed: fps, first_frame_us"),
    (["--dvs", "pos_threshold"], r"--dvs 'pos_threshold': expected FIELD=VALUE \(e.g. --dvs pos_threshold=0.25\)"),
    (["--sensor", "davis364"], r"--sensor: unknown sensor 'davis364' \(did you mean 'davis346'\?\): a sensor is a "
                               r"preset \(ideal, davis346, davis346_road, noisy\) or a sensor file \(.toml\)"),
    (["--sensor-size", "davis364"], r"--sensor-size: unknown sensor size 'davis364' \(did you mean 'davis346'\?\); "
                                    r"allowed: dvs128, davis240, davis346"),
    (["--fps", "20", "--camera", "fps=30"], r"--fps and --camera fps=\.\.\. both set fps: give one"),
])
def test_unknown_model_names_on_the_command_line_list_the_allowed_ones(capsys, tmp_path, args, says):
    err = _error(capsys, ["generate", "ahdr", "--scene", "moving_edge", *args, "--out", str(tmp_path / "o")])
    assert re.search(r"^evsim: error: " + says, err), err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("table, says", [
    ({"defaults": {"dvs": {"pos_thres": 0.2}}},
     r"defaults\.dvs\.pos_thres: unknown DVS field 'pos_thres' \(did you mean 'pos_threshold'\?\); allowed: "),
    ({"defaults": {"camera": {"exposure": 100}}},
     r"defaults\.camera\.exposure: unknown camera field 'exposure' \(did you mean 'exposure_us'\?\)"),
    ({"defualts": {}}, r"defualts: unknown key 'defualts' \(did you mean 'defaults'\?\); allowed: seed, format"),
    ({"defaults": {"sensr": "ideal"}}, r"defaults\.sensr: unknown key 'sensr' \(did you mean 'sensor'\?\)"),
    ({"defaults": {"sampling": {"quantil": 0.9}}}, r"sampling\.quantil: unknown key 'quantil' \(did you mean "
                                                   r"'quantile'\?\)"),
    ({"format": "evt4"}, r"format: unknown format 'evt4' \(did you mean 'evt3'\?\); allowed: native, "),
    ({"sweep": {"leak": [0.1]}}, r"sweep\.leak: unknown sweep parameter 'leak' \(did you mean 'leak_hz'\?\)"),
])
def test_mistyped_configuration_keys_get_a_suggestion_and_the_allowed_names(table, says):
    with pytest.raises(sim.InvalidParameterError, match=says):
        parse_config({**table, "sequence": [{"scene": {"type": "moving_edge"}}]}, source="data.toml")


def test_a_mistyped_scene_type_gets_a_suggestion():
    with pytest.raises(sim.InvalidParameterError, match=r"scene\.type: unknown scene type 'moving_egde' \(did you "
                                                        r"mean 'moving_edge'\?\); allowed: image, frames"):
        parse_config({"sequence": [{"scene": {"type": "moving_egde"}}]})


def test_an_output_folder_named_like_a_file_is_refused_before_any_work(tmp_path, capsys):
    """`convert clip.mp4 --out clip.h5` would write the folder clip.h5/ holding clip.h5: refused, nothing made."""
    for command in (["convert", str(tmp_path / "clip.mp4")], ["generate", "ahdr", "--scene", "moving_edge", *SMALL]):
        err = _error(capsys, [*command, "--out", str(tmp_path / "events.h5")])
        assert "--out " in err and "ends in .h5, a file's suffix, but names the output folder" in err, err
        assert f"--out {tmp_path / 'events'}" in err
    assert not (tmp_path / "events.h5").exists()
    (tmp_path / "old.h5").mkdir()  # an existing folder of that name is the user's choice
    assert main(["generate", "ahdr", "--scene", "moving_edge", "--out", str(tmp_path / "old.h5"), *SMALL]) == 0


def test_an_existing_output_folder_names_the_flags_on_the_command_line_and_the_keywords_in_python(tmp_path, capsys):
    out = tmp_path / "d"
    out.mkdir()
    (out / "old.txt").write_text("x")
    err = _error(capsys, ["generate", "ahdr", "--scene", "moving_edge", "--out", str(out), *SMALL])
    assert "pass --overwrite to replace its contents, or --resume to complete it" in err
    assert "=True" not in err and "overwrite=" not in err
    cfg = parse_config({"sequence": [{"scene": {"type": "moving_edge"}}]})
    with pytest.raises(sim.EvsimInputError) as api:
        generate_dataset(cfg, out, progress=False)
    assert "pass overwrite=True to replace its contents, or resume=True to complete it" in str(api.value)
    assert "--" not in str(api.value)
    err = _error(capsys, ["generate", "ahdr", "--scene", "moving_edge", "--out", str(out), "--resume", "--overwrite",
                          *SMALL])
    assert "--resume and --overwrite exclude each other" in err and "=True" not in err
    with pytest.raises(sim.EvsimInputError, match="^resume=True and overwrite=True exclude each other") as api:
        generate_dataset(cfg, out, progress=False, resume=True, overwrite=True)
    assert "--" not in str(api.value)


def test_an_option_error_in_a_sequence_reaches_the_command_line_in_flags(tmp_path, capsys):
    """The error of a task (here: a stack without frame times) crosses the task runner with both wordings."""
    import numpy as np

    from generators.convert import convert

    np.save(tmp_path / "clip.npy", np.full((3, 6, 8), 100, np.uint8))
    err = _error(capsys, ["convert", str(tmp_path / "clip.npy"), "--out", str(tmp_path / "o"), "--no-progress"])
    assert "no frame times: give --input-fps or --timestamps (a file of frame times)" in err
    with pytest.raises(sim.OptionError) as api:
        convert(tmp_path / "clip.npy", tmp_path / "o2", progress=False)
    assert "no frame times: give fps or timestamps (a file of frame times)" in str(api.value)
    assert "--" not in str(api.value)
    failures = [TaskOutcome("a", error="OptionError: x=1 is wrong", kind="input", cli_error="OptionError: --x is "
                                                                                              "wrong"),
                TaskOutcome("b", error="RuntimeError: boom", kind="bug")]
    with pytest.raises(TasksFailed) as e:
        raise_failures("sequences", failures, 3)
    assert "  a: OptionError: x=1 is wrong" in str(e.value) and "  a: OptionError: --x is wrong" in e.value.cli_message


def test_failed_sequences_name_the_resume_flag_or_keyword():
    failures = [TaskOutcome("a", error="RuntimeError: boom", kind="bug")]
    with pytest.raises(TasksFailed) as e:
        raise_failures("sequences", failures, 2, "rerun with resume=True", cli_hint="rerun with --resume")
    assert "rerun with resume=True" in str(e.value) and "--resume" not in str(e.value)
    assert "rerun with --resume" in e.value.cli_message and "=True" not in e.value.cli_message


@pytest.mark.parametrize("command", [["generate", "ahdr", "--scene", "moving_edge", *SMALL],
                                     ["demo", "--no-reconstruct", "--no-progress"]])
def test_an_interrupted_run_with_nothing_complete_says_so_and_leaves_no_empty_folder(monkeypatch, tmp_path, capsys,
                                                                                     command):
    def interrupted(*args, **kwargs):
        (tmp_path / "o" / ".moving_edge.h5.partial.tmp").unlink(missing_ok=True)  # as the writer's cleanup does
        raise KeyboardInterrupt

    monkeypatch.setattr(generators.dataset, "generate_ahdr", interrupted)
    assert main([*command, "--out", str(tmp_path / "o")]) == 130
    err = capsys.readouterr().err
    assert err.startswith("evsim: interrupted (Ctrl-C)") and "--resume" not in err
    if command[0] == "generate":
        assert "no sequence was complete, nothing was kept" in err
    assert not (tmp_path / "o").exists()
    (tmp_path / "kept").mkdir()  # a folder that was there before stays
    assert main([*command, "--out", str(tmp_path / "kept")]) == 130
    assert (tmp_path / "kept").is_dir()


@pytest.mark.slow
def test_ctrl_c_on_a_real_run_exits_130_naming_resume_with_no_empty_folder(tmp_path):
    out = tmp_path / "o"
    code = ("import signal, sys; signal.signal(signal.SIGINT, signal.default_int_handler); "  # as in a terminal
            "from evsim_app.cli import main; sys.exit(main(sys.argv[1:]))")
    proc = subprocess.Popen([sys.executable, "-c", code, "generate", "ahdr", "--scene", "astronaut_pan",
                             "--duration-s", "3", "--out", str(out), "--no-progress"], cwd=ROOT,
                            stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not any(out.glob(".*.tmp")) and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)  # the sequence's file is being written
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err[-2000:]
    assert "evsim: interrupted (Ctrl-C): no sequence was complete" in err and "Traceback" not in err
    assert not out.exists()


def test_an_interrupted_run_names_the_complete_sequences_and_how_to_resume(monkeypatch, tmp_path, capsys):
    real = generators.dataset.generate_ahdr
    calls = []

    def second_interrupted(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(generators.dataset, "generate_ahdr", second_interrupted)
    out = tmp_path / "o"
    assert main(["generate", "ahdr", *SMALL, "--out", str(out)]) == 130
    err = capsys.readouterr().err
    assert f"1 complete sequence(s) kept in {out}; run the same command with --resume to finish" in err


def test_progress_bars_count_frames_and_events_per_second(capsys):
    from generators.ahdr import generate_ahdr
    from generators.config import build_scene

    spec = next(s for s in BUILTIN_SEQUENCES if s["scene"]["type"] == "moving_edge")
    scene = build_scene(spec["scene"], 16, 20, 200_000)
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        result = generate_ahdr(scene, Path(d) / "e.h5", progress=True)
    err = capsys.readouterr().err
    assert result.n_events > 0
    assert re.search(r"events: 100%.*0\.2/0\.2 s of scene, [0-9.e+]+ frames/s, [0-9.e+]+ events/s", err), err[-500:]
    assert re.search(r"frames: .*/6 .*frame/s", err) and "us/s" not in err


@pytest.mark.parametrize("args,says", [
    (["convert", "in.mp4", "--output", "d"], "unrecognized arguments: --output d ('--output': did you mean '--out' or "
                                             "'--outputs'?)"),
    (["generate", "ahdr", "--dur", "1"], "unrecognized arguments: --dur 1"),
])
def test_abbreviated_flags_are_refused_not_expanded(capsys, args, says):
    assert main(args) == 2
    assert says in capsys.readouterr().err


@pytest.mark.parametrize("args,says", [
    (["generate", "ahdr", "--duration-s", "-1"], "argument --duration-s: must be a finite number > 0, got '-1'"),
    (["demo", "--height", "0"], "argument --height: must be a positive integer, got '0'"),
    (["convert", "in.mp4", "--camera-fps", "nan"], "argument --camera-fps: must be a finite number > 0, got 'nan'"),
])
def test_bad_numbers_are_refused_naming_the_flag(capsys, args, says):
    assert main(args) == 2
    err = capsys.readouterr().err
    assert says in err and "defaults." not in err


def test_a_clip_window_that_ends_before_it_starts_is_refused_in_flags_before_any_work(tmp_path, capsys):
    from video_clips import encode_mp4, slow_motion_frames

    clip = encode_mp4(tmp_path / "c.mp4", slow_motion_frames(6)[:, :24, :32])
    assert main(["convert", str(clip), "--out", str(tmp_path / "o"), "--start-s", "0.2", "--stop-s", "0.1"]) == 2
    out, err = capsys.readouterr()
    assert err == "evsim: error: --start-s 0.2 must come before --stop-s 0.1 (seconds from the input's first frame)\n"
    assert out == "" and not (tmp_path / "o").exists()
