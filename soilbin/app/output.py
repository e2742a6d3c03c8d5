"""The run folder: resolved scene, curve.csv, summary.json and the XDMF fields.

Rows and fields are written as each step converges, each file complete before
the next step starts (a signal waits for the write to end), so a run that
stops early, or is killed, keeps everything it reached, readable.
"""
import csv
import dataclasses
import json
from pathlib import Path

import numpy as np
from dolfinx.cpp.io import perm_vtk
from dolfinx.cpp.mesh import entities_to_geometry
from dolfinx.mesh import CellType

from ..elements import embedding
from ..records.scene import TOOL
from .interrupt import deferred
from .xdmf import XdmfSeries

#: Every column a curve.csv may have; a run writes the step, what its problem observes
#: (a loaded boundary: pressure; a tool: lift, the soil's volume change ahead of it and its
#: heave; the force of the soil pressing on itself) and Newton's effort.
CURVE_COLUMNS = ("step", "load_factor", "displacement", "force", "pressure", "lift",
                 "front_volumetric_strain", "heave", "mesh_quality", "soil_contact_force",
                 "newton_iterations", "cuts", "wall_s")
OBSERVED = ("pressure", "lift", "front_volumetric_strain", "heave", "mesh_quality",
            "soil_contact_force")
#: The file of the remeshes' reports (a remeshing run).
REMESHES = "remeshes.csv"
#: The XDMF topology of each cell the soil's meshes and the tool's faces are made of.
XDMF_CELLS = {CellType.hexahedron: "Hexahedron", CellType.quadrilateral: "Quadrilateral",
              CellType.tetrahedron: "Tetrahedron", CellType.triangle: "Triangle"}


def curve_columns(problem):
    """The columns of this problem's curve.csv."""
    return tuple(c for c in CURVE_COLUMNS if c not in OBSERVED or c in problem.curve_columns)

#: Written into fields.xdmf and tool.xdmf (XML Information and HDF5 attributes).
CONVENTIONS = {
    "time": "the load factor (0: the initial state, 1: the full load)",
    "mesh": "the initial configuration (of a remeshed grid: where its nodes' soil was at the "
            "start); warp it by 'displacement' to see the deformed one",
    "displacement": "total displacement from the initial configuration [length]",
    "stress": "Cauchy stress, cell average, tension positive (compression negative) "
              "[force/area]",
    "plastic_strain": "equivalent plastic strain, cell average (0 where elastic)",
    "gap": "opening between soil and tool at the contact nodes, >= 0 [length]",
}


def _text(value):
    return f"{value:.10g}" if isinstance(value, float) else value


def _gather(comm, array):
    parts = comm.gather(np.ascontiguousarray(array), root=0)
    return np.concatenate(parts) if comm.rank == 0 else None


class MeshData:
    """The soil mesh as one process writes it: the nodes of the P1 displacement space in
    global order and in the scene's three coordinates (less the P1 ``displacement`` where
    given: a remeshed mesh's nodes where its soil was at the start), its cells (VTK node
    order, their XDMF :attr:`topology`), and any field's node or cell values (a vector of a
    two-dimensional mesh with its y component 0)."""

    def __init__(self, point_space, displacement=None):
        mesh = point_space.mesh
        self.comm = mesh.comm
        self._dim = mesh.geometry.dim
        imap = point_space.dofmap.index_map
        self._owned = imap.size_local
        self._n_cells = mesh.topology.index_map(mesh.topology.dim).size_local
        self._cell_nodes = point_space.dofmap.list.array.reshape(
            -1, point_space.dofmap.cell_dofs(0).size)
        cells = imap.local_to_global(self._cell_nodes[:self._n_cells].ravel())
        cell_type = mesh.topology.cell_type
        self.topology = XDMF_CELLS[cell_type]
        perm = perm_vtk(cell_type, self._cell_nodes.shape[1])
        x = point_space.tabulate_dof_coordinates()[:self._owned, :self._dim]
        if displacement is not None:   # a mesh made in the deformed configuration
            x = x - displacement.x.array.reshape(-1, self._dim)[:self._owned]
        self.points = _gather(self.comm, x @ embedding(self._dim).T)
        self.cells = _gather(self.comm, cells.reshape(-1, self._cell_nodes.shape[1])[:, perm])

    def values(self, function):
        """(True, node values) of a Lagrange field, (False, cell values) of a DG0 one."""
        space = function.function_space
        bs = space.dofmap.index_map_bs
        local = function.x.array.reshape(-1, bs)
        if bs == self._dim == 2:   # a vector in the x-z plane
            local = local @ embedding(2).T
            bs = 3
        dofs = space.dofmap.list.array.reshape(len(self._cell_nodes), -1)
        if space.ufl_element().degree() == 0:
            values, on_nodes = local[dofs[:self._n_cells, 0]], False
        else:   # the vertex dofs come first in every Lagrange cell
            where = np.empty(self._cell_nodes.max() + 1, dtype=np.int64)
            where[self._cell_nodes] = dofs[:, :self._cell_nodes.shape[1]]
            values, on_nodes = local[where[:self._owned]], True
        gathered = _gather(self.comm, values)
        return on_nodes, (gathered if gathered is None or bs > 1 else gathered[:, 0])


def tool_surface(problem):
    """(points, cells, XDMF topology) of the faces the tool acts on, initial geometry, in
    the scene's three coordinates: quadrilaterals or triangles, or the segments of a 2D mesh."""
    mesh, tagged = problem.mesh, problem.tagged
    dim = mesh.topology.dim - 1
    owned = mesh.topology.index_map(dim).size_local
    facets = np.concatenate([tagged.facet_tags.find(tagged.boundaries[face])
                             for face in problem.scene.tool.faces])
    facets = np.unique(facets[facets < owned]).astype(np.int32)
    nodes = entities_to_geometry(mesh._mesh, dim, facets, False)   # 0.5: the C++ mesh
    x = mesh.geometry.x[nodes.ravel(), :mesh.geometry.dim] @ embedding(mesh.geometry.dim).T
    corners = _gather(mesh.comm, x)
    if corners is None:
        return None, None, None
    if dim == 1:
        return corners, np.arange(len(corners)).reshape(-1, 2), "Polyline"
    face = (CellType.quadrilateral if mesh.topology.cell_type == CellType.hexahedron
            else CellType.triangle)
    n = nodes.shape[1]
    return corners, np.arange(len(corners)).reshape(-1, n)[:, perm_vtk(face, n)], XDMF_CELLS[face]


class FieldWriter:
    """fields.xdmf (the soil's named output fields) and, with a tool, tool.xdmf (its faces,
    displaced rigidly); frame 0 is the initial state. Rank 0 writes. ``remeshed``: the
    problem is on a mesh a remesh made (its nodes are written where their soil was at the
    start)."""

    def __init__(self, folder, problem, fields, remeshed=False):
        self._names = fields
        self._fields = problem.output_fields(fields)
        displacement = problem.displacement()
        self._mesh = MeshData(displacement.function_space, displacement if remeshed else None)
        rank0 = problem.comm.rank == 0
        self._soil = (XdmfSeries(folder / "fields.xdmf", self._mesh.points, self._mesh.cells,
                                 self._mesh.topology, CONVENTIONS) if rank0 else None)
        self._tool, self._direction = None, None
        if problem.tool is not None:
            points, cells, topology = tool_surface(problem)
            self._direction = np.asarray(problem.tool.direction, dtype=float)
            if rank0:
                self._tool = XdmfSeries(folder / "tool.xdmf", points, cells, topology,
                                        CONVENTIONS)
                self._tool_mesh = (points, cells)
        self.last = None   # (points, cells, point data, cell data) of the last frame, rank 0

    def remeshed(self, problem):
        """The frames from here on are on ``problem``'s new mesh (collective)."""
        self._fields = problem.output_fields(self._names)
        displacement = problem.displacement()
        self._mesh = MeshData(displacement.function_space, displacement)
        if self._soil is not None:
            self._soil.new_mesh(self._mesh.points, self._mesh.cells)

    def write(self, t, tool_travel=0.0):
        point_data, cell_data = {}, {}
        for name, (function, update) in self._fields.items():
            update()
            on_nodes, values = self._mesh.values(function)
            (point_data if on_nodes else cell_data)[name.value] = values
        if self._soil is None:
            return
        with deferred():
            self._soil.write(t, point_data, cell_data)
            if self._tool is not None:
                self._tool.write(t, {"displacement": np.tile(tool_travel * self._direction,
                                                             (self._tool.n_points, 1))}, {})
        self.last = (self._mesh.points, self._mesh.cells, point_data, cell_data)
        self._travel = tool_travel

    def picture(self):
        """(soil, tool) of the last frame for :func:`figures_3d.soil_3d_png` on rank 0, or
        None (no tool, a two-dimensional mesh, or displacement or plastic strain not written)."""
        if self._tool is None or self.last is None or self._mesh.topology not in ("Hexahedron",
                                                                                 "Tetrahedron"):
            return None
        _, _, point_data, cell_data = self.last
        if "displacement" not in point_data or "plastic_strain" not in cell_data:
            return None
        return self.last, (*self._tool_mesh, self._travel * self._direction)


class RunFolder:
    """One folder per run (made and cleared beforehand: :mod:`soilbin.app.outdir`). Only rank 0
    writes files; writing fields is collective."""

    def __init__(self, path, problem, scene, initial_frame=True):
        self.path = Path(path)
        self._rank0 = problem.comm.rank == 0
        self._columns = curve_columns(problem)
        if self._rank0:
            (self.path / "scene.toml").write_text(scene.resolved())
            with open(self.path / "curve.csv", "w", newline="") as f:
                csv.writer(f).writerow(self._columns)
        self._moves_tool = scene.loading.boundary == TOOL
        self.fields = (FieldWriter(self.path, problem, scene.output.fields,
                                   remeshed=not initial_frame)
                       if scene.output.fields else None)
        if self.fields is not None and initial_frame:
            self.fields.write(0.0)
        self._every = scene.output.every
        self._stops = scene.output.stops(scene.loading)
        self.records = []   # the converged steps, in order

    def remeshed(self, problem, report):
        """The run goes on on ``problem``'s new mesh (collective): ``report`` (a
        :class:`~soilbin.remesh.remesher.RemeshReport`) becomes a row of remeshes.csv."""
        if self.fields is not None:
            self.fields.remeshed(problem)
        if self._rank0:
            row = dataclasses.asdict(report)
            path = self.path / REMESHES
            with deferred(), open(path, "a", newline="") as f:
                if not path.stat().st_size:
                    csv.writer(f).writerow(row)
                csv.writer(f).writerow([_text(v) for v in row.values()])

    def add_earlier(self, records):
        """The steps of the run this one resumes: their curve.csv rows (no fields)."""
        for record in records:
            self._add_row(record)

    def add_step(self, record):
        self._add_row(record)
        if self.fields is not None and self.writes_fields(record):
            self._write_fields(record)

    def _add_row(self, record):
        self.records.append(record)
        if self._rank0:
            values = {**dataclasses.asdict(record), **record.columns}
            # a resumed run's earlier steps lack what it took up (soil_contact_force): blank
            with deferred(), open(self.path / "curve.csv", "a", newline="") as f:
                csv.writer(f).writerow([_text(values.get(column, "")) for column in self._columns])

    def writes_fields(self, record):
        """Fields are written every ``every`` steps, at the stated loads and at the end."""
        return (record.step % self._every == 0
                or any(abs(record.load_factor - stop) < 1e-9 for stop in self._stops))

    def _write_fields(self, record):
        self.fields.write(record.load_factor, record.displacement if self._moves_tool else 0.0)

    def finish(self, summary, interrupted=False):
        """Fields of the last converged step (if not yet written; collective, so not after an
        interruption), then summary.json."""
        last = self.records[-1] if self.records else None
        if (self.fields is not None and not interrupted and last is not None
                and not self.writes_fields(last)):
            self._write_fields(last)
        if self._rank0:
            with deferred():
                (self.path / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
