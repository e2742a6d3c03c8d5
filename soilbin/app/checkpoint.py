"""Checkpoints: a run that stopped (killed, out of time, failed) goes on from its last step.

After every converged step the run folder's ``checkpoint/`` holds that step:
the problem's state (:meth:`SoilProblem.state`: the unknowns, the committed
history at the points, the tool's travel and contact state, the mesh's
position in large deformation) in ``state.npz``, and the steps so far and the
resolved scene in ``steps.json``. The state is stored by the mesh's input
cell numbering (``layout``: each cell's dofs, points and nodes; the contact
points by face and initial position), gathered on rank 0, so that it does not
depend on how the mesh was distributed: ``mpirun`` partitions the same mesh
differently from run to run, and a run may resume on another number of
ranks. A step's files are written into ``checkpoint.new/``, which then
replaces the last step's folder whole, so a kill at any moment leaves one
complete checkpoint (``checkpoint/``, or ``checkpoint.old/`` during the swap).

``soilbin run SCENE --resume FOLDER --out NEW`` reads it, builds the same
mesh, checks that it is the same (cell count, cell centres), puts the state on
it and takes the next step where the stopped run would have; NEW's curve.csv
begins with the earlier steps, its fields.xdmf with the initial state and then
the steps after the resume. The scene may differ from the checkpoint's in
``[solver]``, ``[output]`` and ``[headline]`` (and the title) only.
"""
import dataclasses
import json
import shutil
import tomllib
from pathlib import Path

import numpy as np
from mpi4py import MPI
from scipy.spatial import cKDTree

from ..errors import InputError
from ..layout import CONTACT, GLOBAL, CellLayout, gather_rows
from ..solver.stepping import StepRecord
from .interrupt import deferred

FOLDER = "checkpoint"
#: The stored arrays' prefix of the remeshing's state.
REMESH = "remesh"
#: Scene tables and keys a resumed run may change: how it solves, what it writes and reports,
#: how often a remesh that failed is tried again, and the soil's contact with itself (it
#: keeps no state: a run stopped where the soil folded onto itself goes on with it).
FREE = ("title", "solver", "output", "headline", "remesh.retries", "soil_contact")
#: Tolerance of the same point of the mesh in two runs, relative to the mesh's size (its
#: coordinates are the same; an interpolated one differs by round-off).
SAME_MESH = 1e-12


class Checkpoints:
    """Writes a run folder's checkpoint after each converged step (collective)."""

    def __init__(self, folder, problem, scene, remeshing=None):
        self._path = Path(folder) / FOLDER
        self._problem, self._scene = problem, scene
        self._comm = problem.comm
        self._remeshing = remeshing
        self._cells = CellLayout(problem)
        self._centres = self._cells.gather(self._cells.centres[:self._cells.n_owned])

    def remeshed(self, problem):
        """The run goes on on ``problem``'s new mesh (its cells as the remesher made them)."""
        self._problem, self._cells = problem, self._remeshing.layout
        self._centres = self._cells.gather(self._cells.centres[:self._cells.n_owned])

    def _arrays(self):
        """The problem's state as stored (on rank 0; None elsewhere)."""
        cells = self._cells
        keys = None if cells.contact is None else gather_rows(self._comm, cells.contact)
        state = cells.gather_state(self._problem.state())
        if state is None:
            return None
        arrays = {"centres": self._centres}
        if keys is not None:
            arrays[f"{CONTACT}/keys"] = keys
        arrays.update({f"{kind}/{name}": values for name, (kind, values) in state.items()})
        if self._remeshing is not None:
            arrays.update({f"{REMESH}/{name}": values
                           for name, values in self._remeshing.state().items()})
        return arrays

    def write(self, records):
        comm = self._comm
        new, old = self._path.with_name(FOLDER + ".new"), self._path.with_name(FOLDER + ".old")
        with deferred():
            arrays = self._arrays()
            if comm.rank != 0:
                return
            shutil.rmtree(new, ignore_errors=True)
            new.mkdir()
            with open(new / "state.npz", "wb") as f:
                np.savez(f, **arrays)
            steps = {"scene": self._scene.resolved(),
                     "steps": [dataclasses.asdict(r) for r in records]}
            if self._remeshing is not None and self._remeshing.mesh_file is not None:
                tagged = self._problem.tagged
                steps["mesh"] = {"file": self._remeshing.mesh_file,
                                 "regions": tagged.regions, "boundaries": tagged.boundaries}
            (new / "steps.json").write_text(json.dumps(steps) + "\n")
            if self._path.exists():
                self._path.rename(old)
            new.rename(self._path)
            shutil.rmtree(old, ignore_errors=True)


@dataclasses.dataclass(frozen=True)
class Checkpoint:
    """A checkpoint read back: the steps taken and the stored state; ``mesh``: the file (in
    the run folder) and group tags of the remeshed mesh the run was on, or None."""
    folder: Path
    records: tuple
    arrays: dict
    mesh: dict = None

    def remeshing_state(self):
        """The remeshing's :meth:`~soilbin.remesh.Remeshing.state`."""
        return {key.partition("/")[2]: values for key, values in self.arrays.items()
                if key.startswith(f"{REMESH}/")}

    def _mismatch(self, what):
        return InputError(f"--resume {self.folder}: the mesh differs from the checkpoint's "
                          f"({what}; a different gmsh version or mesh file?)")

    def restore(self, problem, layout=None):
        """Put ``problem`` (built from the same scene, or on the remeshed mesh, not yet
        stepped; ``layout``: its cells', if taken already) at the checkpoint's last step;
        InputError (on every rank) if its mesh is not the checkpoint's."""
        cells, arrays = layout or CellLayout(problem), self.arrays
        if len(arrays["centres"]) != cells.n_global:
            raise self._mismatch(f"{cells.n_global} cells, not {len(arrays['centres'])}")
        scale = np.abs(arrays["centres"]).max()
        same = np.allclose(arrays["centres"][cells.number], cells.centres, rtol=0.0,
                           atol=SAME_MESH * scale)
        state, contact = {}, None
        if same and cells.contact is not None:
            contact = _match(arrays[f"{CONTACT}/keys"], cells.contact, SAME_MESH * scale)
            same = contact is not None
        if not problem.comm.allreduce(same, op=MPI.LAND):
            raise self._mismatch("cells or contact points elsewhere")
        for key, values in arrays.items():
            kind, _, name = key.partition("/")
            if not name or name == "keys" or kind == REMESH:
                continue
            state[name] = (values if kind == GLOBAL else values[contact] if kind == CONTACT
                           else cells.local(kind, values))
        try:
            problem.restore(state)
        except KeyError as err:
            raise InputError(f"--resume {self.folder}: the checkpoint lacks {err} (written by "
                             f"another version of soilbin); run the scene afresh") from None


def _match(stored, local, tolerance):
    """The row of ``stored`` contact point keys (face tag, x, y, z) of each ``local`` one, or
    None if one has none within ``tolerance`` (the coordinates are interpolated, so the same
    point differs by round-off from one partition to another)."""
    rows = np.empty(len(local), dtype=np.int64)
    for face in np.unique(local[:, 0]):
        mine, theirs = np.flatnonzero(local[:, 0] == face), np.flatnonzero(stored[:, 0] == face)
        if not len(theirs):
            return None
        distance, nearest = cKDTree(stored[theirs, 1:]).query(local[mine, 1:])
        if (distance > tolerance).any():
            return None
        rows[mine] = theirs[nearest]
    return rows


def _differences(old, new, path=""):
    """Dotted keys whose values differ between two parsed scenes, the free ones left out."""
    keys = [k for k in sorted(set(old) | set(new)) if f"{path}{k}" not in FREE]
    out = []
    for key in keys:
        a, b = old.get(key), new.get(key)
        if isinstance(a, dict) and isinstance(b, dict):
            out += _differences(a, b, f"{path}{key}.")
        elif a != b:
            out.append(f"{path}{key}")
    return out


def read(folder, scene):
    """The checkpoint in run folder ``folder`` for ``scene``; InputError (the folder, what
    does not match) if there is none or it is another scene's."""
    folder = Path(folder)
    found = [folder / name for name in (FOLDER, FOLDER + ".old")
             if (folder / name / "steps.json").is_file()]
    if not found:
        raise InputError(f"--resume {folder}: no checkpoint there (a run folder has one in "
                         f"{FOLDER}/ after its first converged step)")
    path = found[0]
    try:
        steps = json.loads((path / "steps.json").read_text())
        old_scene = tomllib.loads(steps["scene"])
        with np.load(path / "state.npz") as data:
            arrays = {key: data[key] for key in data.files}
    except (OSError, ValueError, KeyError) as err:
        raise InputError(f"--resume {folder}: {path} is unreadable ({err})") from None
    changed = _differences(old_scene, tomllib.loads(scene.resolved()))
    if changed:
        raise InputError(f"--resume {folder}: the scene differs from the checkpoint's in "
                         f"{', '.join(changed)} (only {', '.join(FREE)} may change)")
    records = tuple(StepRecord(**{**r, "residuals": tuple(r["residuals"])})
                    for r in steps["steps"])
    return Checkpoint(folder, records, arrays, steps.get("mesh"))
