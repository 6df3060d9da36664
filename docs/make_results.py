"""Regenerate the results pages of the documentation (docs/results/*.md) from the benchmarks and `evsim evaluate`.

    python docs/make_results.py [--out docs/results] [--quick] [--keep FOLDER]

Runs, each in a fresh process with this checkout's packages first on the path:
- bench/bench_dvs.py, bench/bench_akf.py and bench/bench_generate.py at sizes that take minutes, with --json;
- the built-in AHDR suite (generators.generate_ahdr_suite: the four scikit-image photos, without the optional HDR
  photos, so that every machine makes the same suite), then `evsim evaluate` on it twice, untuned (every method at
  its defaults) and with --tune (each method's parameters searched on the first third of every sequence's scored
  frames, all scored on the rest), both with --json;
and writes results/index.md, results/benchmarks.md and results/evaluation.md: tables with the machine (CPU model,
cores), the date and the git commit printed beside them. --quick runs everything smaller (a check of this script,
not figures to publish). The docs build reads the committed pages; it does not run this script.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
METHODS = ("akf", "aks", "cf", "cf_adaptive", "frames")
METHOD_NAMES = {"akf": "AKF", "aks": "AKS (smoother)", "cf": "CF", "cf_adaptive": "CF adaptive",
                "frames": "frames only"}
LOWER_IS_BETTER = {"mse01", "mse", "log_mse"}


def run(cmd: list[str], what: str) -> str:
    """Run cmd from the repository root with this checkout's packages first on the path; return its stdout."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]).rstrip(":")}
    print(f"[make_results] {what}: {' '.join(cmd)}", flush=True)
    t0 = time.perf_counter()
    r = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{what} failed ({r.returncode}):\n{r.stdout}\n{r.stderr}")
    print(f"[make_results]   done in {time.perf_counter() - t0:.0f} s", flush=True)
    return r.stdout


def machine() -> dict:
    """CPU model, cores, memory, OS, Python and library versions, date and git commit."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem_gb = None
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal:"):
                mem_gb = int(line.split()[1]) / 2**20
    except OSError:
        pass
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()

    def git(*args: str) -> str:
        try:
            return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, check=True).stdout.strip()
        except (OSError, subprocess.CalledProcessError):
            return ""

    commit = git("rev-parse", "HEAD") or "unknown"
    dirty = bool(git("status", "--porcelain", "--untracked-files=no"))
    import numba
    import numpy

    return {"cpu": cpu, "logical_cores": os.cpu_count(), "usable_cores": usable, "memory_gb": mem_gb,
            "os": platform.platform(), "python": platform.python_version(), "numpy": numpy.__version__,
            "numba": numba.__version__, "date": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC"),
            "commit": commit, "dirty": dirty, "load_average": os.getloadavg() if hasattr(os, "getloadavg") else None}


def machine_block(m: dict, extra: str = "") -> list[str]:
    mem = f", {m['memory_gb']:.0f} GB of memory" if m["memory_gb"] else ""
    dirty = " (with uncommitted changes)" if m["dirty"] else ""
    load = (f"; load average {m['load_average'][0]:.1f} when the script started" if m.get("load_average") else "")
    return [":::{admonition} Measured on", ":class: note", "",
            f"- machine: {m['cpu']}, {m['logical_cores']} logical cores ({m['usable_cores']} usable){mem}",
            f"- software: {m['os']}, Python {m['python']}, numpy {m['numpy']}, numba {m['numba']}",
            f"- date: {m['date']}{load}",
            f"- code: git commit `{m['commit']}`{dirty}",
            *([f"- {extra}"] if extra else []), ":::", ""]


def fmt(v: float, digits: int = 4) -> str:
    if isinstance(v, str):
        return v
    return f"{v:#.{digits}g}"


# ----- benchmarks --------------------------------------------------------------------------------------------------

def benchmarks(tmp: Path, quick: bool) -> dict:
    py = sys.executable
    # the scripts' defaults (346x260 and 1280x720 DVS input, 10 M AKF events, a 1 s sequence and 2 s / 8 s memory
    # runs: a few minutes in all), or small sizes with --quick
    dvs_args = ["--frames", "100", "--frames-hd", "10"] if quick else []
    akf_args = ["--rate", "1e6", "--repeat", "1"] if quick else []
    gen_args = ["--duration-s", "0.2", "--skip-memory"] if quick else []
    out = {}
    for name, args in (("bench_dvs", dvs_args), ("bench_akf", akf_args), ("bench_generate", gen_args)):
        path = tmp / f"{name}.json"
        cmd = [py, f"bench/{name}.py", *args, "--json", str(path)]
        run(cmd, name)
        out[name] = {"command": " ".join(["python", f"bench/{name}.py", *args]), **json.loads(path.read_text())}
    return out


def benchmarks_page(b: dict, m: dict) -> str:
    lines = ["# Benchmarks", "", "Throughput and memory of the three stages a user waits for: the DVS emulator, "
             "the reconstruction filters and the generation of a whole sequence. Wall-clock figures depend on the "
             "machine and on whatever else runs on it; CPU-time figures (the work, summed over threads) are the "
             "steadier ones to compare between machines. Every table below comes from one run of "
             "`python docs/make_results.py` on the machine described here.", "", *machine_block(m)]
    d = b["bench_dvs"]
    lines += ["## DVS emulator", "",
              "A periodic log-normal HDR texture (contrast above 1000:1) translating 0.2 pixels per frame at 1000 "
              "frames per second through the `davis346` preset (noise, mismatch, refractory period, photoreceptor "
              "filter). Beside it, a bare one-thread numba kernel of the ESIM rule (events at every threshold "
              "crossing of the interpolated log intensity, nothing else) fed the same frames in the same loop: "
              "the ratio is the emulator's speed relative to that yardstick on the same machine.", "",
              f"Command: `{d['command']}`", "",
              "| sensor size | frames | events per frame | M pixel-frames/s (wall) | M events/s (wall) "
              "| M pixel-frames per CPU-second | speed vs bare ESIM kernel (wall / CPU) | peak traced memory (MiB) |",
              "|---|---|---|---|---|---|---|---|"]
    for r in d["runs"]:
        lines.append(f"| {r['size']} | {r['frames']} | {r['events_per_frame']:,.0f} | "
                     f"{r['pixel_frames_per_s'] / 1e6:.1f} | {r['events_per_s'] / 1e6:.2f} | "
                     f"{r['pixel_frames_per_cpu_s'] / 1e6:.1f} | {r['speed_vs_bare_wall']:.2f}x / "
                     f"{r['speed_vs_bare_cpu']:.2f}x | {r['peak_traced_mib']:.0f} |")
    a = b["bench_akf"]
    lines += ["", "## Reconstruction filters", "",
              f"{a['events']:,} synthetic events over {a['seconds']:g} s at {a['size']} (random walkers, random "
              f"polarity), {a['frames']} frames through the AHDR window CRF, {a['published']} images published; "
              f"{a['threads']} numba thread(s); best of {a['repeat']} timed runs after a warm-up that compiles "
              "the kernels.", "", f"Command: `{a['command']}`", "",
              "| method | M events/s (wall) | M events per CPU-second | wall time (s) | peak traced memory (MiB) |",
              "|---|---|---|---|---|"]
    for name, r in a["methods"].items():
        lines.append(f"| {name} | {r['events_per_s'] / 1e6:.2f} | {r['events_per_cpu_s'] / 1e6:.2f} | "
                     f"{r['wall_s']:.3f} | {r['peak_traced_mib']:.1f} |")
    g = b["bench_generate"]
    w = g["work"]
    c, wl = w["stages_cpu_s"], w["stages_wall_s"]
    lines += ["", "## Generating a sequence", "",
              f"`generate_ahdr` of the built-in `{g['scene']}` sequence at {w['size']}, {w['duration_s']:g} s, 30 "
              f"frames per second, `davis346` sensor, compression {g['compression']}: {w['n_events']:,} events, "
              f"{w['n_frames']} frames, {w['n_dvs_samples']:,} DVS input samples, a {w['file_mb']:.1f} MB file. "
              "Work is CPU time (all threads) of the call in a process whose imports and numba kernels are "
              "already loaded. The scene is rendered on a thread of its own while the DVS runs: its row is the time "
              "the DVS waited for it (and the camera's rendering), the DVS's row includes the scene's work beside "
              "it.", "", f"Command: `{g['command']}`", "",
              "| stage | CPU-s | share | wall (s) |", "|---|---|---|---|"]
    stages = ("scene", "dvs", "camera", "writing")
    for k in stages:
        lines.append(f"| {k} | {c[k]:.3f} | {100 * c[k] / c['total']:.0f} % | {wl[k]:.3f} |")
    other_c, other_w = c["total"] - sum(c[k] for k in stages), wl["total"] - sum(wl[k] for k in stages)
    lines += [f"| other (setup) | {other_c:.3f} | {100 * other_c / c['total']:.0f} % | {other_w:.3f} |",
              f"| **total** | **{w['cpu_s']:.3f}** | | **{w['wall_s']:.3f}** |", "",
              f"{w['duration_s'] / w['cpu_s']:.2f} s of sequence per CPU-second of work "
              f"({w['n_frames'] / w['cpu_s']:.1f} frames per CPU-second).", ""]
    if g.get("memory"):
        lines += ["Peak resident memory of a whole generation process (a fresh process each) against the sequence "
                  "length: generation streams the sequence to disk, so memory does not grow with the duration.", "",
                  "| duration (s) | events | file (MB) | peak RSS (MB) |", "|---|---|---|---|"]
        for r in g["memory"]:
            lines.append(f"| {r['duration_s']:g} | {r['n_events']:,} | {r['file_mb']:.0f} | {r['peak_rss_mb']:.0f} |")
        lines.append("")
    return "\n".join(lines)


# ----- evaluation --------------------------------------------------------------------------------------------------

def evaluation(tmp: Path, quick: bool) -> dict:
    py = sys.executable
    size = dict(height=60, width=80, duration_s=0.4) if quick else dict(height=180, width=240, duration_s=1.0)
    suite = tmp / "ahdr_suite"
    run([py, "-c", "from generators import generate_ahdr_suite; "
                   f"generate_ahdr_suite({str(suite)!r}, include_hdr=False, seed=0, height={size['height']}, "
                   f"width={size['width']}, duration_s={size['duration_s']})"], "the built-in AHDR suite")
    out = {"size": size}
    methods = ",".join(METHODS)
    # the page's tables lead with the paper's mse01 / ssim01, so the tuning minimises mse01 (the reference
    # protocol's default tuning metric is log_rmse)
    for label, extra in (("untuned", []), ("tuned", ["--tune", "--tune-metric", "mse01"])):
        path = tmp / f"{label}.json"
        cmd = [py, "-m", "evsim_app", "evaluate", str(suite), "--methods", methods, "--no-progress", *extra,
               "--json", str(path)]
        c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        stdout = run(cmd, f"evsim evaluate ({label})")
        c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        out[label] = {"command": " ".join(["evsim evaluate ahdr_suite --methods", methods, *extra]),
                      "scores": json.loads(path.read_text()), "stdout": stdout,
                      "cpu_s": c1.ru_utime + c1.ru_stime - c0.ru_utime - c0.ru_stime}
    return out


def _table(scores: dict, metrics: tuple[str, ...]) -> list[str]:
    """Per-sequence rows of metric pairs, a column per method, the best of each metric in bold."""
    seqs = [s for s in scores[METHODS[0]] if s != "mean"] + ["mean"]
    head = "| sequence | " + " | ".join(f"{METHOD_NAMES[m]} {' / '.join(metrics)}" for m in METHODS) + " |"
    lines = [head, "|---" * (len(METHODS) + 1) + "|"]
    for s in seqs:
        cells = []
        for m in METHODS:
            parts = []
            for k in metrics:
                vals = [scores[mm][s][k] for mm in METHODS]
                best = min(vals) if k in LOWER_IS_BETTER else max(vals)
                v = scores[m][s][k]
                parts.append(f"**{fmt(v)}**" if v == best else fmt(v))
            cells.append(" / ".join(parts))
        lines.append(f"| {'**mean**' if s == 'mean' else s} | " + " | ".join(cells) + " |")
    return lines


def _mean_table(scores: dict, metrics: tuple[str, ...]) -> list[str]:
    lines = ["| mean | " + " | ".join(METHOD_NAMES[m] for m in METHODS) + " |", "|---" * (len(METHODS) + 1) + "|"]
    for k in metrics:
        vals = [scores[m]["mean"][k] for m in METHODS]
        best = min(vals) if k in LOWER_IS_BETTER else max(vals)
        lines.append(f"| {k} | " + " | ".join(f"**{fmt(v)}**" if v == best else fmt(v) for v in vals) + " |")
    return lines


#: the per-class rows of the results pages (evsim_eval.pixel_classes), in this order, with a short label
CLASS_ROWS = {"well": "well-exposed in the nearest frames", "high": "clipped high in a nearest frame",
              "low": "clipped low in a nearest frame", "flat": "flat truth", "textured": "textured truth",
              "at_frames": "times inside a frame's exposure", "between": "times between frames"}


def _class_table(scores: dict, metrics: tuple[str, ...] = ("mse01", "ssim01")) -> list[str]:
    """Mean over the sequences of each class's scores (rows: classes with pixels; the mean share of the scored
    pixels beside the class), a column per method, the best of each metric in bold."""
    mean = {m: scores[m]["mean"] for m in METHODS}
    rows = [c for c in CLASS_ROWS if (mean[METHODS[0]].get(f"share@{c}") or 0) > 0]
    if not rows:
        return []
    head = "| pixel class (share) | " + " | ".join(f"{METHOD_NAMES[m]} {' / '.join(metrics)}" for m in METHODS) + " |"
    lines = [head, "|---" * (len(METHODS) + 1) + "|"]
    for c in rows:
        cells = []
        for m in METHODS:
            parts = []
            for k in metrics:
                vals = [mean[mm][f"{k}@{c}"] for mm in METHODS]
                best = min(vals) if k in LOWER_IS_BETTER else max(vals)
                v = mean[m][f"{k}@{c}"]
                parts.append(f"**{fmt(v)}**" if v == best else fmt(v))
            cells.append(" / ".join(parts))
        lines.append(f"| {CLASS_ROWS[c]} ({100 * mean[METHODS[0]][f'share@{c}']:.0f} %) | " + " | ".join(cells) + " |")
    return lines


def _losses(scores: dict, metrics: tuple[str, ...] = ("mse01", "ssim01")) -> list[str]:
    """Where the AKF is not the best: every sequence, and every class with pixels (mean over the sequences)."""
    places = [(s, s, "") for s in scores["akf"] if s != "mean"]
    shares = scores["akf"]["mean"]
    places += [(f"class {c}", "mean", f"@{c}") for c in CLASS_ROWS if (shares.get(f"share@{c}") or 0) > 0]
    out = []
    for k in metrics:
        pick = min if k in LOWER_IS_BETTER else max
        for label, row, suffix in places:
            vals = {m: scores[m][row][k + suffix] for m in METHODS}
            best = pick(vals, key=vals.get)
            if best != "akf":
                out.append(f"- {label}, `{k}`: AKF {fmt(vals['akf'])}, {METHOD_NAMES[best]} {fmt(vals[best])}")
    return out


def _notes(stdout: str) -> list[str]:
    """The notes `evsim evaluate` prints on the assumptions it made (the tuned settings are listed apart)."""
    lines = [x.strip() for x in stdout.splitlines()]
    return [x for x in lines if x.startswith("note:") and not x.startswith("note: tuned ")]


def evaluation_page(e: dict, m: dict) -> str:
    size = e["size"]
    lines = ["# Evaluation", "",
             "HDR reconstruction on the built-in AHDR suite: four scikit-image photos made HDR, moved under a "
             "camera pan, zoom or rotation and seen by a noisy DAVIS346-like event sensor and an LDR camera behind "
             "the AKF paper's window CRF, which clips most of each frame. Every method reconstructs the HDR "
             "reference frames' times; the scores are the paper's protocol (`mse01`, `ssim01`: both images "
             "mapped to [0, 1] by a white the methods can reach, min(scene white, the full well)) and HDR-aware "
             "metrics on absolute values (`mse`, "
             "`log_mse`, PU21-SSIM); the model reference describes each metric and protocol.", "",
             f"The suite: `generate_ahdr_suite('ahdr_suite', include_hdr=False)` at {size['height']}x"
             f"{size['width']} pixels, {size['duration_s']:g} s per sequence, seed 0. Methods: the AKF, the "
             "complementary filter (CF) with a fixed and with the adaptive crossover gain, and the frames alone "
             "(the inverse CRF of the nearest frame). The best value of each metric is in bold.", "",
             *machine_block(m)]
    from evsim_eval import NORMALISATION

    lines += ["How each metric normalises its inputs (as `evsim evaluate` prints it):", ""]
    lines += [f"- `{k}`: {NORMALISATION[k]}" for k in ("mse01", "ssim01", "mse", "log_mse", "pu21_ssim")] + [""]
    for label, title, text in (
            ("untuned", "Untuned: every method at its defaults",
             "What `evsim evaluate` prints out of the box: every method with its default parameters, scored on "
             "every reference frame."),
            ("tuned", "Tuned: each method's parameters searched on held-out frames",
             "With `--tune`: for each method, one coordinate search over its main parameters (contrast scale; "
             "CF gain; AKF and smoother event and frame noise scales and output smoothing; the smoother's drift and "
             "clip-prior variance; the output bound) picks the setting of least mean "
             "`mse01` on the first third of every sequence's scored frames, starting from the defaults; every "
             "method is then scored on the remaining two thirds, so these numbers are not comparable frame for "
             "frame with the untuned ones.")):
        r = e[label]
        scores = {k: v for k, v in r["scores"].items() if k not in ("tuning", "scoring")}
        lines += [f"## {title}", "", text, "",
                  f"Command: `{r['command']}` ({r['cpu_s']:.0f} CPU-seconds on this machine).", "",
                  *_table(scores, ("mse01", "ssim01")), "", *_mean_table(scores, ("mse", "log_mse", "pu21_ssim")), ""]
        classes = _class_table(scores)
        if classes:
            lines += ["Per pixel class (`mse01` / `ssim01` of the class's pixels pooled over each sequence's scored "
                      "times, then averaged over the sequences; `evsim_eval.pixel_classes`): where each method "
                      "wins.", "",
                      *classes, ""]
        losses = _losses(scores)
        lines += (["Where the AKF is not the best:", "", *losses, ""] if losses
                  else ["The AKF is the best on every sequence and every class of `mse01` and `ssim01`.", ""])
        if label == "tuned" and r["scores"].get("tuning"):
            from evsim_eval.tuning import describe_setting

            lines += ["Settings the tuning chose:", ""]
            lines += [f"- {METHOD_NAMES.get(k, k)}: {describe_setting(v)}" for k, v in r["scores"]["tuning"].items()]
            lines.append("")
        notes = _notes(r["stdout"])
        if notes:
            lines += ["What `evsim evaluate` said about the data:", "", "```text", *notes, "```", ""]
    return "\n".join(lines)


def index_page(m: dict, quick: bool) -> str:
    return "\n".join([
        "# Results", "",
        "Measured figures of this version: the speed of the simulator and the filters, and the reconstruction "
        "scores on the built-in AHDR suite, untuned and tuned. All of them are written by one command from the "
        "repository root,", "", "```bash", "python docs/make_results.py", "```", "",
        "which runs the benchmark scripts in `bench/` and `evsim evaluate` and writes these pages; the figures "
        "on another machine will differ (the scores only by floating-point details, the timings by the "
        "machine).", "", *machine_block(m, "a quick run with small sizes: not figures to quote" if quick else ""),
        "```{toctree}", ":maxdepth: 1", "", "benchmarks", "evaluation", "lab", "```", ""])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "results", help="folder of the pages")
    ap.add_argument("--quick", action="store_true", help="small sizes: checks the script in a minute or two")
    ap.add_argument("--keep", type=Path, help="keep the JSON results and the suite in this folder")
    args = ap.parse_args()
    sys.path.insert(0, str(ROOT))
    m = machine()
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = args.keep or Path(tmp)
        tmp.mkdir(parents=True, exist_ok=True)
        b = benchmarks(tmp, args.quick)
        e = evaluation(tmp, args.quick)
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "benchmarks.md").write_text(benchmarks_page(b, m))
        (args.out / "evaluation.md").write_text(evaluation_page(e, m))
        (args.out / "index.md").write_text(index_page(m, args.quick))
    print(f"[make_results] wrote {args.out}/index.md, benchmarks.md, evaluation.md in "
          f"{time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
