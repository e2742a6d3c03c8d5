"""The run folder: resolved scene, curve.csv, summary.json and XDMF fields.

Rows and fields are written as each step converges, so a run that stops
early keeps everything it reached.
"""
import csv
import json
from pathlib import Path

from dolfinx import io

#: Every column a curve.csv may have; a run writes the step, what its problem observes
#: (a loaded boundary: pressure; a tool: lift and the soil's volume change ahead of it)
#: and Newton's effort.
CURVE_COLUMNS = ("step", "load_factor", "displacement", "force", "pressure", "lift",
                 "front_volumetric_strain", "newton_iterations", "cuts", "wall_s")
OBSERVED = ("pressure", "lift", "front_volumetric_strain")


def curve_columns(problem):
    """The columns of this problem's curve.csv."""
    return tuple(c for c in CURVE_COLUMNS if c not in OBSERVED or c in problem.curve_columns)


class FieldWriter:
    """XDMF time series of the problem's named output fields."""

    def __init__(self, path, problem, fields):
        mesh = problem.mesh
        self._xdmf = io.XDMFFile(mesh.comm, str(path), "w")
        self._xdmf.write_mesh(mesh)
        # Large deformation moves the mesh: fields are written on the initial
        # mesh, with the total displacement to warp it by in ParaView.
        self._x = mesh.geometry.x
        self._reference_x = self._x.copy() if problem.moves_mesh else None
        self._fields = list(problem.output_fields(fields).values())

    def write(self, t):
        for _, update in self._fields:
            update()
        if self._reference_x is not None:
            current = self._x.copy()
            self._x[:] = self._reference_x
        for function, _ in self._fields:
            self._xdmf.write_function(function, t)
        if self._reference_x is not None:
            self._x[:] = current

    def close(self):
        self._xdmf.close()


class RunFolder:
    """One folder per run. Only rank 0 writes the text files."""

    def __init__(self, path, problem, scene):
        self.path = Path(path)
        self._rank0 = problem.comm.rank == 0
        if self._rank0:
            self.path.mkdir(parents=True, exist_ok=True)
            (self.path / "scene.toml").write_text(scene.resolved())
            with open(self.path / "curve.csv", "w", newline="") as f:
                csv.writer(f).writerow(curve_columns(problem))
        self._fields = (FieldWriter(self.path / "fields.xdmf", problem, scene.output.fields)
                        if scene.output.fields else None)
        self._every = scene.output.every
        self._stops = scene.output.stops(scene.loading)
        self._last = None

    def add_step(self, record):
        if self._rank0:
            with open(self.path / "curve.csv", "a", newline="") as f:
                csv.writer(f).writerow([record.step, f"{record.load_factor:.10g}",
                                        f"{record.displacement:.10g}", f"{record.force:.10g}",
                                        *(f"{v:.10g}" for v in record.columns.values()),
                                        record.newton_iterations,
                                        record.cuts, f"{record.wall_s:.4f}"])
        if self._fields is not None and self.writes_fields(record):
            self._fields.write(record.load_factor)
        self._last = record

    def writes_fields(self, record):
        """Fields are written every ``every`` steps, at the stated loads and at the end."""
        return (record.step % self._every == 0
                or any(abs(record.load_factor - stop) < 1e-9 for stop in self._stops))

    def finish(self, summary):
        """Fields of the last converged step (if not yet written), summary.json, close."""
        if self._fields is not None:
            if self._last is not None and not self.writes_fields(self._last):
                self._fields.write(self._last.load_factor)
            self._fields.close()
        if self._rank0:
            (self.path / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
