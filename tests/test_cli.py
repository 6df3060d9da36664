import json
import subprocess
import sys

import pytest

from evsim_app.cli import main
from evsim_eval.choices import DEFAULT_METRICS
from generators import load

SMALL = ["--duration-s", "0.05", "--height", "8", "--width", "10", "--no-progress"]


def test_demo_generates_and_reports(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--duration-s", "0.3", "--height", "24", "--width", "32",
                 "--no-progress"]) == 0
    text = capsys.readouterr().out
    rec = load(out / "demo.h5")
    assert rec.events.size > 0 and rec.frames.shape[1:] == (24, 32)
    assert f"{rec.events.size} (ON" in text and str(out / "demo.h5") in text
    table = (out / "metrics.txt").read_text()
    assert table.splitlines()[0].split() == ["method", *DEFAULT_METRICS["reference"]]
    assert {line.split()[0] for line in table.splitlines()[1:]} == {"akf", "aks", "cf", "frames"}
    assert table in text


def test_generate_refuses_to_overwrite_without_the_flag(tmp_path, capsys):
    args = ["generate", "ahdr", "--scene", "moving_edge", "--sensor", "ideal", "--out", str(tmp_path / "d"), *SMALL]
    assert main(args) == 0
    index = json.loads((tmp_path / "d" / "index.json").read_text())
    assert [s["name"] for s in index["sequences"]] == ["moving_edge"]
    rec = load(tmp_path / "d" / "moving_edge.h5")
    assert rec.metadata["config"]["dvs"]["threshold_sigma"] == 0  # the ideal preset
    before = (tmp_path / "d" / "moving_edge.h5").read_bytes()
    capsys.readouterr()
    assert main(args + ["--seed", "3"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("evsim: error:") and "--overwrite" in err and "Traceback" not in err
    assert (tmp_path / "d" / "moving_edge.h5").read_bytes() == before
    assert main(args + ["--seed", "3", "--overwrite", "--format", "e2vid"]) == 0
    assert load(tmp_path / "d" / "moving_edge.h5").metadata["seed"]["entropy"] == 3
    assert (tmp_path / "d" / "moving_edge_e2vid.h5").is_file()


def test_info_prints_a_summary_and_rejects_bad_files(tmp_path, capsys):
    assert main(["generate", "ahdr", "--scene", "sun", "--out", str(tmp_path / "d"), *SMALL]) == 0
    capsys.readouterr()
    assert main(["info", str(tmp_path / "d" / "sun.h5")]) == 0
    text = capsys.readouterr().out
    n = load(tmp_path / "d" / "sun.h5").events.size
    assert str(n) in text and "window" in text
    (tmp_path / "junk.h5").write_bytes(b"not hdf5 at all")
    assert main(["info", str(tmp_path / "junk.h5")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("evsim: error:") and "junk.h5" in err


def test_bad_config_key_exits_2_naming_the_key(tmp_path, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text("[[sequence]]\nscene = { type = 'moving_edge', speed_px_per_s = 5.0 }\nduraton_s = 1\n")
    assert main(["generate", "ahdr", "--config", str(cfg), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("evsim: error:") and "sequence[0].duraton_s" in err and "Traceback" not in err
    assert not (tmp_path / "o").exists()
    assert main(["generate", "ahdr", "--config", str(cfg), "--scene", "sun", "--out", str(tmp_path / "o")]) == 2
    assert "--scene cannot be combined with --config" in capsys.readouterr().err
    assert main(["generate", "ahdr", "--seed", "-1"]) == 2  # argparse usage error
    assert "non-negative" in capsys.readouterr().err


def test_sweep_from_config_with_grid_flags(tmp_path):
    cfg = tmp_path / "s.toml"
    cfg.write_text("seed = 4\n[defaults]\nduration_s = 0.04\nheight = 6\nwidth = 8\n"
                   "[[sequence]]\nname = 'edge'\nscene = { type = 'moving_edge', speed_px_per_s = 40.0 }\n"
                   "[sweep]\nthreshold_sigma = [0.0, 0.05]\nleak_hz = [0.0]\n")
    assert main(["generate", "sweep", "--config", str(cfg), "--leak-hz", "0", "2", "--out", str(tmp_path / "sw"),
                 "--no-progress"]) == 0
    index = json.loads((tmp_path / "sw" / "index.json").read_text())
    assert index["grid"] == {"threshold_sigma": [0.0, 0.05], "leak_hz": [0.0, 2.0]}
    points = [e["sweep_point"] for e in index["sequences"]]
    assert len(points) == 4 and points[-1] == {"threshold_sigma": 0.05, "leak_hz": 2.0}
    for e in index["sequences"]:
        dvs = load(tmp_path / "sw" / e["file"]).metadata["config"]["dvs"]
        assert dvs["leak_hz"] == e["sweep_point"]["leak_hz"]


def test_sweep_grid_flags_alone_are_the_grid(tmp_path):
    # without a configuration, --shot-noise-hz alone sweeps the shot noise only (the default grid is not mixed in)
    out = tmp_path / "sw"
    assert main(["generate", "sweep", "--scene", "moving_edge", "--sensor", "ideal", "--shot-noise-hz", "0", "5",
                 "--out", str(out), *SMALL]) == 0
    index = json.loads((out / "index.json").read_text())
    assert index["grid"] == {"shot_noise_hz": [0.0, 5.0]}
    shot = [load(out / e["file"]).metadata["config"]["dvs"]["shot_noise_hz"] for e in index["sequences"]]
    assert shot == [0.0, 5.0]


def test_unexpected_errors_exit_1(monkeypatch, tmp_path, capsys):
    import generators.dataset

    def boom(*a, **k):
        raise RuntimeError("boom")

    monkeypatch.setattr(generators.dataset, "generate_dataset", boom)
    assert main(["generate", "ahdr", "--scene", "sun", "--out", str(tmp_path / "x"), *SMALL]) == 1
    err = capsys.readouterr().err
    assert "RuntimeError: boom" in err and "unexpected error" in err


def test_ctrl_c_wrapped_by_an_import_is_an_interruption_not_a_bug(monkeypatch, tmp_path, capsys):
    """A signal that lands while a C extension is being imported (OpenEXR's, on the first write of an EXR file)
    comes out as "ImportError: initialization failed" caused by the handler's exception (tests/test_kill_outputs.py
    met it with SIGTERM): the command is interrupted (130, 143 for SIGTERM), not an unexpected error (1)."""
    import generators.dataset

    def interrupted_import(*a, **k):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as e:
            raise ImportError("initialization failed") from e

    monkeypatch.setattr(generators.dataset, "generate_dataset", interrupted_import)
    assert main(["generate", "ahdr", "--scene", "sun", "--out", str(tmp_path / "x"), *SMALL]) == 130
    err = capsys.readouterr().err
    assert "evsim: interrupted" in err and "unexpected error" not in err and "Traceback" not in err


@pytest.mark.slow  # a subprocess
def test_console_entry_point_help_documents_units():
    out = subprocess.run([sys.executable, "-m", "evsim_app.cli", "generate", "ahdr", "--help"],
                         capture_output=True, text=True, check=True).stdout
    for unit in ("seconds", "pixels", "microseconds", "frames per second", "pixels per second", "Hz"):
        assert unit in out


def test_denoise_evaluation_refuses_workers(tmp_path, capsys):
    # checked before the dataset is read: the denoising task runs in this process
    assert main(["evaluate", str(tmp_path), "--task", "denoise", "--workers", "2"]) == 2
    assert "drop --workers/--scheduler" in capsys.readouterr().err
