"""A large-deformation run's remeshing: when the mesh's quality falls below the scene's
``remesh.min_quality`` after a converged step (or every ``remesh.every`` steps), the deformed
soil is meshed afresh, its state moved over, and the new problem brought back to equilibrium
at the same load before the next step.

State by ``layout`` kind (the problem's :meth:`~soilbin.problem.SoilProblem.state`): the
quadrature points' stress and history by the cell-wise fit of :mod:`.transfer` (the first
iterate's tangent is the new problem's elastic one: a fitted consistent tangent took more
iterations); the tool's contact state (its law's history, the jump at rest, the tool's
normal) from the nearest old contact point of the same face; the total displacement (of the
mesh's nodes from the initial configuration) interpolated from the old nodes; the unknowns
start from zero (the increment of the next step; a mean-dilatation element's pressure from
the transferred mean stress); the load factor, the driven boundary's state and the force
scale unchanged. Each model then makes the history variables it ties together consistent
again (the caps' centre from their end). The
re-equilibration is one Newton solve at that load factor with the return map, which takes a
transferred stress outside its yield surface back to it (where it fails, the same in stages:
:func:`_equilibrated`); its first and last residuals are reported with the soil's volume,
its integral of the equivalent plastic strain and its plastic work before and after the
transfer.
"""
import contextlib
import dataclasses
import math
import time
from pathlib import Path

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI
from scipy.spatial import cKDTree

from ..errors import ConvergenceError
from ..layout import CONTACT, GLOBAL, NODES, POINTS, CellLayout, gather_rows
from ..problem import SoilProblem
from ..problem.loads import start_mean_pressure
from ..solver.newton import NewtonResult
from ..solver.quadrature import PLASTIC_WORK, quadrature_space
from .local import remeshed_around
from .mesher import Sizes, mesh_cells, mesh_outline, mesh_surface
from .outline import OutlineError, gather_outline, initial_sizes
from .smoothing import smoothed
from .surface import gather_surface
from .transfer import OldCells, cell_simplices

#: gmsh's input rounded to this fraction of the mesh's extent: the mesh a remesh makes must
#: not depend on round-off (partitioned runs sum their forces in another order, and gmsh's
#: Delaunay and recombination decide differently on points a rounding apart).
GRAIN = 1e-9
#: Stages of a re-equilibration that did not converge in one (:func:`_equilibrated`).
RELEASE_STAGES = 4
#: The tangent floor (``solver.tangent_floor``) of a re-equilibration tried again
#: (:func:`_equilibrated`).
EQUILIBRIUM_FLOOR = 1e-2
#: The run folder's folder of the meshes that remeshing made.
MESHES = "meshes"
#: A three-dimensional soil whose least quality fell below min_quality keeps its cells, its
#: nodes moved (:mod:`.smoothing`), or else its cells away from the poor ones (:mod:`.local`),
#: where that lifts the least quality to this many times min_quality (the fresh meshes of the
#: tine's soil reach 1.1-2.2 times its 0.045).
SMOOTHED = 1.15
#: How much of the old mesh a remesh kept: none, its cells (nodes moved), the cells away from
#: the poor ones (:meth:`Remeshing._mended`).
FRESH, MOVED, LOCAL = "fresh", "moved", "local"


def _mesh_file(step):
    """The run folder's file of the mesh made after ``step``."""
    return f"{MESHES}/remesh-{step:04d}.msh"


class RemeshError(RuntimeError):
    """A remesh that failed: the mesher, the transfer or the re-equilibration."""


@dataclasses.dataclass(frozen=True)
class RemeshReport:
    """What one remesh did (``remeshes.csv``): after ``step``, the cells before and after, the
    equilibrium residual (of the run's force scale) after the transfer and after the
    re-equilibration with its Newton iterations, the driven force before, right after the
    transfer (at the transferred state's first residual) and after the re-equilibration, the
    relative change of the soil's volume, of its integral of the equivalent plastic strain and
    of its plastic work (:data:`~soilbin.solver.quadrature.PLASTIC_WORK`) by the transfer, the
    least scaled Jacobian before and after, the seconds spent: meshing (the outline
    gathered, gmsh, the mesh distributed), the new problem with its transferred state, the
    re-equilibration, and all of it; 1 where the old cells were kept, their nodes moved
    (``remesh.smooth_first``), and 1 where the soil was meshed afresh around its poor cells
    alone (``remesh.local_first``); both 0 where the whole soil was meshed afresh."""
    step: int
    load_factor: float
    cells_before: int
    cells_after: int
    residual_transferred: float
    residual_equilibrated: float
    newton_iterations: int
    force_before: float
    force_transferred: float
    force_after: float
    volume_change: float
    plastic_strain_change: float
    plastic_work_change: float
    quality_before: float
    quality_after: float
    mesh_s: float
    transfer_s: float
    equilibrium_s: float
    wall_s: float
    smoothed: int
    local: int


class Remeshing:
    """Decides when the run remeshes and makes the new problem (collective); each new mesh is
    written to the run folder's ``meshes/remesh-STEP.msh``."""

    def __init__(self, scene, folder):
        self.scene, self.folder = scene, Path(folder)
        #: the run folder's file of the mesh the run is on, None while on the scene's own
        self.mesh_file = None
        #: the new mesh's cells and their entities as the mesh was made (a checkpoint's
        #: layout: the re-equilibration moves the mesh before the first checkpoint on it)
        self.layout = None
        self.settings = scene.remesh
        self.reports = []   # this run's (not those before a resume)
        self.count = 0      # remeshes since the start, a resumed run's before it included
        self.failures = 0   # remeshes that failed since the start (:meth:`goes_on`)
        self._in_a_row = 0  # of them since the last that worked
        self._last = 0      # the step of the last remesh
        #: Rank 0: the scene's mesh as built, its cells' corners (n, k, d) and element sizes
        #: (None until the first remesh, which reads them off the mesh it remeshes): a cell
        #: of any later mesh takes the size of the built cell where its soil started, so
        #: that sizes do not drift by remeshing (carried from mesh to mesh instead, sampled
        #: at each new mesh's cell centres, they coarsened the tine's tetrahedra by 30% in
        #: 28 remeshes).
        self._built = None
        self._built_cells = None   # the built mesh's OldCells, to find points in

    def due(self, record):
        """Whether to remesh after this converged step."""
        quality = record.columns.get("mesh_quality", 1.0)
        every = self.settings.every
        return (quality < self.settings.min_quality
                or (every > 0 and record.step - self._last >= every))

    def check_folding(self, problem, record):
        """RemeshError (on every rank) if after this step the three-dimensional soil's boundary
        passes through itself: past that the soil overlaps itself, and no mesh can be made of
        it (collective)."""
        if problem.disc.planar:
            return
        surface = gather_surface(problem.tagged)
        folded = problem.comm.bcast(surface.folded(problem.tagged.boundaries)
                                     if surface is not None else None, root=0)
        if folded:
            hint = ("no [soil_contact]: the soil passes through itself" if
                    problem.soil_contact is None else "through [soil_contact]'s penalty: a "
                    "larger soil_contact.k_n or shorter steps may hold it")
            raise RemeshError(f"after step {record.step} {folded} ({hint}): the run stops at "
                              "the first step where it does")

    def remesh(self, problem, record):
        """The problem on a new mesh of the deformed soil, in equilibrium at ``record``'s load
        factor; RemeshError (on every rank) if that cannot be done."""
        start = time.perf_counter()
        before = soil_integrals(problem)
        try:
            new, layout, mesh_s, how = self._transferred(problem, record.step,
                                                         self._mends(record))
        except (OutlineError, RuntimeError) as err:
            raise self._failed(problem.comm, record.step,
                               f"remeshing after step {record.step} failed: {err}") from None
        transferred = soil_integrals(new)
        transfer_s = time.perf_counter() - start - mesh_s
        new.set_load_factor(record.load_factor)
        with _first_force(new) as forces:
            try:
                result = _equilibrated(new)
            except ConvergenceError as err:
                new.destroy()
                raise self._failed(new.comm, record.step,
                                   f"after remeshing at step {record.step} the soil did not "
                                   f"come back to equilibrium at the same load ({err})") from None
        new.commit()
        seen = new.observe()
        scale = new.newton.force_scale or 1.0
        report = RemeshReport(
            step=record.step, load_factor=record.load_factor,
            cells_before=_cells(problem), cells_after=_cells(new),
            residual_transferred=result.residuals[0] / scale,
            residual_equilibrated=result.residuals[-1] / scale,
            newton_iterations=result.iterations,
            force_before=record.force, force_after=seen.force,
            force_transferred=forces[0] if forces else math.nan,
            volume_change=transferred[0] / before[0] - 1.0,
            plastic_strain_change=_change(transferred[1], before[1]),
            plastic_work_change=_change(transferred[2], before[2]),
            quality_before=record.columns.get("mesh_quality", float("nan")),
            quality_after=seen.columns.get("mesh_quality", float("nan")),
            mesh_s=mesh_s, transfer_s=transfer_s,
            equilibrium_s=time.perf_counter() - start - mesh_s - transfer_s,
            wall_s=time.perf_counter() - start, smoothed=int(how == MOVED),
            local=int(how == LOCAL))
        self.reports.append(report)
        self.mesh_file, self.layout = _mesh_file(record.step), layout
        self._last = record.step
        self.count += 1
        self._in_a_row = 0
        return new

    def _failed(self, comm, step, message):
        """The RemeshError of a remesh after ``step`` that failed, its mesh file (if made)
        removed: each file in :data:`MESHES` is of a mesh the run went on."""
        if comm.rank == 0:
            (self.folder / _mesh_file(step)).unlink(missing_ok=True)
        return RemeshError(message)

    def goes_on(self):
        """Whether the run goes on on the old mesh after a remesh that failed (and tries again
        after the next step): while no more than ``remesh.retries`` have failed since the
        last that worked. The old mesh is below min_quality, but a step that would take it
        below half of it is cut (:class:`~soilbin.problem.SoilProblem`), so its cells do
        not fold."""
        self.failures += 1
        self._in_a_row += 1
        return self._in_a_row <= self.settings.retries

    def _mends(self, record):
        """Whether to try keeping part of the old mesh (its cells, nodes moved; else its cells
        away from the poor ones): where either is asked for and its quality fell below
        min_quality (:meth:`_transferred` tries it in three dimensions only)."""
        settings = self.settings
        return ((settings.smooth_first or settings.local_first)
                and record.columns.get("mesh_quality", 1.0) < settings.min_quality)

    def _transferred(self, old, step, mend):
        """A new problem on a new mesh of ``old``'s deformed soil, with its state, its
        cells' layout as made, the seconds the mesh took and how much of the old mesh it kept
        (:data:`FRESH`, :data:`MOVED` or :data:`LOCAL`). Where ``mend``: the old cells with
        nodes moved (``remesh.smooth_first``), else the old mesh meshed afresh around its poor
        cells alone (``remesh.local_first``); else, or where neither reaches
        :data:`SMOOTHED` min_quality, a fresh mesh."""
        start = time.perf_counter()
        comm, tagged, scene = old.comm, old.tagged, self.scene
        element = old.disc.element
        planar = old.disc.planar
        boundary = gather_outline(tagged) if planar else gather_surface(tagged)
        layout = CellLayout(old)
        state = layout.gather_state(old.state())
        samples = layout.gather(layout.by_cell(POINTS, _point_coordinates(old)))
        contact = _contact_points(old)
        sizes, kept, how = None, None, FRESH
        if comm.rank == 0:
            boundary, sizes = self._mesher_input(state, boundary, element.simplex,
                                                 old.disc.dimension, _tool_shift(old))
            if mend and not planar:
                kept, how = self._mended(state, boundary, sizes)
        how = comm.bcast(how, root=0)
        mesh_file = _mesh_file(step)
        groups = dict(tagged.regions), dict(tagged.boundaries)
        if planar:
            new_tagged = mesh_outline(comm, boundary, sizes, *groups, element.simplex,
                                      self.folder / mesh_file)
        elif how != FRESH:
            new_tagged = mesh_cells(comm, *(kept or (None,) * 4), *groups,
                                    self.folder / mesh_file)
        else:
            new_tagged = mesh_surface(comm, boundary, sizes, *groups, self.folder / mesh_file,
                                      self.settings.min_quality)
        mesh_s = time.perf_counter() - start
        new = SoilProblem(scene, new_tagged)
        new.newton.on_iterate = old.newton.on_iterate
        new_layout = CellLayout(new)
        target = new_layout.gather_state(new.state())
        x = new_layout.gather(new_layout.by_cell(POINTS, _point_coordinates(new)))
        new_contact = _contact_points(new)
        failure = None
        if comm.rank == 0:
            _transfer(state, target, samples, x, element)
            if contact is not None:
                try:
                    _transfer_contact(state, target, contact, new_contact)
                except RuntimeError as err:
                    failure = str(err)
        target, failure = comm.bcast((target, failure), root=0)
        if failure is not None:
            new.destroy()
            raise RuntimeError(failure)
        new.restore({name: values if kind == GLOBAL else new_layout.local(kind, values)
                     for name, (kind, values) in target.items()})
        new.points.settle_history()
        if element.mixed:
            start_mean_pressure(new.disc, new.points, new.w, new.w_committed)
        return new, new_layout, mesh_s, how

    def _mended(self, state, surface, sizes):
        """(the nodes, cells and the boundary's triangles and tags of a mesh that keeps what
        it can of the old one, and :data:`MOVED` or :data:`LOCAL`), or (None,
        :data:`FRESH`) where neither lifts the least quality to :data:`SMOOTHED` min_quality
        (rank 0; ``state``'s corners and the ``surface`` on the same grid)."""
        corners = state["kinematics/mesh_x"][1]
        points, index = np.unique(corners.reshape(-1, 3), axis=0, return_inverse=True)
        cells = index.reshape(len(corners), -1)
        merged, of_surface = np.unique(np.concatenate([points, surface.points]), axis=0,
                                       return_inverse=True)
        if len(merged) != len(points):
            raise RuntimeError("the soil's boundary is not on its cells' corners")
        triangles = of_surface[len(points):][surface.triangles]
        target = SMOOTHED * self.settings.min_quality
        if self.settings.smooth_first:
            moved, least = smoothed(points, cells, triangles, surface.tags, target)
            if least >= target:
                return (moved, cells, triangles, surface.tags), MOVED
        if self.settings.local_first:
            around = remeshed_around(points, cells, triangles, surface.tags, sizes, target)
            if around is not None:
                return around, LOCAL
        return None, FRESH

    def _mesher_input(self, state, boundary, simplices, d, tool_shift):
        """(the boundary: in 2D the outline sampled at the sizes, in 3D the surface; the
        :class:`~.mesher.Sizes`) on rank 0, on the grid of :data:`GRAIN` (the old corners in
        ``state`` too, for the transfer); ``d``: the mesh's dimension; ``tool_shift``: the
        tool's displacement along the mesh's axes (None without a tool)."""
        corners = state["kinematics/mesh_x"][1][:, :, :d]
        initial = corners - state["kinematics/total_displacement"][1][:, :, :d]
        if self._built is None:
            self._built = (initial, initial_sizes(initial, simplices))
        if self._built_cells is None:
            self._built_cells = OldCells(self._built[0], simplices)
        built = self._built[1][self._built_cells.parent]   # each built simplex's cell's size
        built_sizes = built[self._built_cells.locate(initial.mean(axis=1))[1]]
        if tool_shift is not None:
            # Around the tool where it now is, the sizes it was built with around it: at the
            # place that lay where each cell now lies relative to the tool (none where that
            # place was not soil), so that the fine cells at the tool go with it.
            holding = self._built_cells.holding(corners.mean(axis=1) - tool_shift)[1]
            inside = holding >= 0
            built_sizes[inside] = np.minimum(built_sizes[inside], built[holding[inside]])
        grain = GRAIN * np.abs(corners).max()
        corners = state["kinematics/mesh_x"][1][:, :, :d] = _rounded(corners, grain)
        sizes, at_node = _size_field(corners, built_sizes, simplices)
        sizes = dataclasses.replace(sizes, values=_rounded(sizes.values, grain))
        if d == 3:
            return boundary.on_grid(grain), sizes
        outline = dataclasses.replace(boundary, vertices=_rounded(boundary.vertices, grain))
        _, vertex = cKDTree(at_node[0]).query(outline.vertices)   # they are old nodes
        at_vertices = at_node[1][vertex]
        # full-quad recombination halves the boundary's segments: sample it twice as long
        outline = outline.resampled(_rounded(at_vertices, grain) * (1.0 if simplices else 2.0))
        return dataclasses.replace(outline, vertices=_rounded(outline.vertices, grain)), sizes

    # -- checkpoints ------------------------------------------------------------------
    def state(self):
        """What a checkpoint keeps of the remeshing (rank 0's arrays): name -> array."""
        state = {"last": np.asarray(self._last), "count": np.asarray(self.count),
                 "failures": np.asarray(self.failures), "in_a_row": np.asarray(self._in_a_row)}
        if self._built is not None:
            state["built_corners"], state["built_sizes"] = self._built
        return state

    def restore(self, state, mesh_file, layout):
        """Back to a checkpoint's :meth:`state`, on the mesh of ``mesh_file`` (None: the
        scene's) with its ``layout`` as made."""
        self._last, self.count = int(state["last"]), int(state["count"])
        self.failures, self._in_a_row = (int(state.get(key, 0)) for key in ("failures",
                                                                            "in_a_row"))
        self._built = ((state["built_corners"], state["built_sizes"])
                       if "built_corners" in state else None)
        self._built_cells = None
        self.mesh_file, self.layout = mesh_file, layout


@contextlib.contextmanager
def _first_force(problem):
    """A list that holds, after the block, the driven force at the first residual Newton
    evaluates in it (if any): the state's before any correction (collective)."""
    forces, chained = [], problem.newton.on_iterate

    def on_iterate(iteration, residual, target):
        if not forces:
            forces.append(problem.drive.observe().force)
        if chained is not None:
            chained(iteration, residual, target)

    problem.newton.on_iterate = on_iterate
    try:
        yield forces
    finally:
        problem.newton.on_iterate = chained


def _equilibrated(problem):
    """Newton at the load factor from the transferred state; where it fails, the transfer's
    out-of-balance R_0 is released in :data:`RELEASE_STAGES` equal parts (R = (1 − k/n) R_0,
    k = 1 … n, each stage from the last one's solution; the committed history is the
    transferred one throughout); where that fails too, both again with Newton's matrix
    floored at :data:`EQUILIBRIUM_FLOOR` of the elastic stiffness (the same equilibrium: a
    remeshed soil at 4.3 in of the tine's travel was too soft in places for the scene's
    1e-3). Returns a NewtonResult (the iterations of the attempts that converged, the first
    and last residual); ConvergenceError if every attempt fails."""
    points = problem.points
    scene_floor = points.tangent_floor
    try:
        for floor in sorted({scene_floor, max(scene_floor, EQUILIBRIUM_FLOOR)}):
            points.floor_tangent(floor)
            try:
                return problem.solve()
            except ConvergenceError:
                problem.roll_back()
            try:
                return _released(problem)
            except ConvergenceError as err:
                problem.roll_back()
                failure = err
        raise failure
    finally:
        points.floor_tangent(scene_floor)


def _released(problem):
    """The transfer's out-of-balance released in :data:`RELEASE_STAGES` stages (one solve
    each); a NewtonResult of their iterations, the first and the last residual."""
    newton, iterations = problem.newton, 0
    try:
        first = newton.hold_out_of_balance(1.0 - 1.0 / RELEASE_STAGES)
        for k in range(1, RELEASE_STAGES + 1):
            newton.hold_out_of_balance(1.0 - k / RELEASE_STAGES)   # the last: 0, as it was
            result = problem.solve()
            iterations += result.iterations
    finally:
        newton.hold_out_of_balance(0.0)
    return NewtonResult(iterations, (first, result.residuals[-1]))


def _transfer(state, target, samples, points, element):
    """Fill ``target`` (the new problem's gathered state) from ``state`` (the old one's), on
    rank 0: ``samples`` (n_old, q, d) are the old quadrature points, ``points`` (n_new, q, d)
    the new ones."""
    d = samples.shape[2]
    old = OldCells(state["kinematics/mesh_x"][1][:, :, :d], element.simplex)
    at_points = old.at_points(samples, old.locate(points.reshape(-1, d)))
    new_corners = target["kinematics/mesh_x"][1]
    at_nodes = old.locate(new_corners[:, :, :d].reshape(-1, d))
    for name, (kind, values) in target.items():
        if kind == GLOBAL:
            target[name] = state[name]
        elif kind == POINTS and name != "points/converged_tangent":
            moved = at_points(state[name][1])
            target[name] = (kind, moved.reshape(values.shape))
    total = state["kinematics/total_displacement"][1]
    moved = old.at_nodes(total, at_nodes)
    target["kinematics/total_displacement"] = (NODES, moved.reshape(new_corners.shape))


def _transfer_contact(state, target, old, new):
    """The tool's contact state in ``target`` from ``state`` (both gathered, on rank 0): each
    new contact point takes that of the nearest old point of the same face (``old``, ``new``:
    face tag and position of each, (n, 4)); the law and its offset (the jump at rest) travel
    with the soil, the re-equilibration settles the tractions. RuntimeError if a face of the
    new mesh has no old contact point."""
    rows = np.empty(len(new), dtype=np.int64)
    for face in np.unique(new[:, 0]):
        mine, theirs = np.flatnonzero(new[:, 0] == face), np.flatnonzero(old[:, 0] == face)
        if not len(theirs):
            raise RuntimeError(f"the tool's face {int(face)} had no contact points before the "
                               f"remesh")
        rows[mine] = theirs[cKDTree(old[theirs, 1:]).query(new[mine, 1:])[1]]
    for name, (kind, _) in target.items():
        if kind == CONTACT:
            target[name] = (kind, state[name][1][rows])


def _tool_shift(problem):
    """The tool's rigid displacement along the mesh's axes (d,), None without a tool."""
    if problem.tool is None:
        return None
    disc = problem.disc
    return disc.to_world(np.eye(disc.dimension)) @ (problem.tool.travel * problem.tool.direction)


def _contact_points(problem):
    """The face tag and position of every contact point of the tool, gathered on rank 0 (None
    elsewhere, and without a tool; collective)."""
    if problem.tool is None:
        return None
    interface = problem.tool.interface
    faces = interface.contact_keys()[:, :1]
    return gather_rows(problem.comm, np.column_stack([faces, interface.positions()]))


def _size_field(corners, sizes, simplices):
    """(:class:`~.mesher.Sizes` over the old cells, each corner the mean initial size of the
    cells around it, in 3D each tetrahedron its own; (the old nodes, the mean at each), None
    in 3D).

    Tetrahedra keep their own sizes: at the mean of the nodes gmsh's tetrahedra came out
    coarser by 2-8% a remesh (the tine from a STEP file, remeshed every 2 steps)."""
    d = corners.shape[2]
    if d == 3:
        return Sizes(corners, np.repeat(sizes[:, None], corners.shape[1], axis=1)), None
    nodes, inverse = np.unique(corners.reshape(-1, d), axis=0, return_inverse=True)
    total, count = np.zeros(len(nodes)), np.zeros(len(nodes))
    np.add.at(total, inverse, np.repeat(sizes, corners.shape[1]))
    np.add.at(count, inverse, 1.0)
    at_node = total / count
    at_corner = at_node[inverse].reshape(corners.shape[:2])
    split = cell_simplices(simplices, d)
    cells = np.concatenate([corners[:, list(t)] for t in split])
    values = np.concatenate([at_corner[:, list(t)] for t in split])
    return Sizes(cells, values), (nodes, at_node)


def _rounded(x, grain):
    """``x`` on a grid of ``grain``."""
    return np.round(x / grain) * grain


def _point_coordinates(problem):
    """(n_points, d): where this rank's quadrature points are now."""
    points = problem.points
    return points.evaluate(points.expression(ufl.SpatialCoordinate(problem.mesh)))


def soil_integrals(problem):
    """(volume, ∫ equivalent plastic strain dV, ∫ plastic work dV) of the soil in its
    current configuration (collective)."""
    points, disc = problem.points, problem.disc
    integrands = [fem.Constant(problem.mesh, 1.0)]
    for key in ("eps_p_eq", PLASTIC_WORK):
        integrands.append(fem.Function(quadrature_space(problem.mesh,
                                                        disc.element.quadrature_degree)))
        points.write(points.history(key), integrands[-1])
    dx = disc.measure()
    return tuple(problem.comm.allreduce(fem.assemble_scalar(fem.form(f * dx)), op=MPI.SUM)
                 for f in integrands)


def _change(after, before):
    """after / before - 1; zero where there was nothing before."""
    return after / before - 1.0 if before else 0.0


def _cells(problem):
    mesh = problem.mesh
    return mesh.topology.index_map(mesh.topology.dim).size_global
