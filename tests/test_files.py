"""Files that are lost or left behind (issue 9), with real processes and real files.

* User files: an output folder carries mjlink's marker; a run replaces only the files mjlink
  wrote there, keeps the rest, and refuses a folder it did not write (or another command's).
* Non-regular targets: ``build -o`` and ``synth --write`` refuse a FIFO, a socket or a folder,
  and write through a symbolic link instead of replacing it.
* Files a user names (``build -o``, ``design -o``, ``export --dxf/--points``, ``synth
  --write``): one that exists is kept unless ``--force``; a command's input is never an output
  (also through a link, also with ``--force``); two outputs are never one file; ``design``
  writes its page into ``simulate``'s folder under that folder's rules.
* Leftovers and orphans: SIGTERM and SIGINT end ``simulate`` with 143 and 130 while its plot
  worker runs, leaving no staging folder and no process; SIGKILL takes the worker with it; a
  failed run's worker cannot re-create the staging folder; the next run removes a killed run's
  staging folder.

The signal tests look at processes through /proc (Linux). They wait for the forked plot worker
to appear before signalling, and wait on each event itself (a process there or gone, a file
written: conftest.wait_for), never for a time.
"""

import functools
import json
import os
import signal
import socket
import stat
import subprocess
import sys
from contextlib import contextmanager
from pathlib import Path

import pytest
from conftest import HUNG_S, ROOT, in_process, wait_for

from mjlink import files, pipeline, validation
from mjlink.cli import main
from mjlink.errors import MjlinkError, OutputError
from mjlink.model import catalogue
from mjlink.model.mechanism import parse
from mjlink.runtime import markers, signals, staging, workers

EXAMPLE_PATH = catalogue.MECHANISMS_DIR / "examples" / "crank_rocker.toml"
EXAMPLE = EXAMPLE_PATH.read_text()
FAST = pipeline.Options(dynamics=False, plots=False, video=False, loads=False)
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}  # conftest has chosen MUJOCO_GL: no GL probes
LINUX = sys.platform.startswith("linux")


@pytest.fixture(scope="module")
def mech():
    return validation.get(EXAMPLE_PATH)


def hidden(folder):
    """Hidden staging or backup folders beside the outputs."""
    return sorted(p.name for p in Path(folder).iterdir() if p.name.startswith("."))


def names(folder):
    return sorted(p.name for p in Path(folder).iterdir())


def dead_pid():
    """The PID of a process that has ended (and been reaped)."""
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


# ============================================================================ 9: user files
def test_a_run_replaces_its_own_files_and_keeps_the_users(tmp_path, mech):
    first = pipeline.run(mech, tmp_path, pipeline.Options(dynamics=False, plots=False, video=False, loads=True))
    out = first.out_dir
    marker = markers.read_marker(out)
    assert marker is not None and marker["kind"] == "simulate" and marker["mechanism"] == "crank_rocker"
    assert marker["files"] == sorted(first.files) and "loads.csv" in marker["files"]
    (out / "notes.txt").write_text("my notes\n")
    (out / "mine").mkdir()
    (out / "mine" / "fit.py").write_text("print(1)\n")
    os.symlink("notes.txt", out / "notes_link")
    inode = (out / "notes.txt").stat().st_ino

    second = pipeline.run(mech, tmp_path, FAST)  # no loads this time
    assert "loads.csv" not in second.files
    assert names(out) == sorted([*second.files, ".mjlink-output.json", "mine", "notes.txt", "notes_link"])
    assert (out / "notes.txt").read_text() == "my notes\n" and (out / "notes.txt").stat().st_ino == inode
    assert (out / "mine" / "fit.py").read_text() == "print(1)\n"
    assert os.readlink(out / "notes_link") == "notes.txt"
    assert markers.read_marker(out)["files"] == sorted(second.files)  # the user's files are not claimed
    assert hidden(tmp_path) == []


def test_a_folder_mjlink_did_not_write_is_refused_in_one_line(tmp_path, mech):
    user = tmp_path / "crank_rocker"
    user.mkdir()
    (user / "report.json").write_text('{"mine": true}\n')
    (user / "thesis.tex").write_text("\\begin{document}\n")
    with pytest.raises(OutputError) as e:
        pipeline.run(mech, tmp_path, FAST)
    msg = str(e.value)
    assert "\n" not in msg and str(user) in msg and "--force" in msg and "not written by mjlink" in msg
    assert names(user) == ["report.json", "thesis.tex"] and (user / "report.json").read_text() == '{"mine": true}\n'
    assert hidden(tmp_path) == []

    res = pipeline.run(mech, tmp_path, FAST, force=True)  # mjlink's files go in, the user's others stay
    assert (user / "thesis.tex").read_text() == "\\begin{document}\n"
    assert json.loads((user / "report.json").read_text())["mechanism"] == "crank_rocker"
    assert set(res.files) | {"thesis.tex", ".mjlink-output.json"} == set(names(user))
    assert "thesis.tex" not in markers.read_marker(user)["files"]
    pipeline.run(mech, tmp_path, FAST)  # now it is mjlink's: no --force needed, thesis.tex still kept
    assert (user / "thesis.tex").read_text() == "\\begin{document}\n"
    (tmp_path / "empty" / "crank_rocker").mkdir(parents=True)  # an empty folder has nothing to lose
    assert markers.read_marker(pipeline.run(mech, tmp_path / "empty", FAST).out_dir)["kind"] == "simulate"


def test_a_users_file_with_the_name_of_a_new_output_is_not_replaced(tmp_path):
    dest = tmp_path / "x"
    with staging.staged_dir(dest, kind="simulate", mechanism="x") as stage:
        (stage / "a.csv").write_text("1\n")
    (dest / "b.png").write_text("the user's picture")
    with pytest.raises(OutputError, match=r"b\.png in it was not written by mjlink; .*--force") as e:
        with staging.staged_dir(dest, kind="simulate", mechanism="x") as stage:
            (stage / "a.csv").write_text("2\n")
            (stage / "b.png").write_text("mjlink's plot")
    assert "\n" not in str(e.value)
    assert (dest / "b.png").read_text() == "the user's picture" and (dest / "a.csv").read_text() == "1\n"
    assert hidden(tmp_path) == []
    with staging.staged_dir(dest, kind="simulate", mechanism="x", force=True) as stage:
        (stage / "b.png").write_text("mjlink's plot")
    assert names(dest) == [".mjlink-output.json", "b.png"]  # a.csv was mjlink's and is not written again
    assert (dest / "b.png").read_text() == "mjlink's plot"


def test_commands_never_write_into_each_others_folders(tmp_path, mech):
    loads = pipeline.loads(mech, tmp_path, plots=False)
    folder = loads.out_dir
    assert folder.name == "crank_rocker_loads" and markers.read_marker(folder)["kind"] == "loads"
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    # A mechanism named like the torque command's folder: simulate must not replace it.
    impostor = validation.validate(
        parse(EXAMPLE.replace('name = "crank_rocker"', 'name = "crank_rocker_loads"'), tmp_path / "f.toml")
    )
    with pytest.raises(OutputError) as e:
        pipeline.run(impostor, tmp_path, FAST)
    msg = str(e.value)
    assert "\n" not in msg and str(folder) in msg and "--force" in msg
    assert "'mjlink torque/reactions' for crank_rocker" in msg and "'mjlink simulate'" in msg
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before
    # Nor may the steady study, or the same command for another mechanism.
    with pytest.raises(OutputError, match="--force"):
        with staging.staged_dir(folder, kind="steady", mechanism="crank_rocker") as stage:
            (stage / "steady.png").write_text("x")
    with pytest.raises(OutputError, match="for crank_rocker, not for other"):
        with staging.staged_dir(folder, kind="loads", mechanism="other") as stage:
            (stage / "loads.csv").write_text("x")
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before and hidden(tmp_path) == []
    # The same command again replaces its own folder.
    assert pipeline.loads(mech, tmp_path, plots=False).out_dir == folder
    assert markers.read_marker(folder)["kind"] == "loads"


# ============================================================================ 10: non-regular targets
def test_build_refuses_a_fifo(tmp_path, capsys):
    fifo = tmp_path / "model.xml"
    os.mkfifo(fifo)
    assert main(["build", str(EXAMPLE_PATH), "-o", str(fifo)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "is a FIFO (named pipe), not a regular file" in err and str(fifo) in err
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode) and names(tmp_path) == ["model.xml"]


def test_the_writer_refuses_a_folder(tmp_path):
    (tmp_path / "model.xml").mkdir()
    with pytest.raises(OutputError, match=r"model\.xml is a folder, not a regular file: refusing to replace it$"):
        files.write_text(tmp_path / "model.xml", "<mujoco/>")
    assert names(tmp_path) == ["model.xml"] and names(tmp_path / "model.xml") == []


def test_build_refuses_a_socket(tmp_path, capsys):
    """A socket, made here (a character device such as /dev/null is refused by the same rule:
    anything but a regular file; the test touches no file of the machine's)."""
    target = tmp_path / "model.xml"
    with socket.socket(socket.AF_UNIX) as s:
        s.bind(str(target))
    before = os.lstat(target)
    assert stat.S_ISSOCK(before.st_mode)
    # The writer itself first, with a body that aborts: even if it failed to refuse, the
    # socket would not be replaced.
    with pytest.raises(OutputError, match="is a socket"):
        with files.atomic_path(target):
            raise AssertionError("the socket was not refused")
    assert main(["build", str(EXAMPLE_PATH), "-o", str(target)]) == 1
    err = capsys.readouterr().err
    assert err == f"mjlink: error: {target} is a socket, not a regular file: refusing to replace it\n"
    after = os.lstat(target)
    assert stat.S_ISSOCK(after.st_mode) and after.st_ino == before.st_ino and names(tmp_path) == ["model.xml"]


def test_build_writes_through_a_symlink(tmp_path, capsys):
    real = tmp_path / "real"
    real.mkdir()
    (real / "target.xml").write_text("old")
    link = tmp_path / "model.xml"
    os.symlink(real / "target.xml", link)
    assert main(["build", str(EXAMPLE_PATH), "-o", str(link)]) == 1  # it exists: kept
    assert "--force" in capsys.readouterr().err and (real / "target.xml").read_text() == "old"
    assert main(["build", str(EXAMPLE_PATH), "-o", str(link), "--force"]) == 0, capsys.readouterr().err
    assert os.path.islink(link) and os.readlink(link) == str(real / "target.xml")
    assert (real / "target.xml").read_text().startswith("<mujoco")
    assert names(tmp_path) == ["model.xml", "real"] and names(real) == ["target.xml"]  # no temporaries


def test_synth_write_refuses_a_fifo_and_writes_through_a_symlink(tmp_path, capsys):
    fifo = tmp_path / "design.toml"
    os.mkfifo(fifo)
    assert main(["synth", "crank_slider", "--write", str(fifo)]) == 1
    assert "is a FIFO (named pipe)" in capsys.readouterr().err and stat.S_ISFIFO(os.lstat(fifo).st_mode)
    (tmp_path / "kept").mkdir()
    link = tmp_path / "designed.toml"
    os.symlink(tmp_path / "kept" / "designed.toml", link)  # dangling: the target is created
    assert main(["synth", "crank_slider", "--write", str(link)]) == 0, capsys.readouterr().err
    assert os.path.islink(link) and "[mechanism]" in (tmp_path / "kept" / "designed.toml").read_text()


# ============================================================================ files a user names
NAMED = ("build -o", "design -o", "export --dxf", "export --points", "synth --write")


def named(command, out, mechanism=EXAMPLE_PATH):
    """The arguments of ``command`` (one of NAMED) writing ``out``, reading ``mechanism``."""
    what, option = command.split()
    return ["synth", "crank_slider", option, str(out)] if what == "synth" else [what, str(mechanism), option, str(out)]


def contents(folder):
    """Every entry of ``folder``: a file's bytes, a link's target."""
    return {p.name: os.readlink(p) if p.is_symlink() else p.read_bytes() for p in folder.iterdir()}


def one_line(capsys):
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("mjlink: error: "), err
    return err


@pytest.mark.parametrize("via", ["the file", "a link to it"])
@pytest.mark.parametrize("command", NAMED)
def test_a_file_you_name_is_kept_unless_force_is_given(tmp_path, capsys, command, via):
    """Every command that writes a file the user names keeps one that exists (one line naming
    it and --force, status 1, the file byte for byte as it was); --force replaces it."""
    mine = tmp_path / "mine.csv"  # an extension every command accepts; a stem synth accepts
    mine.write_bytes(b"my own file\n")
    out = mine
    if via == "a link to it":
        out = tmp_path / "link.csv"
        os.symlink(mine, out)
    before = names(tmp_path)
    assert main(named(command, out)) == 1
    err = one_line(capsys)
    assert str(out) in err and "--force" in err
    assert mine.read_bytes() == b"my own file\n" and names(tmp_path) == before
    assert main([*named(command, out), "--force"]) == 0, capsys.readouterr().err
    assert mine.read_bytes() != b"my own file\n" and names(tmp_path) == before
    assert os.path.islink(out) == (via == "a link to it")


@pytest.mark.parametrize(
    ("command", "how"),
    [
        (c, h)
        for c in NAMED[:4]
        for h in ("its own name", "another spelling", "a link", "a hard link")
        if c != "export --points" or "link" in h  # --points takes a .csv or .json name
    ],
)
def test_no_command_writes_onto_the_file_it_reads(tmp_path, capsys, command, how):
    """Not even with --force: the mechanism file is the command's input."""
    src = tmp_path / "my_rocker.toml"
    src.write_text(EXAMPLE)
    (tmp_path / "sub").mkdir()
    out = {
        "its own name": src,
        "another spelling": tmp_path / "sub" / ".." / "my_rocker.toml",
        "a link": tmp_path / "out.csv",
        "a hard link": tmp_path / "out.csv",
    }[how]
    if how == "a link":
        os.symlink(src, out)
    elif how == "a hard link":
        os.link(src, out)
    before = names(tmp_path)
    assert main([*named(command, out, src), "--force"]) == 1
    assert "is the file this command reads" in one_line(capsys)
    assert src.read_text() == EXAMPLE and names(tmp_path) == before


def test_synth_never_writes_onto_the_file_it_starts_from(tmp_path, capsys, monkeypatch):
    """synth reads the shipped crank_slider.toml: --write through a link to it is refused with
    --force (nothing is written even if the refusal failed: the writer is replaced)."""
    monkeypatch.setattr(pipeline.design, "write_files", lambda *a, **k: pytest.fail("it wrote"))
    link = tmp_path / "base.toml"
    os.symlink(catalogue.path_of("crank_slider"), link)
    assert main(["synth", "crank_slider", "--write", str(link), "--force"]) == 1
    assert "is the file this command reads" in one_line(capsys)


@pytest.mark.parametrize("how", ["one name", "another spelling", "a link", "hard links"])
def test_two_outputs_of_one_command_are_never_one_file(tmp_path, capsys, monkeypatch, how):
    """export --dxf X --points X is refused before any work (nothing computed, nothing written,
    a file there kept), naming both options."""
    from mjlink.pipeline import export

    monkeypatch.setattr(export, "positions", lambda *a: pytest.fail("computed before refusing"))
    x = tmp_path / "x.csv"
    other = {"one name": x, "another spelling": tmp_path / "." / "x.csv", "a link": tmp_path / "y.csv"}
    other["hard links"] = tmp_path / "y.csv"
    if how == "a link":
        os.symlink(x, other[how])
    elif how == "hard links":
        x.write_text("mine\n")
        os.link(x, other[how])
    before = contents(tmp_path)
    assert main(["export", str(EXAMPLE_PATH), "--dxf", str(x), "--points", str(other[how]), "--force"]) == 1
    err = one_line(capsys)
    assert "--dxf" in err and "--points" in err and "same file" in err
    assert contents(tmp_path) == before


def test_design_writes_its_page_where_simulate_does(tmp_path, mech):
    """One place for design.html: renders/NAME/design.html, the root created as simulate --out
    creates it (outside a checkout there is no renders/); simulate's folder keeps its own rules:
    design replaces only the page, keeping the run's files, and simulate takes it back."""
    r = in_process("design", str(EXAMPLE_PATH), cwd=tmp_path)
    folder = tmp_path / "renders" / "crank_rocker"
    assert r.returncode == 0, r.stderr
    assert (
        names(folder) == [markers.MARKER, "design.html"] and str(Path("renders/crank_rocker/design.html")) in r.stderr
    )
    run = pipeline.run(mech, tmp_path / "renders", FAST)  # its own folder: no --force needed
    assert "design.html" in run.files
    kept = {n: (folder / n).stat().st_ino for n in run.files if n != "design.html"}
    page = (folder / "design.html").stat().st_ino
    r = in_process("design", str(EXAMPLE_PATH), cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert {n: (folder / n).stat().st_ino for n in kept} == kept and (folder / "design.html").stat().st_ino != page
    assert markers.read_marker(folder)["files"] == sorted(run.files) and hidden(folder.parent) == []
    assert pipeline.run(mech, tmp_path / "renders", FAST).files == run.files  # simulate's own again
    # A folder of the user's there is refused without --force, and kept.
    mine = tmp_path / "other" / "crank_rocker"
    mine.mkdir(parents=True)
    (mine / "notes.txt").write_text("mine\n")
    r = in_process("design", str(EXAMPLE_PATH), "--out", str(tmp_path / "other"))
    assert r.returncode == 1 and "--force" in r.stderr and names(mine) == ["notes.txt"]


# ============================================================================ 11: leftovers and orphans
def _stat(pid):
    """(parent PID, state, start time) of a process from /proc; None when it is gone."""
    try:
        raw = Path(f"/proc/{pid}/stat").read_bytes()
    except OSError:
        return None
    fields = raw[raw.rindex(b")") + 2 :].split()
    return int(fields[1]), fields[0].decode(), int(fields[19])


def _children(pid):
    """{PID: start time} of the processes whose parent is ``pid``."""
    kids = {}
    for d in os.listdir("/proc"):
        if d.isdigit() and (st := _stat(int(d))) is not None and st[0] == pid:
            kids[int(d)] = st[2]
    return kids


def _running(pid, start):
    """Whether process ``pid`` (started at ``start``: not a reused PID) still runs; a zombie
    (dead, not yet reaped by its new parent) does not."""
    st = _stat(pid)
    return st is not None and st[2] == start and st[1] not in ("Z", "X")


def _threads(pid):
    """How many threads process ``pid`` runs (0 once it is gone)."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return 0
    return int(next(line.split()[1] for line in status.splitlines() if line.startswith("Threads:")))


def _signalled():
    """Wait for the signal just sent to this process to raise in its handler (it does within a
    few bytecodes); only a handler that never raises makes the test fail here."""
    wait_for(lambda: False, "the signal's handler to raise")


@contextmanager
def _sigint_default():
    """Children inherit an ignored SIGINT (a background job's), and Python then never raises
    KeyboardInterrupt: give them the default disposition."""
    old = signal.getsignal(signal.SIGINT)
    if old is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        if old is signal.SIG_IGN:
            signal.signal(signal.SIGINT, old)


class Simulate:
    """``python -m mjlink simulate takeup`` (video on) in its own process group, started and
    watched until its forked plot worker draws while it renders the video."""

    def __init__(self, out, env=ENV):
        self.out, self.err = out, out.parent / f"{out.name}.stderr"
        cmd = [sys.executable, "-m", "mjlink", "simulate", "takeup", "--no-dynamics", "--out", str(out)]
        with _sigint_default(), open(self.err, "w") as err:
            # stderr to a file, not a pipe: a surviving worker would hold a pipe open.
            self.p = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=err, start_new_session=True)
        self.seen = {}  # every child process seen: PID -> start time

    def stderr(self):
        return self.err.read_text()

    def wait_for_worker(self):
        """The forked worker's (PID, start time): a child running the parent's command line while
        the run stages, with a thread beside its main one (its watch on the parent, started
        first thing). A child between fork and exec (a subprocess being started) runs the
        command line too, for an instant, on one thread."""

        def worker():
            if self.p.poll() is not None:
                pytest.fail(f"simulate ended ({self.p.returncode}) before forking its worker: {self.stderr()}")
            cmdline = Path(f"/proc/{self.p.pid}/cmdline").read_bytes()
            kids = _children(self.p.pid)
            self.seen.update(kids)
            if not (self.out.is_dir() and any(n.startswith(".takeup.partial-") for n in names(self.out))):
                return None
            for pid, start in kids.items():
                try:
                    forked = cmdline != b"" and Path(f"/proc/{pid}/cmdline").read_bytes() == cmdline
                except OSError:
                    continue
                if forked and _threads(pid) >= 2:
                    return pid, start
            return None

        return wait_for(worker, "simulate's forked plot worker")

    def end(self):
        self.seen.update(_children(self.p.pid))
        return self.p.wait(HUNG_S)

    def children_end(self):
        """Wait until none of the children seen runs any more: each ends once the run has (the
        worker killed by it or by its own watch, an encoder once its input is closed)."""
        wait_for(
            lambda: not any(_running(*kid) for kid in self.seen.items()),
            f"the run's children to end (still running: {self.seen})",
        )

    def kill_all(self):
        for pid, start in self.seen.items():
            if _running(pid, start):
                os.kill(pid, signal.SIGKILL)


linux_only = pytest.mark.skipif(not LINUX, reason="processes are inspected through /proc")


@linux_only
@pytest.mark.slow
@pytest.mark.parametrize(
    ("how", "status", "line"),
    [("SIGTERM", 143, "mjlink: terminated"), ("SIGINT", 130, "mjlink: interrupted")],
)
def test_signal_during_the_fork_ends_cleanly(tmp_path, how, status, line):
    """SIGTERM to the process (``kill PID``), SIGINT to its process group (Ctrl-C in a terminal)
    while the worker draws and the parent renders: the documented status and line, no staging
    folder, no process left."""
    out = tmp_path / "out"
    run = Simulate(out)
    try:
        worker = run.wait_for_worker()
        run.seen.update(_children(run.p.pid))
        if how == "SIGTERM":
            run.p.send_signal(signal.SIGTERM)
        else:
            os.killpg(run.p.pid, signal.SIGINT)
        rc = run.end()
        err = run.stderr()
        assert rc == status, err
        assert err.strip().splitlines()[-1] == line and "Traceback" not in err
        run.children_end()
        assert not _running(*worker)
        assert names(out) == []  # no .takeup.partial-*, no half output
    finally:
        run.p.kill()
        run.kill_all()


@linux_only
@pytest.mark.slow
def test_sigkill_takes_the_worker_along_and_the_next_run_removes_the_stage(tmp_path, mech):
    out = tmp_path / "out"
    run = Simulate(out)
    try:
        worker = run.wait_for_worker()
        run.p.kill()
        assert run.end() == -signal.SIGKILL
        wait_for(lambda: not _running(*worker), "the worker to end with its killed parent")
        run.children_end()  # the encoder too, once its input is closed
    finally:
        run.p.kill()
        run.kill_all()
    (stale,) = hidden(out)  # only a SIGKILL leaves a stage behind ...
    assert stale.startswith(f".takeup.partial-{run.p.pid}-")
    dead = dead_pid()
    # Another killed run's stage, marked as mjlink marks a stage (a copy of the real one's marker
    # with its own name), and a look-alike of the user's without mjlink's marker.
    killed = out / f".takeup.partial-{dead}-x"
    killed.mkdir()
    (killed / "kinematics.csv").write_text("half")
    marker = json.loads((out / stale / markers.MARKER).read_text())
    (killed / markers.MARKER).write_text(json.dumps({**marker, "stage": killed.name, "pid": dead}))
    mine = out / f".takeup.partial-{dead}-z"
    mine.mkdir()
    (mine / "notes.txt").write_text("the user's")
    live = out / f".takeup.partial-{os.getpid()}-y"  # a run still going (this process)
    live.mkdir()
    pipeline.run(mech, out, FAST)  # ... and the next run into the same folder removes them
    assert hidden(out) == sorted([live.name, mine.name]) and names(out) == sorted(
        [live.name, mine.name, "crank_rocker"]
    )
    assert (mine / "notes.txt").read_text() == "the user's"


def test_an_interrupted_publication_is_put_back_by_the_next_run(tmp_path, mech):
    """The fallback publication (no atomic exchange) moves the old output aside as
    ``.NAME.old-<pid>`` for an instant; if the process dies then, the next run puts it back."""
    first = pipeline.run(mech, tmp_path, FAST)
    (first.out_dir / "notes.txt").write_text("mine")
    os.rename(first.out_dir, tmp_path / f".crank_rocker.old-{dead_pid()}")
    with staging.staged_dir(tmp_path / "other", kind="simulate", mechanism="other") as stage:
        (stage / "a.csv").write_text("1\n")
    assert hidden(tmp_path) == [] and (first.out_dir / "notes.txt").read_text() == "mine"
    assert markers.read_marker(first.out_dir)["files"] == sorted(first.files)


@linux_only
@pytest.mark.slow
def test_a_failed_runs_worker_cannot_recreate_the_stage(tmp_path):
    """The video fails (an encoder that exits at once) while the worker draws the plots: the run
    stops the worker before removing its stage, which stays gone."""
    out = tmp_path / "out"
    run = Simulate(out, env={**ENV, "IMAGEIO_FFMPEG_EXE": "/bin/false"})
    try:
        worker = run.wait_for_worker()
        rc = run.end()
        err = run.stderr()
        assert rc == 1 and "mjlink: error: video encoding failed" in err and "Traceback" not in err, err
        run.children_end()
        assert not _running(*worker)
        # Every process that could write there is gone: what is there now stays.
        assert names(out) == []
    finally:
        run.p.kill()
        run.kill_all()


def _slow_plot(stage, pidfile, hold=None):
    """A plot job as the worker runs it: announces itself, draws until ``hold`` (a pipe's read
    end, None: not at all) can be read, then saves like plotting.style.save (which creates its
    folder if missing). The worker holds the pipe's write end too: nothing but a write ends
    the wait, and the test whose run fails writes nothing."""
    (pidfile.parent / "pid.tmp").write_text(str(os.getpid()))
    os.replace(pidfile.parent / "pid.tmp", pidfile)  # whole: the test reads it as soon as it exists
    if hold is not None:
        os.read(hold, 1)
    stage.mkdir(parents=True, exist_ok=True)
    (stage / "late.png").write_text("drawn after the clean-up")


def _failing_plot(stage):
    raise OutputError(f"{stage / 'positions.png'}: cannot write plot: No space left on device")


@linux_only
def test_a_failing_run_stops_its_worker_before_removing_the_stage(tmp_path):
    """In-process and deterministic: the run fails while its forked worker is still drawing; the
    worker is killed and reaped before the stage is removed, so it cannot re-create it."""
    pidfile = tmp_path / "worker.pid"
    out = tmp_path / "out"
    hold, release = os.pipe()
    try:
        with pytest.raises(RuntimeError, match="the video failed"):
            with staging.staged_dir(out / "x", kind="simulate") as stage:
                worker = workers.start([functools.partial(_slow_plot, stage, pidfile, hold)])
                assert worker is not None
                wait_for(pidfile.exists, "the worker's first plot")
                raise RuntimeError("the video failed")
    finally:
        os.close(hold)
        os.close(release)
    pid = int(pidfile.read_text())
    assert pid == worker.pid and _stat(pid) is None  # killed and reaped: not even a zombie
    assert names(out) == []  # and it was the only process that could write there


@linux_only
def test_the_workers_error_and_success_reach_the_run(tmp_path):
    with staging.staged_dir(tmp_path / "ok", kind="simulate") as stage:
        worker = workers.start([functools.partial(_slow_plot, stage, tmp_path / "pid")])
        workers.finish(worker)
    assert (tmp_path / "ok" / "late.png").is_file() and _stat(worker.pid) is None
    with pytest.raises(OutputError, match=r"positions\.png: cannot write plot: No space left on device$"):
        with staging.staged_dir(tmp_path / "bad", kind="simulate") as stage:
            workers.finish(workers.start([functools.partial(_failing_plot, stage)]))
    assert names(tmp_path) == ["ok", "pid"]


def _one_figure(stage):
    from mjlink.plotting import style

    fig, ax = style.subplots(figsize=(2.0, 1.5))
    ax.plot([0.0, 1.0], [0.0, 1.0])
    style.save(fig, stage, "one.png")


@linux_only
def test_what_an_examine_finds_in_a_worker_reaches_the_run(tmp_path):
    """style.examine's function runs in the worker, where the figure is drawn, and what it
    returned comes back to the run; what cannot travel back is the worker's one-line error."""
    from mjlink.plotting import style

    with style.examine(lambda name, fig: (name, os.getpid(), len(fig.axes))) as found:
        with staging.staged_dir(tmp_path / "ok", kind="simulate") as stage:
            worker = workers.start([functools.partial(_one_figure, stage)])
            workers.finish(worker)
    assert found == [("one.png", ("one.png", worker.pid, 1))] and worker.pid != os.getpid()
    with style.examine(lambda name, fig: lambda: fig) as found:  # a function does not pickle
        with pytest.raises(MjlinkError, match=r"^plot worker: .*(pickle|Pickl)"):
            with staging.staged_dir(tmp_path / "bad", kind="simulate") as stage:
                workers.finish(workers.start([functools.partial(_one_figure, stage)]))
    assert found == [] and names(tmp_path) == ["ok"]


def test_terminated_unwinds_a_staged_run(tmp_path):
    """In-process: SIGTERM during a staged run raises Terminated, the stage is removed and the
    previous output kept; outside a run SIGTERM's disposition is untouched."""
    if signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL:
        pytest.skip("SIGTERM has a handler here already; staged_dir leaves it alone")
    dest = tmp_path / "x"
    with staging.staged_dir(dest, kind="simulate") as stage:
        (stage / "a.csv").write_text("old\n")
    with pytest.raises(signals.Terminated):
        with staging.staged_dir(dest, kind="simulate") as stage:
            (stage / "a.csv").write_text("half")
            handler = signal.getsignal(signal.SIGTERM)
            assert (
                callable(handler) and handler.__module__ == "mjlink.runtime.signals"
            )  # else SIGTERM would kill pytest
            os.kill(os.getpid(), signal.SIGTERM)
            _signalled()
    assert hidden(tmp_path) == [] and (dest / "a.csv").read_text() == "old\n"
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL


def test_a_swallowed_or_disguised_interruption_still_ends_the_run(tmp_path):
    """Code that catches the interruption (a library catching everything) or turns it into an
    ordinary error (ctypes does, in a callback: 'argument 2: Terminated ...') cannot hide it: the
    run publishes nothing and ends with the signal's exception."""
    if signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        pytest.skip("SIGINT has another handler here; interruptible leaves it alone")
    if signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL:
        pytest.skip("SIGTERM has a handler here already; interruptible leaves it alone")
    with pytest.raises(KeyboardInterrupt):
        with staging.staged_dir(tmp_path / "x", kind="simulate") as stage:
            (stage / "a.csv").write_text("1\n")
            try:
                os.kill(os.getpid(), signal.SIGINT)
                _signalled()
            except KeyboardInterrupt:
                pass
    assert names(tmp_path) == []
    with pytest.raises(signals.Terminated) as e:
        with signals.interruptible():
            try:
                os.kill(os.getpid(), signal.SIGTERM)
                _signalled()
            except signals.Terminated as t:
                raise RuntimeError(f"argument 2: {t!r}") from t
    assert isinstance(e.value.__cause__, RuntimeError)
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_an_interruption_in_unraisable_code_is_not_printed(monkeypatch):
    """A signal landing where Python can only report the exception as unraisable (an import
    lock's weakref callback, a __del__) is not reported ('Exception ignored ... Traceback' on
    stderr), and the run still ends with the signal's exception once the body is done."""
    if signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL:
        pytest.skip("SIGTERM has a handler here already; interruptible leaves it alone")
    reported = []
    monkeypatch.setattr(sys, "unraisablehook", reported.append)

    class Dying:
        def __del__(self):
            os.kill(os.getpid(), signal.SIGTERM)
            _signalled()  # the handler raises Terminated in here

    with pytest.raises(signals.Terminated):
        with signals.interruptible():
            Dying()  # collected at once: Terminated is raised inside __del__, unraisable
    assert reported == []
    assert sys.unraisablehook == reported.append  # put back as it was
