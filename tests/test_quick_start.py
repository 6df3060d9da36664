"""The README's two quick-start commands, one after the other in one fresh environment, then `evsim` from another
folder: the installed copy's compiled kernels must not shadow the editable install that replaces it (numba's cache
lives in the user's cache folder, sim.numba_cache, not in site-packages where pip would leave it behind)."""

import os
import shutil
import subprocess
import sys
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _copy_sources(dst: Path) -> None:
    """The repository's tracked files (no build folders, no caches) into dst."""
    files = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout.split()
    for name in files:
        if (ROOT / name).is_file():
            (dst / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / name, dst / name)


@pytest.mark.slow
def test_quick_start_commands_in_order_then_evsim_from_another_folder(tmp_path):
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("needs a git checkout to copy the sources from")
    src, env_dir, elsewhere = tmp_path / "evsim", tmp_path / "venv", tmp_path / "elsewhere"
    src.mkdir()
    elsewhere.mkdir()
    _copy_sources(src)
    # the dependencies come from this environment; evsim itself is installed into the new one (pip builds it in
    # isolation, as the README's commands do)
    venv.EnvBuilder(system_site_packages=True, with_pip=True).create(env_dir)
    bindir = env_dir / ("Scripts" if sys.platform == "win32" else "bin")
    env = {**os.environ, "PATH": f"{bindir}{os.pathsep}{os.environ['PATH']}", "VIRTUAL_ENV": str(env_dir),
           "XDG_CACHE_HOME": str(tmp_path / "cache"), "PIP_DISABLE_PIP_VERSION_CHECK": "1"}
    env.pop("NUMBA_CACHE_DIR", None)
    env.pop("PYTHONPATH", None)
    small = ["--duration-s", "0.2", "--height", "24", "--width", "32", "--no-progress"]

    def run(cmd, cwd):
        done = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=900)
        assert done.returncode == 0, f"{' '.join(map(str, cmd))} in {cwd}:\n{done.stdout[-2000:]}\n" \
                                     f"{done.stderr[-2000:]}"
        return done

    python = str(bindir / "python")
    run([python, "-m", "pip", "install", "-q", "."], src)
    run(["evsim", "demo", "--out", str(tmp_path / "demo1"), *small], src)  # the first command: numba compiles
    installed = Path(run([python, "-c", "import sim; print(sim.__file__)"], elsewhere).stdout.strip()).parent
    assert not list(installed.rglob("*.nbi")), "numba's cache landed in site-packages"
    run([python, "-m", "pip", "install", "-q", "-e", ".[test]"], src)  # the second command's install
    assert run(["evsim", "--help"], elsewhere).stdout.startswith("usage: evsim")
    run(["evsim", "demo", "--out", str(tmp_path / "demo2"), *small], elsewhere)
    located = run([python, "-c", "import sim; print(sim.__file__)"], elsewhere).stdout.strip()
    assert Path(located).resolve().is_relative_to(src.resolve())  # the editable copy, not a leftover
