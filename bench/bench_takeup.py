"""Speed of the take-up pipeline. Run: ``python bench/bench_takeup.py``.

Prints the end-to-end wall time of ``python -m mjlink simulate takeup`` (a cold process,
video included, the issue's 10 s goal), MuJoCo steps per second of the kinematic and
dynamic models, and reference positions per second (all points, vectorized).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def best(f, repeat=3):
    out = []
    for _ in range(repeat):
        t = time.perf_counter()
        f()
        out.append(time.perf_counter() - t)
    return min(out)


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        subprocess.run(
            [sys.executable, "-m", "mjlink", "simulate", "takeup", "--out", tmp],
            cwd=ROOT,
            check=True,
            env={**os.environ, "PYTHONPATH": str(ROOT)},
            capture_output=True,
        )
        print(f"simulate takeup (cold, video included): {time.perf_counter() - t:.2f} s wall")

    import mujoco
    import numpy as np

    from mjlink import reference, validation
    from mjlink.sim import builder, simulate

    mech = validation.get("takeup")
    for name, case in (("kinematic", simulate.kinematic_case(mech)), ("dynamic", simulate.dynamic_case(mech))):
        model = builder.build(mech, case.settings)
        data = mujoco.MjData(model)
        n = 20000

        def steps(model=model, data=data, n=n):
            for _ in range(n):
                mujoco.mj_step(model, data)

        print(
            f"MuJoCo {name} model ({case.settings.integrator}, dt {case.settings.timestep:g} s): "
            f"{n / best(steps):,.0f} steps/s"
        )
    phi = np.linspace(0, 2 * np.pi, 100_000)
    dt = best(lambda: reference.solve(mech, phi))
    print(
        f"reference positions with exact 1st and 2nd derivatives: {len(phi) / dt:,.0f} crank angles/s "
        f"({len(mech.point_names)} points each)"
    )
    sd = reference.SpectralDynamics(mech)
    t_eval = np.linspace(0, 1, 4001)
    print(
        f"reference forward dynamics (DOP853, rtol {reference.TIGHT_RTOL:g}, 0..1 s): "
        f"{best(lambda: reference.forward_dynamics(mech, t_eval, sd=sd), 1):.2f} s"
    )


if __name__ == "__main__":
    main()
