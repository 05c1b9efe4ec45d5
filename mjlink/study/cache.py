"""The resume cache of a study: its finished chunks on disk, valid only for what made them.

A study interrupted (Ctrl-C, a lost cluster, a killed process) and run again takes its finished
chunks from ``OUT/.NAME-study.chunks/`` instead of computing them anew. A chunk is reused only
if everything that determines it is unchanged, as the folder's manifest (``cache.json``)
records it:

* ``definition``: the study file's text (its sampling, parameters, metrics, bounds, [set]);
* ``mechanism``: the text of the mechanism file it resolved to;
* ``code``: mjlink's own source (every module of the package: a metric's code changed with
  the version number unchanged must not serve old numbers), with the versions of mjlink,
  numpy, scipy and MuJoCo;
* ``chunking``: the number of variants, the chunk bounds and the crank angles per turn.

On any difference the cached chunks are discarded, with one line saying what changed
(:mod:`mjlink.notes`), and computed anew. Every chunk file carries a SHA-256 of its arrays; a
truncated or corrupt chunk (a disk full, a copy cut short) is detected, said in one line,
removed and computed anew, never a traceback. Files are plain ``.npz`` (no pickles: a cache
file is data, never code), each written atomically.

Only a folder mjlink made is ever used or removed: it is born with its manifest (made under a
temporary name, then renamed into place), and a folder of that name without one (a user's, a
link) makes the study refuse to start.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import importlib.metadata
import json
import os
import shutil
import tempfile
import zipfile
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from ..errors import InputError
from ..files import atomic_path, read_json
from ..notes import note
from ..version import __version__
from .spec import Study

FORMAT = 2  # the manifest's layout (1: {study, digest, version}, before the manifest named its parts)
MANIFEST = "cache.json"
CHECKSUM = "__sha256__"  # the array in every chunk file holding the SHA-256 of the others

# What each manifest entry is, for the line that says why a cache was discarded.
_PARTS = {
    "study": "the study's name",
    "definition": "the study file",
    "mechanism": "the mechanism file",
    "code": "mjlink's code",
    "versions": "the versions of mjlink or its libraries",
    "chunking": "the chunking",
}


class CacheError(InputError):
    """The cache folder's place is taken by something mjlink did not make (exit status 2)."""


@functools.cache
def code_digest() -> str:
    """SHA-256 (16 hex digits) of mjlink's source: every ``.py`` file of the package, by its
    path inside the package and its bytes. Where the source cannot be read (an import from a
    zip), mjlink's version stands in for it."""
    root = Path(__file__).resolve().parent.parent
    h = hashlib.sha256()
    try:
        for f in sorted(root.rglob("*.py")):
            h.update(f.relative_to(root).as_posix().encode() + b"\0")
            h.update(f.read_bytes() + b"\0")
    except OSError:
        return f"version {__version__}"
    return h.hexdigest()[:16]


def _version(dist: str) -> str:
    try:
        return importlib.metadata.version(dist)
    except importlib.metadata.PackageNotFoundError:
        return ""


def manifest(study: Study, variants: int, chunking: Mapping[str, Any]) -> dict[str, Any]:
    """What a cache of ``study`` with ``variants`` variants cut by ``chunking`` must match."""
    return {
        "written_by": "mjlink",
        "kind": "study-cache",
        "format": FORMAT,
        "study": study.name,
        "definition": study.definition_digest,
        "mechanism": study.mechanism_digest,
        "code": code_digest(),
        "versions": {
            "mjlink": __version__,
            "numpy": np.__version__,
            "scipy": _version("scipy"),
            "mujoco": _version("mujoco"),
        },
        "chunking": {"variants": variants, "angles_per_turn": study.per_turn, **chunking},
    }


def _read_manifest(folder: Path) -> dict[str, Any] | None:
    """The folder's manifest if mjlink wrote it (this format or the first), else None."""
    data = read_json(folder / MANIFEST)
    if not isinstance(data, dict):
        return None
    if data.get("written_by") == "mjlink" and data.get("kind") == "study-cache":
        return data
    if set(data) == {"study", "digest", "version"} and data["version"] == 1:  # the first format
        return data
    return None


def check(folder: Path) -> None:
    """Refuse (CacheError) a ``folder`` that is not a cache mjlink made: anything there that is
    not a real folder with mjlink's manifest. Absent is fine. Nothing is changed."""
    if not os.path.lexists(folder):
        return
    if folder.is_symlink() or not folder.is_dir() or _read_manifest(folder) is None:
        raise CacheError(
            f"{folder} is in the way of the study's resume cache: mjlink did not make it (no {MANIFEST} of "
            "mjlink's in it); move it away"
        )


class Cache:
    """The finished chunks of one study on disk (see the module docstring).

    Args:
      folder: the cache folder (None: no cache; every method then does nothing).
      study: the study.
      variants: how many variants it has.
      chunking: how they are cut (recorded: a different cut makes other chunks).

    On creation an existing folder is checked (:func:`check`) and, if its manifest differs,
    emptied with a note; the folder itself is made at the first chunk saved.
    """

    def __init__(self, folder: Path | None, study: Study, variants: int = 0, chunking: Mapping[str, Any] = {}):
        self.folder = folder
        self.want = manifest(study, variants, chunking)
        self.resumable = 0  # chunk files found valid for this study when opened
        if folder is None:
            return
        check(folder)
        have = _read_manifest(folder) if os.path.lexists(folder) else None
        if have is None:
            return
        changed = [k for k in _PARTS if have.get(k) != self.want[k]] if have.get("format") == FORMAT else ["format"]
        if changed:
            n = sum(1 for p in folder.iterdir() if p.suffix == ".npz")
            what = "an older mjlink" if changed == ["format"] else " and ".join(_PARTS[k] for k in changed)
            note(
                f"discarding the {n} cached chunk(s) in {folder}: they were computed before {what} changed; "
                "computing them anew"
            )
            shutil.rmtree(folder, ignore_errors=True)
        else:
            self.resumable = sum(1 for p in folder.iterdir() if p.suffix == ".npz")
            if self.resumable:
                note(f"resuming: {self.resumable} finished chunk(s) in {folder} are taken as they are")

    def _file(self, kind: str, start: int, stop: int) -> Path | None:
        return None if self.folder is None else self.folder / f"{kind}-{start:08d}-{stop:08d}.npz"

    def load(
        self, kind: str, start: int, stop: int, valid: Callable[[dict[str, np.ndarray]], bool] = lambda z: True
    ) -> dict[str, np.ndarray] | None:
        """A chunk's arrays, or None if it is not cached. A chunk that is damaged (unreadable,
        its checksum wrong) or not what ``valid`` expects is said so, removed, and None."""
        f = self._file(kind, start, stop)
        if f is None or not f.is_file():
            return None
        try:
            with np.load(f, allow_pickle=False) as z:
                arrays = {k: z[k] for k in z.files}
            why = "its checksum does not match" if _digest(arrays) != arrays.pop(CHECKSUM).tobytes() else ""
            if not why and not valid(arrays):
                why = "it does not hold what the study computes"
        except Exception as e:
            why = f"it cannot be read ({type(e).__name__})"
        if why:
            note(f"cached chunk {f.name} is damaged ({why}); computing it anew")
            with contextlib.suppress(OSError):
                f.unlink()
            return None
        return arrays

    def save(self, kind: str, start: int, stop: int, arrays: dict[str, Any]) -> None:
        """Write a chunk atomically, with its checksum (the folder is made first if need be)."""
        f = self._file(kind, start, stop)
        if f is None:
            return
        self._make()
        arrays = {k: np.asarray(v) for k, v in arrays.items()}
        arrays[CHECKSUM] = np.frombuffer(_digest(arrays), dtype=np.uint8)
        with atomic_path(f, suffix=".npz") as tmp, open(tmp, "wb") as fh:
            _write_npz(fh, arrays)

    def _make(self) -> None:
        """The folder, born with its manifest: made under a temporary name, then renamed."""
        assert self.folder is not None
        if os.path.lexists(self.folder):
            check(self.folder)
            return
        self.folder.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f"{self.folder.name}.new-", dir=self.folder.parent))
        try:
            (tmp / MANIFEST).write_text(json.dumps(self.want, indent=1) + "\n", encoding="utf-8")
            os.rename(tmp, self.folder)
        except OSError:
            shutil.rmtree(tmp, ignore_errors=True)
            check(self.folder)  # made by another run meanwhile: it must be a cache too
            if not os.path.lexists(self.folder):
                raise

    def remove(self) -> None:
        """Remove the cache (the study's outputs are published): only if it is mjlink's."""
        remove(self.folder)


def _write_npz(fh: BinaryIO, arrays: dict[str, np.ndarray]) -> None:
    """``np.savez``'s format, with the archive closed however the write ends: numpy 1.26's
    savez leaves it open on an interrupt (Ctrl-C while a chunk is written), and the archive's
    finaliser then writes to the closed file as the process exits, printing a traceback."""
    with zipfile.ZipFile(fh, mode="w", compression=zipfile.ZIP_STORED, allowZip64=True) as zf:
        for key, val in arrays.items():
            with zf.open(key + ".npy", "w", force_zip64=True) as member:
                np.lib.format.write_array(member, val, allow_pickle=False)


def remove(folder: Path | None) -> None:
    """Remove a cache folder once its study's outputs are published: only if it is mjlink's (its
    manifest is there) and not a link. Its manifest is not compared with anything: opening a
    :class:`Cache` to remove it would judge the chunks against a study of unknown size and say
    they were discarded."""
    if folder is not None and os.path.lexists(folder) and _read_manifest(folder) is not None:
        if not folder.is_symlink():
            shutil.rmtree(folder, ignore_errors=True)


def _digest(arrays: Mapping[str, np.ndarray]) -> bytes:
    """SHA-256 of the arrays: each one's name, dtype, shape and bytes, in name order."""
    h = hashlib.sha256()
    for k in sorted(arrays):
        if k == CHECKSUM:
            continue
        a = np.ascontiguousarray(arrays[k])
        h.update(f"{k}\0{a.dtype.str}\0{a.shape}\0".encode())
        h.update(a.tobytes())
    return h.digest()
