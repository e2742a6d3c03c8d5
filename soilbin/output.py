"""The run folder: resolved scene, curve.csv, summary.json and XDMF fields.

Rows and fields are written as each step converges, so a run that stops
early keeps everything it reached.
"""
import csv
import json
from pathlib import Path

from dolfinx import io

CURVE_COLUMNS = ("step", "load_factor", "displacement", "force", "pressure",
                 "newton_iterations", "cuts", "wall_s")


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
                csv.writer(f).writerow(CURVE_COLUMNS)
        self._area = problem.area
        self._fields = (FieldWriter(self.path / "fields.xdmf", problem, scene.output.fields)
                        if scene.output.fields else None)
        self._every = scene.output.every
        self._last = None

    def add_step(self, record):
        if self._rank0:
            with open(self.path / "curve.csv", "a", newline="") as f:
                csv.writer(f).writerow([record.step, f"{record.load_factor:.10g}",
                                        f"{record.displacement:.10g}", f"{record.force:.10g}",
                                        f"{record.force / self._area:.10g}", record.newton_iterations,
                                        record.cuts, f"{record.wall_s:.4f}"])
        if self._fields is not None and record.step % self._every == 0:
            self._fields.write(record.load_factor)
        self._last = record

    def finish(self, summary):
        """Fields of the last converged step (if not yet written), summary.json, close."""
        if self._fields is not None:
            if self._last is not None and self._last.step % self._every != 0:
                self._fields.write(self._last.load_factor)
            self._fields.close()
        if self._rank0:
            (self.path / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
