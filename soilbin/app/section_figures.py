"""The displacement fields of figures 8.10–8.12: three sections around the tool at a stated load.

(a) the vertical section through the tool's centre line (x–z), (b) the
horizontal section at the tool's tip depth (x–y), (c) the bin surface (x–y).
Each panel draws the in-plane soil displacement at the mesh nodes of that
plane as arrows (one scale for the figure, with a reference arrow) on the
initial geometry, and the tool's faces cut by the plane. A tetrahedral mesh has
no planes of nodes: there a section draws the nodes within half a cell of its
plane (:func:`slab_half_width`). Data are gathered to rank 0, which draws.
"""
import numpy as np
from dolfinx import cpp

from ..plotting import pyplot, wrapped
from .figure_labels import key_words


def _node_plane(coordinates, target, comm):
    """The coordinate of the plane of mesh nodes nearest to ``target`` (all ranks agree)."""
    local = coordinates[np.argmin(np.abs(coordinates - target))] if len(coordinates) else np.inf
    candidates = comm.allgather(local)
    return min(candidates, key=lambda c: abs(c - target))


def slab_half_width(problem):
    """How far from a section's plane a node is drawn on it: 0 where the mesh's nodes lie in
    planes (hexahedra), else half the median diameter of the cells at the tool's faces
    (all ranks agree)."""
    if not problem.disc.element.simplex:
        return 0.0
    tagged = problem.tagged
    mesh, dim = tagged.mesh, tagged.mesh.topology.dim
    tool = [tagged.boundaries[face] for face in problem.scene.tool.faces]
    facets = tagged.facet_tags.indices[np.isin(tagged.facet_tags.values, tool)]
    mesh.topology.create_connectivity(dim - 1, dim)
    to_cells = mesh.topology.connectivity(dim - 1, dim)
    cells = np.unique(to_cells.array[to_cells.offsets[facets]])   # a boundary facet's one cell
    owned = cells[cells < mesh.topology.index_map(dim).size_local].astype(np.int32)
    diameters = problem.comm.gather(cpp.mesh.h(mesh._mesh, dim, owned), root=0)   # 0.5: C++ mesh
    half = 0.5 * float(np.median(np.concatenate(diameters))) if problem.comm.rank == 0 else None
    return problem.comm.bcast(half, root=0)


def _sections(problem):
    """(title, normal axis, plane coordinate, in-plane axes) of the three sections."""
    comm = problem.comm
    tool = np.concatenate(list(problem.tool.face_points.values()))
    # (mpi4py's MIN and MAX compare whole objects: gather the corners instead)
    low = np.min(comm.allgather(tool.min(axis=0, initial=np.inf)), axis=0)
    high = np.max(comm.allgather(tool.max(axis=0, initial=-np.inf)), axis=0)
    # across a symmetry plane the tool's centre line is that plane, y = low
    centre = low[1] if problem.tool.share < 1.0 else 0.5 * (low[1] + high[1])
    return [("vertical section through the tool's centre line", 1, centre, (0, 2)),
            ("horizontal section at the tool's tip depth", 2, low[2], (0, 1)),
            ("bin surface", 2, high[2], (0, 1))], low, high


def section_panels(problem):
    """The three sections' data on rank 0 (None elsewhere; collective): ([(title, normal axis,
    plane, in-plane axes, node coordinates, their displacements, tool points)], the tool's
    low and high corners, :func:`slab_half_width`)."""
    comm = problem.comm
    x, displacement = problem.nodal_displacement()
    sections, low, high = _sections(problem)
    half = slab_half_width(problem)
    tool = np.concatenate(list(problem.tool.face_points.values()))
    panels = []
    for title, normal, target, axes in sections:
        plane = _node_plane(x[:, normal], target, comm)
        within = max(half, 1e-9 * (1.0 + abs(plane)))
        on = np.abs(x[:, normal] - plane) <= within
        tool_on = np.abs(tool[:, normal] - plane) <= within
        parts = comm.gather((x[on][:, axes], displacement[on][:, axes], tool[tool_on][:, axes]),
                            root=0)
        if comm.rank == 0:
            panels.append((title, normal, plane, axes, *(np.concatenate(p) for p in zip(*parts))))
    return (panels, low, high, half) if comm.rank == 0 else None


def sections_png(problem, scene, load, path):
    """One PNG of the three sections at the current (converged) state; collective."""
    drawn = section_panels(problem)
    if drawn is not None:
        _draw(*drawn, scene, load, path)


def _draw(panels, low, high, half, scene, load, path):
    size = high - low
    reach = 1.5 * max(size.max(), 1e-12)   # the tool depth or width, whichever larger
    scale = max(np.abs(p[5]).max(initial=0.0) for p in panels) or 1.0
    units = scene.unit_system
    plt = pyplot()
    fig, axs = plt.subplots(3, 1, figsize=(7, 12))
    for ax, (title, normal, plane, axes, xs, us, tool) in zip(axs, panels):
        a, b = axes
        arrows = ax.quiver(xs[:, 0], xs[:, 1], us[:, 0], us[:, 1], np.hypot(us[:, 0], us[:, 1]),
                           angles="xy", scale_units="xy", scale=scale / (0.25 * reach),
                           cmap="viridis", width=0.0025)
        ax.scatter(tool[:, 0], tool[:, 1], s=6, c="k", label="tool")
        ax.quiverkey(arrows, 0.85, 0.92, scale, f"{scale:.3g} {units.length}",
                     labelpos="W", coordinates="axes", fontproperties={"size": 8})
        ax.set_xlim(low[a] - reach, high[a] + reach)
        ax.set_ylim(max(low[b] - reach, xs[:, 1].min()), min(high[b] + reach, xs[:, 1].max()))
        ax.set_aspect("equal")
        ax.set_xlabel(f"{'xyz'[a]} [{units.length}]")
        ax.set_ylabel(f"{'xyz'[b]} [{units.length}]")
        ax.set_title(f"{title}, {'xyz'[normal]} = {np.round(plane, 9) + 0.0:.3g} {units.length}",
                     fontsize=9)
        fig.colorbar(arrows, ax=ax, label=f"in-plane displacement [{units.length}]")
    words, unit = key_words("loading.magnitude", scene)   # the load's: draft, or tool travel
    slab = f"; the nodes within {half:.3g} {units.length} of each plane" if half else ""
    fig.suptitle(wrapped(scene.title) + "\n" + wrapped(
        f"soil displacement at {words} {load:g} {unit} (arrows on the initial geometry; "
        f"black: the tool's faces{slab})"), fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
