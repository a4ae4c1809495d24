"""The package installs and works under every supported Python found on this machine.

``requires-python`` admits 3.11 to 3.13 (casadi ships abi3 wheels from cp311, typst abi3
wheels, numpy/scipy wheels for each). For each of those interpreters present (on PATH or
under pyenv), a fresh virtual environment gets ``pip install`` of the repository (binary
wheels preferred), then imports the engine, the models, the problems and the report, and
simulates and linearises a model. Slow (minutes per interpreter, downloads wheels).
"""

from __future__ import annotations

import glob
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
VERSIONS = ["3.11", "3.12", "3.13"]

SMOKE = """
import sys
import numpy as np
import workbench, models, problems
from workbench.app.report import build_report
from workbench.app import registry
from models import pendulum3d
from workbench import linearize, simulate
m = pendulum3d.full(J=np.diag([0.13, 0.28, 0.17]), rho=[0, 0, 0.3])
x0 = m.state(R=np.eye(3), omega=[0.0, 0.0, 0.0])
traj = simulate(m, x0, np.linspace(0, 1, 11))
lin = linearize(m, x0)
assert lin.A.shape == (6, 6) and np.allclose(traj.final, x0)
assert len(registry.names()) > 10
print(".".join(map(str, sys.version_info[:2])))
"""


def interpreter(version: str) -> str | None:
    """A python executable of ``version`` (pyenv's installs first, then PATH)."""
    found = sorted(glob.glob(f"/root/.pyenv/versions/{version}.*/bin/python{version}"))
    for exe in [*found, shutil.which(f"python{version}")]:
        if exe and subprocess.run([exe, "-c", "import sys"], capture_output=True,
                                  timeout=60).returncode == 0:
            return exe
    return None


def test_requires_python_admits_the_supported_versions():
    spec = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["requires-python"]
    from packaging.specifiers import SpecifierSet

    s = SpecifierSet(spec)
    assert all(f"{v}.0" in s for v in VERSIONS) and "3.10.0" not in s
    assert f"{sys.version_info.major}.{sys.version_info.minor}.0" in s


@pytest.mark.slow
@pytest.mark.parametrize("version", VERSIONS)
def test_installs_and_imports_under(version, tmp_path):
    exe = interpreter(version)
    if exe is None:
        pytest.skip(f"no Python {version} on this machine")
    venv = tmp_path / "venv"
    subprocess.run([exe, "-m", "venv", str(venv)], check=True, timeout=300)
    py = str(venv / "bin" / "python")
    pip = subprocess.run([py, "-m", "pip", "install", "--quiet", "--prefer-binary",
                          str(ROOT)], capture_output=True, text=True, timeout=1800)
    assert pip.returncode == 0, pip.stderr[-3000:]
    run = subprocess.run([py, "-c", SMOKE], capture_output=True, text=True, timeout=600,
                         cwd=tmp_path)
    assert run.returncode == 0, run.stderr[-3000:]
    assert run.stdout.strip().splitlines()[-1] == version
