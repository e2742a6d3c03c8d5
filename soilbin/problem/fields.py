"""Named output fields of a problem: a Function each, and how to bring it up to date.

Quadrature data go out as cell averages (DG0): the exact mean over each cell
with the solver's own rule. Only the fields asked for are built.
"""
import numpy as np
import ufl
from petsc4py import PETSc
from dolfinx import fem
import dolfinx.fem.petsc  # noqa: F401

from ..records.scene import Field
from ..solver.quadrature import quadrature_space
from ..tensors import ufl_from_mandel


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


def _displacement(problem):
    return problem.displacement(), problem.displacement


def _stress(problem):
    mesh = problem.mesh
    s = fem.Function(fem.TensorFunctionSpace(mesh, ("DG", 0), shape=(3, 3)), name="stress")
    return s, CellAverage(problem.disc, ufl_from_mandel(problem.points.stress), s)


def _plastic_strain(problem):
    mesh, points = problem.mesh, problem.points
    q = fem.Function(quadrature_space(mesh, problem.disc.element.quadrature_degree))
    e = fem.Function(fem.FunctionSpace(mesh, ("DG", 0)), name="plastic_strain")
    average = CellAverage(problem.disc, q, e)

    def update():
        points.write(points.history("eps_p_eq"), q)
        average()
    return e, update


def _gap(problem):
    interface = problem.tool.interface
    gap = fem.Function(interface.scalar_space, name="gap")

    def update():   # the widest opening of a node over the faces it touches
        gap.x.array[:] = 0.0
        np.maximum.at(gap.x.array, interface.nodes, interface.gap())
        gap.x.scatter_forward()
    return gap, update


_BUILDERS = {Field.DISPLACEMENT: _displacement, Field.STRESS: _stress,
             Field.PLASTIC_STRAIN: _plastic_strain, Field.GAP: _gap}


def build(problem, names):
    """name -> (Function, update) for the fields asked for; the gap only with an interface."""
    has_interface = problem.tool is not None and problem.tool.interface is not None
    return {name: _BUILDERS[name](problem) for name in names
            if name is not Field.GAP or has_interface}
