"""scripts/setup.sh's host check and scripts/check_torch.py's torch acceptance (no .venv is touched)."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

TOP = Path(__file__).resolve().parents[2]
SETUP = TOP / "scripts" / "setup.sh"
CHECK_TORCH = TOP / "scripts" / "check_torch.py"
BASH = shutil.which("bash") or "/bin/bash"


def _base_python() -> str:
    """The CPython 3.11 this test runs on, outside any venv (what setup.sh would make .venv with)."""
    return os.path.realpath(getattr(sys, "_base_executable", None) or sys.executable)


def test_check_only_passes_on_this_machine():
    run = subprocess.run([BASH, str(SETUP), "--check-only"], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "prerequisites ok" in run.stdout
    for item in ("platform", "python", "Python.h", "cmake", "C compiler", "C++ compiler", "git", "flock"):
        assert f"setup: {item} " in run.stdout


def test_check_only_reports_every_missing_tool_at_once(tmp_path):
    # A PATH with only bash and python3.11: no cmake, no compilers, no git, no flock.
    (tmp_path / "bash").symlink_to(BASH)
    (tmp_path / "python3.11").symlink_to(_base_python())
    env = {"PATH": str(tmp_path), "HOME": os.environ.get("HOME", "/tmp"), "LANG": "C.UTF-8"}
    run = subprocess.run([str(tmp_path / "bash"), str(SETUP), "--check-only"], capture_output=True,
                         text=True, timeout=60, env=env)
    assert run.returncode == 1, run.stdout + run.stderr
    err = run.stderr
    assert "missing cmake" in err
    assert "missing C compiler" in err and "missing C++ compiler" in err
    assert "missing git" in err and "missing flock" in err
    assert "sudo apt-get install cmake gcc g++ git util-linux" in err
    assert "missing CPython" not in err and "Python.h" in run.stdout  # the python itself was found


def test_check_only_names_a_missing_python(tmp_path):
    (tmp_path / "bash").symlink_to(BASH)
    env = {"PATH": str(tmp_path), "PYTHON": "python3.11-nowhere"}
    run = subprocess.run([str(tmp_path / "bash"), str(SETUP), "--check-only"], capture_output=True,
                         text=True, timeout=60, env=env)
    assert run.returncode == 1
    assert "missing python3.11-nowhere" in run.stderr
    assert "python3.11 python3.11-venv python3.11-dev" in run.stderr


def _check_torch(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(CHECK_TORCH), *args], capture_output=True, text=True,
                          timeout=60)


def test_pin_is_read_from_requirements():
    run = _check_torch("--print-pin")
    assert run.returncode == 0
    assert f"torch=={run.stdout.strip()}\n" in (TOP / "requirements.txt").read_text()


@pytest.mark.parametrize("version", ["2.13.0", "2.13.0+cpu", "2.13.0+cu126"])
def test_torch_check_accepts_the_pin_cpu_or_cuda(version):
    run = _check_torch(version, "--pin", "2.13.0")
    assert run.returncode == 0, run.stderr
    assert f"torch {version} (the pinned 2.13.0" in run.stdout
    if "+cu" in version:
        assert "TORCH_INDEX_URL=https://download.pytorch.org/whl/cpu" in run.stdout


@pytest.mark.parametrize("version", ["2.14.1", "2.13.0+rocm6.2", "2.13.0a0", "2.13"])
def test_torch_check_refuses_other_versions(version):
    run = _check_torch(version, "--pin", "2.13.0")
    assert run.returncode == 1
    assert f"torch {version} installed" in run.stderr
    assert "pins torch==2.13.0" in run.stderr


# ------------------------------------------------------------------------ which CPython makes .venv
def _interpreter(directory: Path, name: str, version: str) -> Path:
    """A stand-in for CPython `version` at directory/name, answering what setup.sh asks an interpreter:
    the host check's script on stdin (implementation, version, executable, venv, Python.h, include dir)
    and `-c` (.venv's X.Y); anything else (pip, venv) fails."""
    xy = version.rsplit(".", 1)[0]
    path = directory / name
    include = f"/usr/include/python{xy}"
    path.write_text(f"""#!{BASH}
case "$1" in
  -) cat >/dev/null; printf '%s\\n' CPython {version} "$0" venv {include}/Python.h {include} ;;
  -c) echo {xy} ;;
  *) exit 1 ;;
esac
""")
    path.chmod(0o755)
    return path


def _check_only(env: dict) -> subprocess.CompletedProcess:
    return subprocess.run([BASH, str(SETUP), "--check-only"], capture_output=True, text=True, timeout=60,
                          env={"PATH": os.environ["PATH"], "HOME": os.environ.get("HOME", "/tmp"), **env})


def test_cpython_312_sets_up_the_runtime_and_says_the_simulator_needs_311(tmp_path):
    run = _check_only({"PYTHON": str(_interpreter(tmp_path, "python3.12", "3.12.3"))})
    assert run.returncode == 0, run.stdout + run.stderr
    assert "(CPython 3.12.3)" in run.stdout and "prerequisites ok" in run.stdout
    assert "runtime only" in run.stdout and "The simulator needs CPython 3.11" in run.stdout
    # how to get one: Ubuntu 24.04's python3 is 3.12, its 3.11 comes from the deadsnakes PPA (or uv)
    assert "ppa:deadsnakes/ppa" in run.stdout and "PYTHON=python3.11 make setup" in run.stdout


def test_cpython_311_sets_up_everything_without_a_note(tmp_path):
    run = _check_only({"PYTHON": str(_interpreter(tmp_path, "python3.11", "3.11.9"))})
    assert run.returncode == 0, run.stdout + run.stderr
    assert "(CPython 3.11.9)" in run.stdout and "runtime only" not in run.stdout


@pytest.mark.parametrize("version", ["3.10.12", "3.13.1"])
def test_other_pythons_are_refused_naming_311(tmp_path, version):
    run = _check_only({"PYTHON": str(_interpreter(tmp_path, "python3", version))})
    assert run.returncode == 1
    assert "missing CPython 3.11" in run.stderr and f"CPython {version}" in run.stderr


def test_without_python311_the_default_is_python3(tmp_path):
    # Stock Ubuntu 24.04: python3 is 3.12 and there is no python3.11.
    (tmp_path / "bash").symlink_to(BASH)
    _interpreter(tmp_path, "python3", "3.12.3")
    run = subprocess.run([str(tmp_path / "bash"), str(SETUP), "--check-only"], capture_output=True, text=True,
                         timeout=60, env={"PATH": str(tmp_path)})
    python_line = f"setup: python        {tmp_path / 'python3'} (CPython 3.12.3)"
    assert python_line in run.stdout, run.stdout + run.stderr
    assert "missing CPython" not in run.stderr and "runtime only" in run.stdout


def test_a_venv_of_another_python_is_named_not_reused(tmp_path):
    # A copy of the set-up script, its .venv made by 3.11, PYTHON a 3.12: it stops before pip runs.
    (tmp_path / "scripts").mkdir()
    shutil.copy(SETUP, tmp_path / "scripts" / "setup.sh")
    (tmp_path / ".venv" / "bin").mkdir(parents=True)
    _interpreter(tmp_path / ".venv" / "bin", "python", "3.11.9")
    python312 = _interpreter(tmp_path, "python3.12", "3.12.3")
    run = subprocess.run([BASH, str(tmp_path / "scripts" / "setup.sh")], capture_output=True, text=True,
                         timeout=60, env={**os.environ, "PYTHON": str(python312)})
    assert run.returncode == 1, run.stdout + run.stderr
    assert ".venv is Python 3.11 but" in run.stderr and "mv .venv .venv-3.11" in run.stderr
    assert "pip install" not in run.stderr


def _pins() -> list:
    from packaging.requirements import Requirement

    lines = (line.split("#")[0].strip() for line in (TOP / "requirements.txt").read_text().splitlines())
    return [Requirement(line) for line in lines if line]


@pytest.mark.parametrize("version,left_out", [("3.11", []), ("3.12", ["pybullet"])])
def test_requirements_leave_out_only_the_simulators_engine_on_312(version, left_out):
    # Every other pin has a cp312 wheel (ROS 2 Jazzy's included); PyBullet 3.2.7 has cp311 wheels only.
    environment = {"python_version": version, "python_full_version": version + ".0"}
    assert [pin.name for pin in _pins() if pin.marker and not pin.marker.evaluate(environment)] == left_out
