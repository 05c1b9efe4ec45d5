"""What ``simulate`` costs, side by side in one run (the speed issue's figures).

Prints, on this machine, in one run so that the ratios compare like with like:

1. CPU and wall seconds of ``python -m mjlink simulate NAME`` (a fresh process: imports,
   the GL choice, runs, reference, loads, plots, video, CSVs) for every shipped mechanism,
   with and without the video (the fastest of ``--repeat`` runs each by wall time, with its CPU, interleaved; the medians beside it),
   each run between two timings of a fixed CPU loop (:func:`host_loop`) that show how fast
   the shared machine ran then;
2. the project's sampling loop (:func:`mjlink.sim.simulate.run` on a compiled model, traces
   and loads decoded from the sensors included) against a plain C loop ``mj_step(m, d, nstep)`` on the same model: steps per second and their ratio,
   for the kinematic and the dynamic case of the take-up;
3. the reference's kinematics (positions, velocities and accelerations on jets) of the
   take-up file and of its four-bar alone (P2, P3, P5: the points pylinkage's linkage has)
   against pylinkage 1.3.0 with numba
   (``step_fast_with_kinematics``, its first, compiling call excluded) and against a plain
   numpy closed form of the same four-bar (positions, velocities and accelerations from the
   loop-closure equations): crank angles per second and their ratios;
4. the reference's equation of motion over each file's dynamic run: the default solution over
   the crank angle against LSODA and the DOP853 twin (CPU and deviation);
5. the cost of one more named point: ``simulate --no-video --no-plots`` of the take-up file
   with 0 and with ``--points`` extra points attached to the lever, the CPU difference per point
   (best of 7 runs each, interleaved; the difference of the medians beside it).

pylinkage and numba come with ``pip install -e '.[bench]'``; without them item 3 says so.
Run: ``python bench/bench_simulate.py`` (``--quick``: one repeat, fewer angles).
"""

from __future__ import annotations

import argparse
import atexit
import math
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# As the command line runs (mjlink.runtime.environment.one_blas_thread): the in-process contenders, mjlink's and the
# peers' alike, with numpy's OpenBLAS on one thread. Set before numpy is loaded.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

MECHANISMS = ("takeup", "crank_slider", "takeup_eyelets", "warp_knitting")


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


_PYCACHE: str | None = None


def _bytecode() -> str:
    """A bytecode cache outside the tree (``PYTHONPYCACHEPREFIX``) that the measured processes
    read and write: an installed package runs from compiled bytecode, while a process started
    with PYTHONDONTWRITEBYTECODE set (as on this machine) compiles mjlink's sources every time
    (0.2 to 0.3 s of CPU). Python then looks for every module's bytecode there, numpy's and
    matplotlib's too, so the processes must be allowed to write it: the first run of each
    command (:func:`run_cli` with ``warm``) fills the cache and is not counted."""
    global _PYCACHE
    if _PYCACHE is None:
        _PYCACHE = tempfile.mkdtemp(prefix="mjlink-bench-pycache-")
        atexit.register(shutil.rmtree, _PYCACHE, True)
    return _PYCACHE


def run_cli(args: list[str]) -> tuple[float, float]:
    """Wall and CPU seconds of ``python -m mjlink ARGS`` in a fresh process (its forked plot
    workers and the video encoder included: they are its children, reaped before it ends),
    from compiled bytecode (:func:`_bytecode`)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), PYTHONPYCACHEPREFIX=_bytecode())
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    c0, t0 = _children_cpu(), time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "mjlink", *args], capture_output=True, text=True, env=env, cwd=ROOT)
    wall = time.perf_counter() - t0
    if r.returncode != 0:
        raise SystemExit(f"simulate failed: {r.stderr.strip().splitlines()[-1:]}")
    return wall, _children_cpu() - c0


def host_loop() -> float:
    """CPU seconds of a fixed workload (pure Python, then numpy; about 60 ms at this machine's
    fastest). Timed beside each measured command, it tells how fast the shared machine ran
    then: its speed drifts by up to 1.8x within minutes, with the load average unchanged."""
    t = time.process_time()
    s = 0
    for i in range(400_000):
        s += i * i
    np.sort(np.random.default_rng(0).random(300_000))
    return time.process_time() - t


def bench_simulate(repeat: int) -> list[tuple[str, str, str, str]]:
    rows = []
    loops: list[float] = []
    host_loop()  # its first call pays for numpy's generator: not counted
    with tempfile.TemporaryDirectory() as tmp:
        # (wall s, CPU s, the host loop's CPU s around the run)
        runs: dict[tuple[str, bool], list[tuple[float, float, float]]] = {}
        for name in MECHANISMS:  # fills the bytecode cache: not counted
            run_cli(["simulate", name, "--out", tmp, "--force"])
        for _ in range(repeat):
            for name in MECHANISMS:
                for video in (True, False):
                    args = ["simulate", name, "--out", tmp, "--force"] + ([] if video else ["--no-video"])
                    before = host_loop()
                    w, c = run_cli(args)
                    loop = 0.5 * (before + host_loop())
                    loops.append(loop)
                    runs.setdefault((name, video), []).append((w, c, loop))
        fastest = min(loops)
        for name in MECHANISMS:
            for video in (True, False):
                got = runs[(name, video)]
                w, c, loop = min(got)  # the fastest run, by wall time, with its CPU
                target = "4 s wall, 6 s CPU" if (name == "takeup" and video) else ("6 s wall" if video else "-")
                spread = (
                    f"median of {len(got)}: {np.median([g[0] for g in got]):.2f} s wall, "
                    f"{np.median([g[1] for g in got]):.2f} s CPU; host loop {loop / fastest:.2f} x its fastest"
                )
                rows.append(
                    (
                        f"simulate {name}" + ("" if video else " --no-video"),
                        f"{w:.2f}",
                        f"{c:.2f}",
                        f"{target}; {spread}",
                    )
                )
    rows.append(
        (
            "host loop beside the simulate runs (the machine's speed then)",
            "",
            f"{fastest:.3f}",
            f"fastest; median {np.median(loops) / fastest:.2f} x, slowest {max(loops) / fastest:.2f} x that",
        )
    )
    return rows


def bench_sampling() -> list[tuple[str, str, str, str]]:
    import mujoco

    from mjlink.model import catalogue, mechanism
    from mjlink.sim import builder, simulate

    mech = mechanism.load(catalogue.path_of("takeup"))
    rows = []
    for label, case in (
        ("kinematic", simulate.kinematic_case(mech)),
        ("dynamic", simulate.dynamic_case(mech)),
    ):
        built = builder.make(mech, case.settings)  # both sides step the same compiled model
        simulate.run(mech, case, built=built)  # warm: imports, first call
        t0 = time.process_time()
        simulate.run(mech, case, built=built)
        ours = time.process_time() - t0
        steps = round(case.duration / case.settings.timestep)
        m = built.model
        d = mujoco.MjData(m)
        mujoco.mj_resetDataKeyframe(m, d, 0) if m.nkey else mujoco.mj_resetData(m, d)
        t0 = time.process_time()
        mujoco.mj_step(m, d, nstep=steps)
        c_loop = time.process_time() - t0
        rows.append(
            (
                f"sampling loop, take-up {label} run ({steps} steps)",
                "",
                f"{ours:.3f}",
                f"{steps / ours:,.0f} steps/s vs C loop {steps / c_loop:,.0f} = {c_loop / ours:.2f} x (target >= 0.5)",
            )
        )
    return rows


def _fourbar(mech) -> dict[str, float]:
    g = {k: np.asarray(v, dtype=float)[:2] * 1e3 for k, v in mech.ground.items()}
    steps = {s.point: s for s in mech.steps}
    p3 = steps["P3"]
    p5 = steps["P5"]
    return dict(
        ax=g["P1"][0],
        ay=g["P1"][1],
        dx=g["P4"][0],
        dy=g["P4"][1],
        a=steps["P2"].length * 1e3,
        b=p3.length_a * 1e3,
        c=p3.length_b * 1e3,
        # mjlink's sign is the closure's sense P2 -> P3 -> P4 (-1 clockwise): P3 lies on the
        # other side of the line P2 -> P4 from the closed form's normal, hence the minus.
        side=-float(p3.sign),
        e=p5.length * 1e3,
        alpha=p5.angle,
    )


def closed_form(fb: dict[str, float], phi: np.ndarray, omega: float) -> tuple[np.ndarray, ...]:
    """Positions (mm), velocities and accelerations of the coupler point P5 of the four-bar, in
    closed form: P3 from the circle intersection, the link rates from the loop's two linear
    velocity and acceleration equations."""
    A = np.array([fb["ax"], fb["ay"]])
    D = np.array([fb["dx"], fb["dy"]])
    a, b, c = fb["a"], fb["b"], fb["c"]
    cp, sp = np.cos(phi), np.sin(phi)
    B = A[:, None] + a * np.stack([cp, sp])
    dvec = D[:, None] - B
    dist = np.hypot(dvec[0], dvec[1])
    along = (b * b - c * c + dist * dist) / (2 * dist)
    h = np.sqrt(np.maximum(b * b - along * along, 0.0))
    u = dvec / dist
    C = B + along * u + fb["side"] * h * np.stack([-u[1], u[0]])
    th3 = np.arctan2(C[1] - B[1], C[0] - B[0])
    th4 = np.arctan2(C[1] - D[1], C[0] - D[0])
    # velocity: a w e^{i phi} i + b w3 i e^{i th3} = c w4 i e^{i th4}
    s34 = np.sin(th3 - th4)
    w3 = a * omega * np.sin(th4 - phi) / (b * s34)
    w4 = a * omega * np.sin(th3 - phi) / (c * s34)
    # acceleration (constant crank speed)
    k1 = -a * omega**2 * np.cos(phi - th4) - b * w3**2 * np.cos(th3 - th4) + c * w4**2
    e3 = k1 / (b * s34)
    k2 = -a * omega**2 * np.cos(phi - th3) - b * w3**2 + c * w4**2 * np.cos(th4 - th3)
    e4 = k2 / (c * s34)
    g = th3 + np.pi + fb["alpha"]  # P5 hangs off P3, from the direction P3 -> P2 turned by alpha
    P = C + fb["e"] * np.stack([np.cos(g), np.sin(g)])
    vC = c * w4 * np.stack([-np.sin(th4), np.cos(th4)])
    V = vC + fb["e"] * w3 * np.stack([-np.sin(g), np.cos(g)])
    aC = c * e4 * np.stack([-np.sin(th4), np.cos(th4)]) - c * w4**2 * np.stack([np.cos(th4), np.sin(th4)])
    Acc = aC + fb["e"] * (e3 * np.stack([-np.sin(g), np.cos(g)]) - w3**2 * np.stack([np.cos(g), np.sin(g)]))
    return P, V, Acc


def _fourbar_file() -> str:
    """The take-up file cut to its four-bar: ground P1, P4 and the points P2, P3, P5 on massless
    links, without the centres of mass and the thread's guides, i.e. what pylinkage's linkage
    below computes (B, C and P5 with velocities and accelerations)."""
    text = (ROOT / "mechanisms" / "takeup.toml").read_text()
    head = text.partition('[[construct]]\npoint = "S1"')[0]
    keep = [l for l in head.splitlines(keepends=True) if not l.startswith(("N1 =", "N2 ="))]
    links = "".join(
        f"[links.{k}]\npoints = [{v}]\n\n"
        for k, v in (("crank", '"P1", "P2"'), ("lever", '"P2", "P3", "P5"'), ("rocker", '"P4", "P3"'))
    )
    return "".join(keep) + links + "[input]\nphi0 = 101.0\nspeed = 100.0\n"


def bench_reference(n: int, repeat: int = 7) -> list[tuple[str, str, str, str]]:
    """The reference's kinematics at ``n`` crank angles, the best of ``repeat`` interleaved runs
    of each contender: the whole take-up file (six points, three link angles) and its four-bar
    alone (the like-for-like with pylinkage and the closed form)."""
    from mjlink import reference
    from mjlink.model import catalogue, mechanism

    mech = mechanism.load(catalogue.path_of("takeup"))
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "takeup_fourbar.toml"
        path.write_text(_fourbar_file())
        four = mechanism.load(path)
    phi = mech.phi0 + 2 * math.pi * np.arange(n) / n
    omega = 100.0
    fb = _fourbar(mech)
    contenders = {
        "all": lambda: reference.solve(mech, phi),
        "four": lambda: reference.solve(four, phi),
        "closed": lambda: closed_form(fb, phi, omega),
    }
    try:
        import numba  # noqa: F401
        import pylinkage as pl
    except ImportError as e:
        missing: str | None = f"not installed ({e}): pip install -e '.[bench]'"
    else:
        missing = None
        A = pl.Ground(fb["ax"], fb["ay"], name="A")
        D = pl.Ground(fb["dx"], fb["dy"], name="D")
        crank = pl.Crank(anchor=A, radius=fb["a"], angular_velocity=2 * math.pi / n, name="B")
        c0 = reference.solve(mech, [0.0]).position("P3")[0, :2] * 1e3  # C on the file's branch at phi = 0
        C = pl.RRRDyad(crank.output, D, distance1=fb["b"], distance2=fb["c"], x=c0[0], y=c0[1], name="C")
        P5 = pl.FixedDyad(C, crank.output, distance=fb["e"], angle=fb["alpha"], name="P5")
        lk = pl.Linkage([A, D, crank, C, P5], name="takeup-fourbar")
        try:
            lk.set_input_velocity(crank, omega)
        except Exception:
            pass
        lk.step_fast_with_kinematics(iterations=16)  # numba compiles here: excluded
        contenders["pylinkage"] = lambda: lk.step_fast_with_kinematics(iterations=n)
    for f in contenders.values():  # first calls (allocations, caches) excluded
        f()
    best = dict.fromkeys(contenders, math.inf)
    for _ in range(repeat):
        for k, f in contenders.items():
            t0 = time.process_time()
            f()
            best[k] = min(best[k], time.process_time() - t0)
    kin = reference.solve(four, phi)
    P, V, Acc = closed_form(fb, phi, omega)
    jet = kin.points["P5"]
    miss = max(
        float(np.abs(jet.v[:, :2].T * 1e3 - P).max() / np.abs(P).max()),
        float(np.abs(jet.d[:, :2].T * 1e3 * omega - V).max() / np.abs(V).max()),
        float(np.abs(jet.dd[:, :2].T * 1e3 * omega**2 - Acc).max() / np.abs(Acc).max()),
    )
    ours, t_np = best["four"], best["closed"]
    rows = [
        (
            f"reference kinematics, take-up file (6 points, 3 link angles, jets), {n} angles",
            "",
            f"{best['all']:.4f}",
            f"{n / best['all']:,.0f} angles/s",
        ),
        (
            f"reference kinematics, its four-bar alone (P2, P3, P5, 3 link angles, jets), {n} angles",
            "",
            f"{ours:.4f}",
            f"{n / ours:,.0f} angles/s",
        ),
        (
            f"numpy closed form, the same four-bar (P5 with v and a), {n} angles",
            "",
            f"{t_np:.4f}",
            f"{n / t_np:,.0f} angles/s; reference (four-bar) / closed form = {t_np / ours:.2f} x the speed "
            f"(target >= 0.5); P5, its velocity and acceleration agree within {miss:.1e} of their range",
        ),
    ]
    if missing is not None:
        rows.append(("pylinkage with numba", "", "", missing))
        return rows
    t_pl = best["pylinkage"]
    rows.append(
        (
            f"pylinkage 1.3.0 + numba step_fast_with_kinematics (B, C, P5), {n} angles",
            "",
            f"{t_pl:.4f}",
            f"{n / t_pl:,.0f} angles/s; reference (four-bar) / pylinkage = {t_pl / ours:.2f} x the speed "
            f"(target >= 2); the whole file: {t_pl / best['all']:.2f} x",
        )
    )
    return rows


def bench_points(k: int, rounds: int = 7) -> list[tuple[str, str, str, str]]:
    text = (ROOT / "mechanisms" / "takeup.toml").read_text()
    extra = "".join(
        f'\n[[construct]]\npoint = "Q{i}"\nblock = "attached"\norigin = "P3"\ntoward = "P2"\n'
        f"angle = {(10.0 * i) % 360.0:.1f}\nlength = {10.0 + i:.1f}\n"
        for i in range(1, k + 1)
    )
    names = ", ".join(f'"Q{i}"' for i in range(1, k + 1))
    more = text.replace('points = ["P2", "P3", "P5"]', f'points = ["P2", "P3", "P5", {names}]', 1)
    head, sep, tail = more.partition("\n[links.crank]")
    more = head + extra + sep + tail
    with tempfile.TemporaryDirectory() as tmp:
        base, plus = Path(tmp) / "takeup.toml", Path(tmp) / "takeup_more.toml"
        base.write_text(text)
        plus.write_text(more)
        cpu: dict[Path, list[float]] = {base: [], plus: []}
        loops: list[float] = []
        host_loop()
        for _ in range(rounds):
            for f in (base, plus):
                loops.append(host_loop())
                cpu[f].append(run_cli(["simulate", str(f), "--out", tmp, "--force", "--no-video", "--no-plots"])[1])
        per = (min(cpu[plus]) - min(cpu[base])) / k
        per_median = (float(np.median(cpu[plus])) - float(np.median(cpu[base]))) / k
    return [
        (
            f"one more named point (take-up, {k} extra on the lever, --no-video --no-plots)",
            "",
            f"{1e3 * per:.1f} ms",
            f"CPU per extra point, best of {rounds} each (target <= 10 ms); from the medians {1e3 * per_median:.1f} ms; "
            f"host loop {min(loops):.3f} to {max(loops):.3f} s meanwhile",
        )
    ]


def bench_dynamics() -> list[tuple[str, str, str, str]]:
    """The reference's equation of motion over each file's dynamic run (4001 times): the
    default solution over the crank angle against LSODA and against the twin, scipy's
    DOP853 at rtol 1e-12 (scipy imported beforehand: its 0.5 s of import is not counted)."""
    import scipy.integrate  # noqa: F401

    from mjlink import reference, validation

    rows = []
    for name in MECHANISMS:
        mech = validation.get(name)
        sd = reference.SpectralDynamics(mech)
        t = np.linspace(0.0, mech.dynamics.duration, 4001)
        cpu, got = {}, {}
        for method in ("auto", "LSODA", "DOP853"):
            best = math.inf
            for _ in range(2):
                t0 = time.process_time()
                got[method] = reference.forward_dynamics(
                    mech, t, sd=sd, method=method, rtol=1e-12 if method == "DOP853" else reference.TIGHT_RTOL
                )
                best = min(best, time.process_time() - t0)
            cpu[method] = best
        scale = float(np.abs(got["DOP853"].omega).max())
        dev = {m: float(np.abs(got[m].omega - got["DOP853"].omega).max()) / scale for m in ("auto", "LSODA")}
        rows.append(
            (
                f"reference dynamics, {name}: over the crank angle ({got['auto'].method}) / LSODA / DOP853 twin",
                "",
                f"{cpu['auto']:.3f}",
                f"LSODA {cpu['LSODA']:.3f} s, DOP853 {cpu['DOP853']:.3f} s: {cpu['LSODA'] / cpu['auto']:.1f} x / "
                f"{cpu['DOP853'] / cpu['auto']:.1f} x faster (target: >= 3 x the DOP853 solve); omega off the twin by "
                f"{dev['auto']:.1e} / {dev['LSODA']:.1e} of its largest value",
            )
        )
    return rows


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="one repeat, fewer angles")
    p.add_argument("--repeat", type=int, default=3, help="runs of each simulate command (best counts)")
    p.add_argument("--points", type=int, default=60, help="extra named points for the per-point cost")
    a = p.parse_args(argv)
    print(f"load average before the runs: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    rows = bench_simulate(1 if a.quick else a.repeat)
    rows += bench_sampling()
    rows += bench_reference(3600 if a.quick else 36000)
    rows += bench_dynamics()
    rows += bench_points(a.points, 3 if a.quick else 7)
    width = max(len(r[0]) for r in rows)
    print(f"{'':{width}}  {'wall s':>8}  {'CPU s':>8}  note")
    for name, wall, cpu, note in rows:
        print(f"{name:{width}}  {wall:>8}  {cpu:>8}  {note}")


if __name__ == "__main__":
    main()
