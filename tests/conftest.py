import os
import sys
from pathlib import Path

import pytest

# One OpenBLAS thread (numpy's BLAS) in the test processes, as the command line sets for itself
# before numpy loads (mjlink.memory.one_blas_thread): with two xdist workers on two cores, its
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


@pytest.fixture(scope="session")
def takeup():
    from mjlink import validation

    return validation.get("takeup")
