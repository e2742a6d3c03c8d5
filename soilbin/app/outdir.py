"""The run folder on disk, before a run: made, checked writable, cleared of an older run.

No FEniCSx here: the command line checks ``--out`` before any mesh is built.
Only the files a run writes are removed (:data:`RUN_FILES`); anything else a
user keeps in the folder stays.
"""
import shutil
from pathlib import Path

from ..errors import InputError

#: What ``soilbin run`` writes into its folder (file patterns, and the folder of field frames).
RUN_FILES = ("scene.toml", "curve.csv", "curve.png", "summary.json", "fields.xdmf", "fields.h5",
             "tool.xdmf", "tool-section.png", "sections-*.png", "soil-3d.png", "traceback*.txt",
             "remeshes.csv")
FRAMES_DIR = "fields"
#: Folders a run writes: its checkpoint (``app.checkpoint``), also while one replaces another,
#: and the meshes a remeshing run made.
RUN_FOLDERS = (FRAMES_DIR, "checkpoint", "checkpoint.new", "checkpoint.old", "meshes")


def writable(path, keep=True):
    """Check that the folder ``path`` takes files (InputError naming --out): made where
    missing, and left made only if ``keep``."""
    path = Path(path)
    probe = path / ".soilbin-write-test"
    if path.exists() and not path.is_dir():
        raise InputError(f"--out {path}: a file, not a folder")
    made = next((folder for folder in reversed((path, *path.parents)) if not folder.exists()),
                None)
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe.write_text("")
        probe.unlink()
    except OSError as err:
        raise InputError(f"--out {path}: cannot write there ({err.strerror or err})") from None
    finally:
        if made is not None and not keep:
            shutil.rmtree(made, ignore_errors=True)
    return path


def prepare(path):
    """Make ``path``, check that it takes files, and remove an older run's files."""
    path = writable(path)
    for pattern in RUN_FILES:
        for name in path.glob(pattern):
            name.unlink(missing_ok=True)
    for folder in RUN_FOLDERS:
        shutil.rmtree(path / folder, ignore_errors=True)
    return path


def prepare_on_rank0(comm, path):
    """:func:`prepare` on rank 0; every rank raises its InputError (no rank is left waiting)."""
    return _on_rank0(comm, prepare, path)


def writable_on_rank0(comm, path, keep=True):
    """:func:`writable` on rank 0 (``comm`` None: this process alone), every rank raising its
    InputError."""
    return _on_rank0(comm, lambda folder: writable(folder, keep), path)


def _on_rank0(comm, check, path):
    error = None
    if comm is None or comm.rank == 0:
        try:
            check(path)
        except InputError as err:
            error = str(err)
    if comm is not None:
        error = comm.bcast(error, root=0)
    if error is not None:
        raise InputError(error)
    return Path(path)
