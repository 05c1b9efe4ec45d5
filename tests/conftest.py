import sys
from pathlib import Path

import pytest

# MuJoCo reads MUJOCO_GL when first imported: choose the backend before any test imports it.
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from mjlink.sim.gl import ensure_gl_backend

ensure_gl_backend()

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="session")
def takeup():
    from mjlink import validation

    return validation.get("takeup")
