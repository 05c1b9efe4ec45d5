"""Output safety: unwritable folders, a full disk, replacing an existing output whole, failed
runs that leave nothing behind, a command's several files written all or none, every output of
a run from the mechanism it loaded (not its file read again), and names from a file that can
neither escape the output folder nor break the MJCF.

Tests run as root, so a read-only folder made with chmod would still be writable: an
unwritable output is made in the test's own folder as a path under a regular file, through a
loop of links or with a name too long instead.
"""

import errno
import json
import operator
import os
import re
import string

import mujoco
import pytest
from conftest import in_process
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mjlink import files as mjfiles
from mjlink import pipeline, validation
from mjlink.errors import MechanismFileError, OutputError, SimulationError
from mjlink.model import catalogue as registry
from mjlink.model.mechanism import parse
from mjlink.runtime import markers, staging
from mjlink.sim import builder, simulate

EXAMPLE = (registry.MECHANISMS_DIR / "examples" / "crank_rocker.toml").read_text()
FAST = pipeline.Options(dynamics=False, plots=False, video=False, loads=False)


def leftovers(folder):
    """Hidden staging or backup folders left beside the outputs."""
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


@pytest.fixture(scope="module")
def mech():
    return validation.get(registry.MECHANISMS_DIR / "examples" / "crank_rocker.toml")


@pytest.fixture
def previous(tmp_path):
    """An existing, complete output folder from an earlier run of mjlink (it carries the marker
    that lets a later run of the same command replace mjlink's own files in it)."""
    old = tmp_path / "crank_rocker"
    with staging.staged_dir(old, kind="simulate", mechanism="crank_rocker") as stage:
        (stage / "report.json").write_text('{"earlier": true}\n')
        (stage / "stale.png").write_text("from an older run")
    return old


def files(folder):
    """The folder's entries, mjlink's marker aside."""
    return sorted(p.name for p in folder.iterdir() if p.name != markers.MARKER)


# ----------------------------------------------------------------------------- unwritable
def test_output_under_a_regular_file_is_one_line_error(tmp_path, mech):
    (tmp_path / "afile").write_text("not a folder")
    with pytest.raises(OutputError, match=r"^cannot write to output folder .*afile/sub: ") as e:
        pipeline.run(mech, tmp_path / "afile" / "sub", FAST)
    assert "\n" not in str(e.value)
    assert (tmp_path / "afile").read_text() == "not a folder"


@pytest.mark.parametrize("why", ["a loop of links", "a name too long"])
def test_output_folder_that_cannot_be_made_is_one_line_error(tmp_path, mech, why):
    """Other reasons a folder cannot be made, made here: the run names the folder and the
    system's reason, in one line, and writes nothing."""
    if why == "a loop of links":
        (tmp_path / "loop").symlink_to(tmp_path / "loop")
        out, reason = tmp_path / "loop" / "sub", "Too many levels of symbolic links"
    else:
        out, reason = tmp_path / ("x" * 300), "File name too long"
    with pytest.raises(OutputError, match=r"^cannot write ") as e:
        pipeline.run(mech, out, FAST)
    assert "\n" not in str(e.value) and str(out) in str(e.value) and reason in str(e.value), str(e.value)
    assert sorted(p.name for p in tmp_path.iterdir()) == (["loop"] if why == "a loop of links" else [])


def test_output_path_that_is_a_file_fails_before_running(tmp_path, mech, monkeypatch):
    (tmp_path / "crank_rocker").write_text("a file")
    ran = []
    monkeypatch.setattr(simulate, "run", lambda *a, **k: ran.append(1))
    with pytest.raises(OutputError, match="exists and is not a folder"):
        pipeline.run(mech, tmp_path, FAST)
    assert not ran and (tmp_path / "crank_rocker").read_text() == "a file"


# ----------------------------------------------------------------------------- failed runs
def test_full_disk_mid_run_leaves_nothing_and_keeps_the_previous_output(tmp_path, mech, previous, monkeypatch):
    real = mjfiles.write_csv
    calls = []

    def full(path, *a, **k):
        calls.append(path.name)
        if len(calls) == 2:  # the first CSV is written, the second hits a full disk
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
        return real(path, *a, **k)

    monkeypatch.setattr(pipeline.simulate, "write_csv", full)
    with pytest.raises(
        OutputError,
        match=r"^cannot write outputs to .*crank_rocker: No space left on device "
        r"\(reference_kinematics.csv\)$",
    ):
        pipeline.run(mech, tmp_path, FAST)
    assert calls == ["kinematics.csv", "reference_kinematics.csv"]
    assert leftovers(tmp_path) == []
    assert files(previous) == ["report.json", "stale.png"]
    assert (previous / "report.json").read_text() == '{"earlier": true}\n'


def test_simulation_failure_mid_run_leaves_no_folder(tmp_path, mech, monkeypatch):
    def diverge(*a, **k):
        raise SimulationError("crank_rocker: MuJoCo diverged (non-finite state) at t = 0.01 s")

    monkeypatch.setattr(simulate, "run", diverge)
    with pytest.raises(SimulationError):
        pipeline.run(mech, tmp_path / "out", FAST)
    assert list((tmp_path / "out").iterdir()) == []


def test_simulation_failure_keeps_the_previous_output(tmp_path, mech, previous, monkeypatch):
    monkeypatch.setattr(simulate, "run", lambda *a, **k: (_ for _ in ()).throw(SimulationError("diverged")))
    with pytest.raises(SimulationError):
        pipeline.run(mech, tmp_path, FAST)
    assert leftovers(tmp_path) == [] and (previous / "report.json").read_text() == '{"earlier": true}\n'


def test_interrupt_mid_run_leaves_nothing(tmp_path, previous):
    with pytest.raises(KeyboardInterrupt):
        with staging.staged_dir(previous, kind="simulate", mechanism="crank_rocker") as stage:
            (stage / "kinematics.csv").write_text("half")
            raise KeyboardInterrupt
    assert leftovers(tmp_path) == [] and files(previous) == ["report.json", "stale.png"]


# ----------------------------------------------------------------------------- replacing
def test_successful_run_replaces_the_previous_output_whole(tmp_path, mech, previous):
    res = pipeline.run(mech, tmp_path, FAST)
    assert res.out_dir == previous
    names = sorted(p.name for p in previous.iterdir())
    assert "stale.png" not in names and "kinematics.csv" in names and "report.json" in names
    assert '"earlier"' not in (previous / "report.json").read_text()
    assert leftovers(tmp_path) == []


def test_replacing_without_atomic_exchange(tmp_path, previous, monkeypatch):
    monkeypatch.setattr(staging, "_exchange", lambda a, b: False)
    with staging.staged_dir(previous, kind="simulate", mechanism="crank_rocker") as stage:
        (stage / "new.txt").write_text("new")
    assert files(previous) == ["new.txt"] and leftovers(tmp_path) == []


def test_failed_final_rename_puts_the_previous_output_back(tmp_path, previous, monkeypatch):
    monkeypatch.setattr(staging, "_exchange", lambda a, b: False)
    real = os.replace

    def flaky(src, dst):
        if ".partial-" in str(src):
            raise OSError(errno.EIO, os.strerror(errno.EIO), str(dst))
        return real(src, dst)

    monkeypatch.setattr(staging.os, "replace", flaky)
    with pytest.raises(OutputError, match="cannot write outputs to"):
        with staging.staged_dir(previous, kind="simulate", mechanism="crank_rocker") as stage:
            (stage / "new.txt").write_text("new")
    assert files(previous) == ["report.json", "stale.png"]
    assert leftovers(tmp_path) == []


def test_atomic_exchange_is_used_on_linux(tmp_path, previous, monkeypatch):
    if not os.uname().sysname == "Linux":
        pytest.skip("renameat2 exchange is Linux only")
    used = []
    real = staging._exchange
    monkeypatch.setattr(staging, "_exchange", lambda a, b: used.append(real(a, b)) or used[-1])
    with staging.staged_dir(previous, kind="simulate", mechanism="crank_rocker") as stage:
        (stage / "new.txt").write_text("new")
    assert used == [True] and files(previous) == ["new.txt"]


# ----------------------------------------------------------------------------- several files: all or none
def everything(folder):
    """Every entry of ``folder``, hidden ones too, with its bytes."""
    return {p.name: p.read_bytes() for p in folder.iterdir()}


def fail_on(monkeypatch, module, name, k, error, only=lambda *a: True):
    """Make ``module.name`` raise ``error`` on its k-th call (from 0) among those ``only`` accepts."""
    real, calls = getattr(module, name), []

    def flaky(*args, **kw):
        if only(*args):
            calls.append(args)
            if len(calls) == k + 1:
                raise error
        return real(*args, **kw)

    monkeypatch.setattr(module, name, flaky)


DISK_FULL = OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


@pytest.mark.parametrize("error", [DISK_FULL, KeyboardInterrupt()], ids=["disk full", "interrupted"])
@pytest.mark.parametrize("k", [0, 1, 2])
@pytest.mark.parametrize("when", ["writing", "placing", "renaming"])
def test_several_files_are_written_all_or_none(tmp_path, monkeypatch, when, k, error):
    """Three files, two of them there before: whichever one fails, while the temporaries are
    written or while they are put in place one after the other, the files there before are left
    byte for byte, the absent one stays absent, and nothing is left behind."""
    a, b, c = tmp_path / "a.dxf", tmp_path / "b.csv", tmp_path / "c.json"
    a.write_bytes(b"my good drawing\n")
    c.write_bytes(b'{"my": "points"}\n')
    before = everything(tmp_path)
    if when == "writing":
        fail_on(monkeypatch, mjfiles, "_temporary", k, error)
    elif when == "placing":
        fail_on(monkeypatch, mjfiles, "_place", k, error)
    else:  # the rename onto the destination itself, after the previous file was kept aside
        fail_on(monkeypatch, os, "replace", k, error, only=lambda src, dst: str(src).endswith(".tmp"))
    with pytest.raises(OutputError if isinstance(error, OSError) else KeyboardInterrupt) as e:
        mjfiles.write_files([(a, "new a"), (b, "new b"), (c, b"new c")], force=True)
    assert everything(tmp_path) == before
    if isinstance(error, OSError):
        assert "\n" not in str(e.value) and "No space left" in str(e.value)


def test_several_files_all_written(tmp_path):
    a, b = tmp_path / "a.dxf", tmp_path / "b.csv"
    a.write_bytes(b"old")
    mjfiles.write_files([(a, "new a"), (b, b"new b")], force=True)
    assert everything(tmp_path) == {"a.dxf": b"new a", "b.csv": b"new b"}


def test_a_file_that_appears_meanwhile_is_kept_without_force(tmp_path):
    """Claimed while absent, there when the files are placed: kept, and the other file is not
    written either."""
    a, b = tmp_path / "a.dxf", tmp_path / "b.csv"
    targets = mjfiles.claim_outputs({"--dxf": a, "--points": b})
    b.write_bytes(b"appeared")
    with pytest.raises(OutputError, match=r"b\.csv: exists .*--force"):
        mjfiles.write_files([(targets["--dxf"], "new a"), (targets["--points"], "new b")])
    assert everything(tmp_path) == {"b.csv": b"appeared"}


def test_a_failed_export_keeps_the_earlier_good_files(tmp_path, monkeypatch):
    """The issue's case (--points into a folder that does not exist, refused before any work)
    and a second file that cannot be put in place after the first was: the earlier DXF and
    points file stay byte for byte, nothing is left behind."""
    dxf, pts = tmp_path / "A.dxf", tmp_path / "A.csv"
    assert in_process("export", "takeup", "--dxf", str(dxf), "--points", str(pts)).returncode == 0
    before = everything(tmp_path)
    missing = str(tmp_path / "no" / "P.csv")
    r = in_process("export", "takeup", "--angle", "30", "--dxf", str(dxf), "--points", missing, "--force")
    assert r.returncode == 1 and "does not exist" in r.stderr and everything(tmp_path) == before
    fail_on(monkeypatch, os, "replace", 1, DISK_FULL, only=lambda src, dst: str(src).endswith(".tmp"))
    r = in_process("export", "takeup", "--angle", "30", "--dxf", str(dxf), "--points", str(pts), "--force")
    assert r.returncode == 1 and r.stderr.count("\n") == 1 and "No space left" in r.stderr, r.stderr
    assert everything(tmp_path) == before


# ----------------------------------------------------------------------------- one loaded mechanism
def page_data(html):
    """The mechanism data design.html embeds (its JSON script)."""
    m = re.search(r"""id=['"]mechanism-data['"]>(.*?)</script>""", html, re.S)
    assert m is not None
    return json.loads(m[1])


@pytest.mark.parametrize("change", ["edited", "deleted", "made invalid"])
def test_every_output_of_a_run_comes_from_the_mechanism_it_loaded(tmp_path, change):
    """The file changes after it was loaded and before the run writes its outputs: the page
    and the report still describe the loaded design, and nothing reads the file again (an
    invalid file would raise TOMLDecodeError, a deleted one FileNotFoundError)."""
    import mjlink

    src = tmp_path / "mine.toml"
    text = EXAMPLE.replace('title = "Plain crank-rocker (example)"', 'title = "the loaded design"')
    src.write_text(text)
    mech = mjlink.load(src)
    if change == "edited":
        src.write_text(text.replace("the loaded design", "another design").replace("length = 15.0", "length = 12.0"))
    elif change == "deleted":
        src.unlink()
    else:
        src.write_text("[mechanism\nname = ")
    res = pipeline.run(mech, tmp_path / "out", FAST)
    data = page_data((res.out_dir / "design.html").read_text())
    assert data["text"] == text
    assert json.loads((res.out_dir / "report.json").read_text())["title"] == "the loaded design"
    page = pipeline.design.design_page(mech, tmp_path / "page.html")  # the design command's page too
    assert page_data(page.read_text())["text"] == text
    # a study's variants and winner files are derived from the loaded text too
    from mjlink.model import paths
    from mjlink.model.mechanism import parse

    length = paths.resolve(mech, "construct.B.length")
    varied = parse(paths.file_text(mech, {length: 16.0}, "a variant"), "variant.toml")
    assert varied.title == "the loaded design" and paths.catalogue(varied)["construct.B.length"].nominal == 16.0
    paths.check_values(mech, {length: 16.0})


# ----------------------------------------------------------------------------- names
@pytest.mark.parametrize(
    "name",
    [
        "../x",
        "..",
        ".",
        "a/b",
        "a\\b",
        "/etc/passwd",
        "~root",
        "x" * 33,
        "é",
        "Kurbel\u00e4",
        "a b",
        "a\n",
        "a\x00",
        "",
        "1abc",
        "_x",
        "a.b",
        "a-b",
        "CON:",
    ],
)
def test_names_that_could_escape_the_output_folder_are_rejected(tmp_path, name):
    quoted = "".join(c if c.isprintable() and c not in '"\\' else f"\\u{ord(c):04x}" for c in name)
    text = EXAMPLE.replace('name = "crank_rocker"', f'name = "{quoted}"')
    with pytest.raises(MechanismFileError, match=r"\[mechanism\] name: invalid name") as e:
        parse(text, tmp_path / "f.toml")
    assert "\n" not in str(e.value)


# The names mechanisms/README.md allows: a letter, then letters, digits or _, at most 32
# characters (ASCII), drawn from that sentence, not from the program's regular expression.
_NAMES = st.builds(
    operator.add,
    st.sampled_from(string.ascii_letters),
    st.text(string.ascii_letters + string.digits + "_", max_size=31),
)


@given(name=_NAMES)
@settings(max_examples=100, deadline=None, database=None)
def test_valid_names_stay_inside_the_output_folder(name):
    """Every name the rule allows is read as the mechanism's name, and the folder simulate
    writes (OUT/NAME) is a child of OUT."""
    mech = parse(EXAMPLE.replace('name = "crank_rocker"', f'name = "{name}"'), "named.toml")
    assert mech.name == name
    root = registry.MECHANISMS_DIR.parent / "renders"
    dest = root / mech.name
    assert dest.parent == root and dest.name == name and os.sep not in name and ".." not in name
    assert os.path.realpath(dest).startswith(os.path.realpath(root) + os.sep)


@given(names=st.lists(_NAMES, min_size=12, max_size=12, unique=True))
@settings(max_examples=40, deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow])
def test_every_valid_name_round_trips_through_the_mjcf(names):
    """Points, links and the mechanism renamed to arbitrary valid names: the file is either
    refused with a clear line (a reserved or clashing name) or its MJCF loads back with every
    name intact."""
    pts = ["A", "D", "B", "C", "E", "S1", "S2", "S3"]
    links = ["crank", "coupler", "rocker"]
    mapping = dict(zip(pts + links + ["crank_rocker"], names))
    # one pass, so that a new name equal to an old one is not renamed again
    text = re.sub(
        r'"([A-Za-z][A-Za-z0-9_]*)"',
        lambda m: (
            f'"{mapping.get(m.group(1), m.group(1))}"'
            if m.group(1) in pts or m.group(1) == "crank_rocker"
            else m.group(0)
        ),
        EXAMPLE,
    )
    text = re.sub(
        r"^([A-Za-z][A-Za-z0-9_]*) = \[",
        lambda m: f"{mapping.get(m.group(1), m.group(1))} = [" if m.group(1) in pts else m.group(0),
        text,
        flags=re.M,
    )
    text = re.sub(r"^\[links\.([A-Za-z][A-Za-z0-9_]*)\]", lambda m: f"[links.{mapping[m.group(1)]}]", text, flags=re.M)
    try:
        mech = validation.validate(parse(text, "renamed.toml"))
    except MechanismFileError as e:
        msg = str(e)
        assert "\n" not in msg
        assert re.search(r"reserved|would be the same as|share its name|defined twice", msg), msg
        return
    xml = builder.to_xml(mech)
    model = mujoco.MjModel.from_xml_string(xml)
    sites = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SITE, i) for i in range(model.nsite)}
    bodies = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, i) for i in range(model.nbody)}
    assert {mapping[p] for p in pts} <= sites
    assert {mapping[l] for l in links} <= bodies
    assert mech.name == mapping["crank_rocker"]


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    st.lists(st.floats(allow_nan=True, allow_infinity=True, width=64), min_size=1, max_size=40),
    st.integers(min_value=1, max_value=5),
)
def test_csv_numbers_read_back_exactly(tmp_path, values, width):
    """Every double, -0.0, NaN and the infinities come back from the CSV bit for bit (the
    shortest round-trip text), whatever the mix of (N,) and (N, m) columns."""
    import numpy as np

    rows = -(-len(values) // width)
    table = np.resize(np.array(values, dtype=float), (rows, width))
    cols = [table[:, 0], table[:, 1:]] if width > 1 else [table[:, 0]]
    names = [f"c{i}" for i in range(width)]
    mjfiles.write_table(tmp_path / "t.csv", names, cols)
    back = mjfiles.read_csv(tmp_path / "t.csv")
    got = np.column_stack([np.atleast_1d(back[n]) for n in names])
    assert np.array_equal(got, table, equal_nan=True)
    finite = ~np.isnan(table)
    assert np.array_equal(np.signbit(got[finite]), np.signbit(table[finite]))  # -0.0 stays -0.0


def test_csv_of_many_blocks_matches_one_block(tmp_path):
    """A table longer than a formatting block is written as the same text as row by row."""
    import numpy as np

    rng = np.random.default_rng(3)
    table = rng.standard_normal((30_000, 3)) * 10.0 ** rng.integers(-12, 12, (30_000, 3))
    table[17, 1], table[29_999, 2] = np.nan, -np.inf
    mjfiles.write_table(tmp_path / "t.csv", ["a", "b", "c"], [table])
    lines = (tmp_path / "t.csv").read_text().splitlines()
    assert lines[0] == "a,b,c" and len(lines) == 30_001 and all(line.count(",") == 2 for line in lines)
    assert np.array_equal(np.loadtxt(tmp_path / "t.csv", delimiter=",", skiprows=1), table, equal_nan=True)


def test_csv_refuses_names_that_do_not_match_the_columns(tmp_path):
    import numpy as np

    with pytest.raises(ValueError, match="3 column names"):
        mjfiles.write_table(tmp_path / "t.csv", ["a", "b", "c"], [np.ones(4), np.ones((4, 1))])
    assert mjfiles.write_table(tmp_path / "e.csv", ["a", "b"], []).read_text() == "a,b\n"
