"""A wheel installed outside the repository works: suites, rod cases, meshes and committed caches ship inside it.

Builds the wheel from a copy of the source tree, installs it (no dependencies) into a fresh virtual
environment that sees this environment's third-party packages through a .pth file, and runs the CLI from an
unrelated folder. About 25 s on the project machine, so it stays in the default suite.
"""

import shutil
import site
import subprocess
import sys
from pathlib import Path

from entangle_bench.suite import SHORT_SEQUENCE

ROOT = Path(__file__).resolve().parents[1]
NOT_SOURCE = shutil.ignore_patterns(".git", ".venv", "build", "results", "*.egg-info", "__pycache__", ".*_cache",
                                    ".hypothesis")


def _run(args, cwd, **kwargs):
    done = subprocess.run(args, cwd=cwd, capture_output=True, text=True, timeout=300, **kwargs)
    assert done.returncode == 0, f"{args}: {done.stdout[-1500:]}\n{done.stderr[-3000:]}"
    return done.stdout


def test_wheel_installed_outside_the_repository_runs_tasks_objects_and_a_trial(tmp_path):
    source = tmp_path / "source"
    shutil.copytree(ROOT, source, symlinks=True, ignore=NOT_SOURCE)
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w", tmp_path / "dist",
          source], tmp_path)
    (wheel,) = (tmp_path / "dist").glob("entangle_bench-*.whl")
    venv = tmp_path / "venv"
    _run([sys.executable, "-m", "venv", "--without-pip", venv], tmp_path)
    (target,) = (venv / "lib").glob("python3*/site-packages")
    # Dependencies come from this environment; a plain .pth path entry does not run its editable-install hook.
    (target / "dependencies.pth").write_text("\n".join(site.getsitepackages()) + "\n")
    _run([sys.executable, "-m", "pip", "--python", venv / "bin" / "python", "install", "--no-deps", "-q", wheel],
         tmp_path)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = {"PATH": f"{venv / 'bin'}:/usr/bin:/bin", "HOME": str(tmp_path), "XDG_CACHE_HOME": str(tmp_path / "xdg")}
    where = _run([venv / "bin" / "python", "-c", "import entangle_bench; print(entangle_bench.__file__)"],
                 elsewhere, env=env)
    assert where.startswith(str(target))
    assert "default" in _run(["entangle-bench", "tasks"], elsewhere, env=env)
    listing = _run(["entangle-bench", "objects", "list"], elsewhere, env=env)
    assert "dexnet_pawn" in listing
    assert not (tmp_path / "xdg" / "entangle-bench").exists(), "a committed decomposition missed"
    settings = [arg for item in SHORT_SEQUENCE for arg in ("--set", item)]
    _run(["entangle-bench", "run", "sphere", "--trials", "1", "--workers", "1", "--preset", "fast",
          "--no-progress", "--out", tmp_path / "out", *settings], elsewhere, env=env)
    assert (tmp_path / "out" / "trials.parquet").is_file() and (tmp_path / "out" / "summary.csv").is_file()
