import contextlib
import gc
import io
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import pytest

# One OpenBLAS thread (numpy's BLAS) in the test processes, as the command line sets for itself
# before numpy loads (mjlink.runtime.environment.one_blas_thread): with two xdist workers on two cores, its
# idle threads spun on the other worker's core. Set before any test imports numpy; a value set by
# the user is kept. The subprocesses the tests start inherit it as a user's setting; the check of
# the command line's own setting (test_cli) removes it from its child's environment, and nothing
# else (OMP_NUM_THREADS, which OpenBLAS also reads) is set, so that check still sees the default.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

# MuJoCo reads MUJOCO_GL when first imported: choose the backend before any test imports it.
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from mjlink.sim.gl import ensure_gl_backend

ensure_gl_backend()

ROOT = Path(__file__).resolve().parent.parent


def pytest_collection_finish(session):
    """The cyclic garbage collector of a test process, tuned with the standard library's ``gc``:

    * what collection imported (numpy, MuJoCo, matplotlib, Dask, the tests) lives as long as
      the process: it is moved out of the collector's sight (``gc.freeze``), so that full
      collections stop rescanning it (it is still freed by reference counting; only cycles
      among these objects would stay);
    * the young generation is collected every 5,000 allocations, not 700, and the whole heap
      after 100 collections of the middle generation, not 10 (``gc.set_threshold``): the
      tests make figures by the hundred, cyclic garbage the collector otherwise chased
      through the whole heap every few tens of thousands of allocations. Memory is not short
      here: a test process peaks at about 1 GB, not 0.7.

    Nothing a test checks depends on when a collection runs; pytest collects in full at the
    end of the session to report any exception raised in a finalizer."""
    gc.collect()
    gc.freeze()
    gc.set_threshold(5000, 10, 100)


@pytest.fixture(scope="session")
def takeup():
    from mjlink import validation

    return validation.get("takeup")


@pytest.fixture(autouse=True)
def _environment_kept():
    """Each test starts from the same environment: a LocalCluster a test starts by hand sets
    Dask's worker settings in this process (its nanny's pre-spawn environment, e.g. glibc's
    64 KiB trim threshold), and every program a later test started inherited them (a study
    resumed in a subprocess ran six times slower). mjlink's own engine puts them back itself
    (tested in test_study)."""
    before = dict(os.environ)
    yield
    environment_back(before)


@pytest.fixture(scope="session", autouse=True)
def _session_elsewhere(tmp_path_factory):
    """The session's current folder, a temporary one: what a module's or the session's fixture
    writes to a relative path (a command's default ``renders/``, MuJoCo's log) never lands in
    the checkout, whatever folder pytest was started from."""
    here = os.getcwd()
    base = tmp_path_factory.mktemp("cwd")
    os.chdir(base)
    yield base
    os.chdir(here)


@pytest.fixture(autouse=True)
def _elsewhere(_session_elsewhere, monkeypatch):
    """Each test runs in a fresh temporary folder of its own, as do the commands it starts
    (in_process, and the subprocesses, which inherit it): nothing a test or a command writes
    to a relative path lands in the checkout or in another test's way. A test that needs a
    known folder gives it (``cwd=tmp_path``)."""
    monkeypatch.chdir(tempfile.mkdtemp(dir=_session_elsewhere))


T = TypeVar("T")

HUNG_S = 300.0  # only a hung test waits this long for an event


def wait_for(event: Callable[[], T], what: str, timeout: float = HUNG_S) -> T:
    """``event()`` once it is true (a file there, a process gone, a line written), polled; the
    test fails naming ``what`` if it is still false after ``timeout`` seconds, which only a
    hung test reaches. How soon the event comes is not the test's subject (bench/ measures
    speed)."""
    end = time.monotonic() + timeout
    while not (got := event()):
        if time.monotonic() > end:
            pytest.fail(f"still waiting for {what} after {timeout:g} s", pytrace=False)
        time.sleep(0.02)
    return got


def environment_back(before: dict[str, str]) -> None:
    """``os.environ`` as it was when ``before = dict(os.environ)`` was taken."""
    if dict(os.environ) != before:
        os.environ.clear()
        os.environ.update(before)


def in_process(*args: str, cwd: Path | None = None) -> "subprocess.CompletedProcess[str]":
    """``python -m mjlink ARGS`` run through :func:`mjlink.cli.main` in this process: its exit
    status and what it printed, as :func:`subprocess.run` returns them. For tests of what a
    command computes, writes and prints; what only a real process shows (the entry point, the
    GL backend chosen at import, signals) is tested in real processes. It runs in ``cwd`` if
    given, else in the test's own temporary folder (conftest._elsewhere)."""
    from mjlink.cli import main

    out, err = io.StringIO(), io.StringIO()
    here = os.getcwd()
    try:
        os.chdir(cwd or here)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                status = main(list(args))
            except SystemExit as e:  # argparse's --help and usage errors
                status = e.code if isinstance(e.code, int) else 1
    finally:
        os.chdir(here)
    return subprocess.CompletedProcess(["mjlink", *args], status, out.getvalue(), err.getvalue())


def chromium() -> str:
    """The Chromium the browser tests drive: Debian's package (``chromium``, or another
    distribution's ``chromium-browser``) on the PATH. The tests install nothing: without it a
    browser test is skipped, saying how to get it, or fails where the environment asks for the
    browser tests (``MJLINK_REQUIRE_BROWSER=1``, which .ci/run sets once it has installed it)."""
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is not None:
        return exe
    why = "no Chromium on the PATH: apt-get install chromium (Debian) to run the browser tests"
    if os.environ.get("MJLINK_REQUIRE_BROWSER") == "1":
        pytest.fail(f"{why} (MJLINK_REQUIRE_BROWSER=1 asks for them)", pytrace=False)
    pytest.skip(why)
