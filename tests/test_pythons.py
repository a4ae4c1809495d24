"""The Pythons the package declares, and how the Makefile picks one.

``requires-python`` admits 3.11 to 3.13 (casadi ships abi3 wheels from cp311, typst abi3
wheels, numpy/scipy wheels for each); the Makefile's ``PYTHONS`` names the same versions and
``.ci/run`` runs the fast subset of the tests (``FAST_TESTS``) on the newest of them after the
suite. The Makefile's interpreter checks run here for real, in a scratch copy of the Makefile:
an interpreter that does not run (a pyenv shim of a version pyenv has not selected) or is not
a declared version is refused before anything is made; a venv made with another interpreter is
made again; ``make test-newest`` says in one line when no newest Python runs.

Slow (minutes per interpreter, downloads wheels): for each declared Python present (on PATH
or under pyenv), a fresh virtual environment gets ``pip install`` of the repository with its
dev extra, imports the engine, the models, the problems and the report, and passes the fast
subset of the tests.
"""

from __future__ import annotations

import os
import re
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


def _runs(exe: str | None) -> bool:
    return bool(exe) and subprocess.run([exe, "-c", ""], capture_output=True,
                                        timeout=60).returncode == 0


def interpreter(version: str) -> str | None:
    """A python executable of ``version`` that runs: on PATH, else pyenv's own install."""
    candidates = [shutil.which(f"python{version}")]
    root = subprocess.run(["pyenv", "root"], capture_output=True, text=True).stdout.strip() \
        if shutil.which("pyenv") else ""
    if root:
        candidates += sorted(Path(root, "versions").glob(f"{version}.*/bin/python{version}"),
                             reverse=True)
    return next((str(c) for c in candidates if _runs(c and str(c))), None)


def makefile_variable(name: str) -> str:
    """A ``:=`` variable of the Makefile, its continuation lines joined."""
    text = (ROOT / "Makefile").read_text().replace("\\\n", " ")
    return re.search(rf"^{name}\s*:=\s*(.*)$", text, flags=re.M).group(1).strip()


def test_requires_python_admits_the_supported_versions():
    spec = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["requires-python"]
    from packaging.specifiers import SpecifierSet

    s = SpecifierSet(spec)
    assert all(f"{v}.0" in s for v in VERSIONS) and "3.10.0" not in s and "3.14.0" not in s
    assert f"{sys.version_info.major}.{sys.version_info.minor}.0" in s
    assert makefile_variable("PYTHONS").split() == VERSIONS


def test_ci_runs_the_suite_then_the_fast_subset_on_the_newest_python():
    commands = [line.strip() for line in (ROOT / ".ci" / "run").read_text().splitlines()
                if line.strip() and not line.lstrip().startswith("#")]
    assert commands[-2:] == ["make test", "make test-newest"]
    assert makefile_variable("NEWEST") == "$(lastword $(PYTHONS))"
    fast = makefile_variable("FAST_TESTS").split()
    assert fast and all((ROOT / f).is_file() for f in fast), fast


# -- the Makefile's interpreter checks, in a scratch copy -----------------------------------


@pytest.fixture
def scratch(tmp_path):
    """A folder with the Makefile and pyproject.toml only: a make that goes wrong makes nothing
    in the repository."""
    if shutil.which("make") is None:
        pytest.skip("make is not installed")
    for name in ("Makefile", "pyproject.toml"):
        shutil.copy(ROOT / name, tmp_path / name)
    return tmp_path


def make(folder: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(["make", "--no-print-directory", *args], cwd=folder,
                          capture_output=True, text=True, timeout=300)


def test_a_python_that_does_not_run_is_refused_before_anything_is_made(scratch):
    shim = scratch / "python3.12"  # what pyenv's shim does for a version it has not selected
    shim.write_text("#!/bin/sh\necho 'pyenv: python3.12: command not found' >&2\nexit 127\n")
    shim.chmod(0o755)
    run = make(scratch, f"PYTHON={shim}", "setup")
    assert run.returncode != 0
    assert f"error: PYTHON={shim} does not run" in run.stdout
    assert "pyenv: python3.12: command not found" in run.stdout  # its own words, passed on
    assert not (scratch / ".venv").exists()
    run = make(scratch, "PYTHON=no-such-python3.12", "setup")
    assert run.returncode != 0 and "is not a command" in run.stdout


def test_an_undeclared_python_is_refused(scratch):
    old = next((exe for v in ("3.10", "3.9", "3.8") if (exe := interpreter(v))), None)
    if old is None:
        pytest.skip("no Python older than 3.11 here")
    run = make(scratch, f"PYTHON={old}", "setup")
    assert run.returncode != 0 and "the package declares 3.11 3.12 3.13" in run.stdout
    assert not (scratch / ".venv").exists()


def _binary(exe: str) -> str:
    """The interpreter's own executable (a pyenv shim is a script that runs another)."""
    return subprocess.run([exe, "-c", "import os, sys; print(os.path.realpath(sys.executable))"],
                          capture_output=True, text=True, timeout=60).stdout.strip()


def _fake_venv(folder: Path, base: str) -> None:
    """A .venv whose python is ``base`` (as a venv's python resolves to its interpreter), with
    a stamp newer than the Makefile: up to date, as far as file times go."""
    bin_ = folder / ".venv" / "bin"
    bin_.mkdir(parents=True)
    (bin_ / "python").symlink_to(os.path.realpath(base))
    (folder / ".venv" / ".installed").touch()


def test_a_venv_is_made_again_when_another_python_is_asked_for(scratch):
    here = _binary(sys.executable)  # the interpreter behind this test's venv
    _fake_venv(scratch, here)
    same = make(scratch, "-n", f"PYTHON={here}", "setup")
    assert same.returncode == 0 and "-m venv" not in same.stdout, same.stdout
    other = next((exe for v in VERSIONS if (exe := interpreter(v)) and _binary(exe) != here),
                 None)
    if other is None:
        pytest.skip("only one declared Python here")
    again = make(scratch, "-n", f"PYTHON={other}", "setup")
    assert again.returncode == 0, again.stdout + again.stderr
    assert f"{other} -m venv .venv" in again.stdout and "rm -rf .venv" in again.stdout


def test_make_test_newest_says_so_in_one_line_where_no_newest_python_runs(scratch):
    run = make(scratch, "test-newest", "NEWEST_PYTHON=")
    assert run.returncode == 0
    assert run.stdout.splitlines() == [
        "skipped: no Python 3.13 runs here (python3.13 on PATH, or installed by pyenv), so the "
        "fast tests on the newest declared Python did not run"]
    assert not (scratch / ".venv-3.13").exists()


def _path_without_browser(folder: Path, apt_get: str | None) -> str:
    """A PATH with the few commands test-deps uses, no chromium, and ``apt_get`` as apt-get."""
    bin_ = folder / "bin"
    bin_.mkdir()
    for tool in ("id", "mktemp", "rm"):
        (bin_ / tool).symlink_to(shutil.which(tool))
    if apt_get is not None:
        (bin_ / "apt-get").write_text(apt_get)
        (bin_ / "apt-get").chmod(0o755)
    return str(bin_)


@pytest.mark.parametrize("apt_get", [None, "#!/bin/sh\necho 'E: no network' >&2\nexit 100\n"],
                         ids=["no apt-get", "apt-get failing"])
def test_test_deps_fails_alone_and_lets_make_test_go_on_where_nothing_installs(scratch,
                                                                              apt_get):
    env = {"PATH": _path_without_browser(scratch, apt_get), "HOME": str(scratch)}
    strict = subprocess.run([shutil.which("make"), "--no-print-directory", "test-deps"],
                            cwd=scratch, capture_output=True, text=True, env=env, timeout=120)
    assert strict.returncode != 0 and "error: " in strict.stdout
    lenient = subprocess.run([shutil.which("make"), "--no-print-directory", "test-deps",
                              "TEST_DEPS_STRICT=0"], cwd=scratch, capture_output=True,
                             text=True, env=env, timeout=120)
    assert lenient.returncode == 0, lenient.stdout + lenient.stderr
    said = lenient.stdout.splitlines()
    if apt_get is None:  # nothing to say: the test run's one line names what to install
        assert said == []
    else:
        assert said[-1].startswith("apt-get could not install chromium and poppler-utils")
        assert said[-1].endswith("the tests that need them are skipped")
    test_target = (ROOT / "Makefile").read_text().split("\ntest: ", 1)[1].split("\n\n")[0]
    assert "test-deps TEST_DEPS_STRICT=0" in test_target


# -- each declared Python, for real ---------------------------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("version", VERSIONS)
def test_installs_and_passes_the_fast_tests_under(version, tmp_path):
    exe = interpreter(version)
    if exe is None:
        pytest.skip(f"no Python {version} on this machine")
    venv = tmp_path / "venv"
    subprocess.run([exe, "-m", "venv", str(venv)], check=True, timeout=300)
    py = str(venv / "bin" / "python")
    pip = subprocess.run([py, "-m", "pip", "install", "--quiet", "--prefer-binary",
                          f"{ROOT}[dev]"], capture_output=True, text=True, timeout=1800)
    assert pip.returncode == 0, pip.stderr[-3000:]
    run = subprocess.run([py, "-c", SMOKE], capture_output=True, text=True, timeout=600,
                         cwd=tmp_path)
    assert run.returncode == 0, run.stderr[-3000:]
    assert run.stdout.strip().splitlines()[-1] == version
    fast = [f for f in makefile_variable("FAST_TESTS").split() if f != "tests/test_pythons.py"]
    tests = subprocess.run([py, "-m", "pytest", "-q", "-p", "no:cacheprovider", *fast],
                           capture_output=True, text=True, timeout=1800, cwd=ROOT)
    assert tests.returncode == 0, tests.stdout[-4000:]
