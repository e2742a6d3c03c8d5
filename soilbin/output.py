"""The run folder: resolved scene, curve.csv, summary.json and XDMF fields.

Rows and fields are written as each step converges, so a run that stops
early keeps everything it reached. Quadrature data go to ParaView as cell
averages (DG0): the exact mean over each cell with the solver's own rule.
"""
import csv
import json
from pathlib import Path

import numpy as np
import ufl
from petsc4py import PETSc
from dolfinx import fem, io
import dolfinx.fem.petsc  # noqa: F401

from .scene import Field
from .solver.quadrature import quadrature_space
from .tensors import ufl_from_mandel

CURVE_COLUMNS = ("step", "load_factor", "displacement", "force", "pressure",
                 "newton_iterations", "cuts", "wall_s")


class CellAverage:
    """Cell means of a quadrature-point UFL expression, written into a DG0 Function."""

    def __init__(self, disc, expression, target):
        dx = disc.measure()
        test = ufl.TestFunction(target.function_space)
        ones = ufl.as_tensor(np.ones(test.ufl_shape).tolist()) if test.ufl_shape else 1.0
        self._form = fem.form(ufl.inner(expression, test) * dx)
        self._volume = fem.form(ufl.inner(ones, test) * dx)   # the mesh may move: per call
        self._target = target

    @staticmethod
    def _assemble(form):
        b = fem.petsc.assemble_vector(form)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        return b

    def __call__(self):
        b, volume = self._assemble(self._form), self._assemble(self._volume)
        b.pointwiseDivide(b, volume)
        b.copy(self._target.vector)
        self._target.x.scatter_forward()
        b.destroy()
        volume.destroy()


class FieldWriter:
    """XDMF time series of the fields a scene asks for (nothing is built for the others)."""

    def __init__(self, path, problem, fields):
        mesh = problem.disc.mesh
        self._xdmf = io.XDMFFile(mesh.comm, str(path), "w")
        self._xdmf.write_mesh(mesh)
        # Large deformation moves the mesh: fields are written on the initial
        # mesh, with the total displacement to warp it by in ParaView.
        self._x = mesh.geometry.x
        self._reference_x = self._x.copy() if problem.large else None
        self._updates, self._functions = [], []
        if Field.DISPLACEMENT in fields:
            self._functions.append(problem.displacement_p1())
            self._updates.append(problem.displacement_p1)
        if Field.STRESS in fields:
            s = fem.Function(fem.TensorFunctionSpace(mesh, ("DG", 0)), name="stress")
            self._updates.append(CellAverage(problem.disc, ufl_from_mandel(problem.points.stress), s))
            self._functions.append(s)
        if Field.PLASTIC_STRAIN in fields:
            q = fem.Function(quadrature_space(mesh, problem.disc.element.quadrature_degree))
            e = fem.Function(fem.FunctionSpace(mesh, ("DG", 0)), name="plastic_strain")
            average = CellAverage(problem.disc, q, e)
            points = problem.points

            def update():
                points.write(points.history("eps_p_eq"), q)
                average()
            self._updates.append(update)
            self._functions.append(e)

        if Field.GAP in fields and problem.contact is not None:
            gap = fem.Function(problem.contact.scalar_space, name="gap")
            contact = problem.contact

            def update_gap():   # the widest opening of a node over the faces it touches
                gap.x.array[:] = 0.0
                np.maximum.at(gap.x.array, contact.nodes, contact.gap())
                gap.x.scatter_forward()
            self._updates.append(update_gap)
            self._functions.append(gap)

    def write(self, t):
        for update in self._updates:
            update()
        if self._reference_x is not None:
            current = self._x.copy()
            self._x[:] = self._reference_x
        for f in self._functions:
            self._xdmf.write_function(f, t)
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
