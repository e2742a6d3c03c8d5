"""PNG figures of a run: the load–displacement curve and, with a tool, a section around it."""
import numpy as np
from mpi4py import MPI

from ..plotting import pyplot, wrapped
from .figure_labels import column_label
from .section_figures import slab_half_width
from ..records.scene import TOOL

#: An estimate above this many times the curve's largest force is named in the legend only.
ESTIMATE_REACH = 1.3


def curve_png(records, scene, path, estimates=()):
    """Write :func:`curve_figure` to ``path``."""
    fig = curve_figure(records, scene, estimates)
    fig.savefig(path, dpi=120)
    pyplot().close(fig)


def curve_figure(records, scene, estimates=()):
    """The curve of the converged steps, one marker each: a tool's draft against its travel,
    a loaded boundary's pressure against its displacement (settlement). The closed-form
    draft ``estimates`` (DraftEstimate; the one that applies first) are dashed lines where
    they lie within ESTIMATE_REACH times the largest force, else numbers in the legend."""
    column = "force" if scene.loading.boundary == TOOL else "pressure"
    xs = [0.0] + [r.displacement for r in records]
    ys = [0.0] + [r.force if column == "force" else r.columns[column] for r in records]
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    ax.plot(xs, ys, "o-", ms=3, label="finite elements")
    reach = ESTIMATE_REACH * max(max(ys), 0.0)
    for estimate, style in zip(estimates, ({"color": "tab:red", "ls": "--"},
                                           {"color": "tab:gray", "ls": ":"})):
        text = _estimate_text(estimate, scene)
        if estimate.draft <= reach:
            ax.axhline(estimate.draft, lw=1.2, label=text, **style)
        else:   # an empty line: its number in the legend, off the axes
            ax.plot([], [], lw=1.2, label=text.replace("\n", " (off scale)\n", 1), **style)
    ax.set_xlim(left=min(xs))
    ax.set_ylim(bottom=min(ys))
    ax.set_xlabel(column_label("displacement", scene))
    ax.set_ylabel(column_label(column, scene))
    ax.set_title(wrapped(scene.title), fontsize=9)
    ax.grid(alpha=0.3)
    if estimates:
        ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def _estimate_text(estimate, scene):
    """The estimate's model and draft, then where its c, phi come from, on two lines."""
    units = scene.unit_system
    return (f"{estimate.model}: {_number(estimate.draft)} {units.force}\n{estimate.strength}: "
            f"φ = {estimate.phi:.3g}°, c = {estimate.c:.2g} {units.stress}")


def _number(value):
    """Three significant digits, and every digit before the point: 0.512, 75.3, 1540."""
    return f"{value:.3g}" if abs(value) < 1e3 else f"{value:.0f}"


def tool_section_png(problem, path, depth_fraction=0.5):
    """Horizontal section through the tool at a fraction of its depth, on the initial
    geometry: soil displacement vectors (x-y) and the gap between soil and tool (rank 0
    draws; data gathered). Returns why it is not drawn (rank 0), else None."""
    x, displacement = problem.nodal_displacement()
    points, gap = problem.tool.gap()
    comm = problem.comm
    z_section = comm.allreduce(points[:, 2].min(initial=np.inf), op=MPI.MIN) * depth_fraction
    # half the spacing of the planes of nodes (hexahedra), or half a cell (tetrahedra)
    half = slab_half_width(problem) or 0.5 * comm.allreduce(
        np.diff(np.unique(np.round(x[:, 2], 9))).min(initial=np.inf), op=MPI.MIN)
    near = np.abs(x[:, 2] - z_section) <= half
    on_section = np.abs(points[:, 2] - z_section) <= half
    data = comm.gather((x[near], displacement[near], points[on_section], gap[on_section]), root=0)
    if comm.rank != 0:
        return
    xs, us, ps, gaps = (np.concatenate(parts) for parts in zip(*data))
    length = problem.scene.unit_system.length
    if not len(ps):
        return (f"no face of the tool crosses the section at z = {z_section:.3g} {length} "
                "(half the depth of its lowest point)")
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 4.5))
    scale = np.abs(us[:, :2]).max()
    arrows = ax.quiver(xs[:, 0], xs[:, 1], us[:, 0], us[:, 1], np.linalg.norm(us[:, :2], axis=1),
                       angles="xy", scale_units="xy", scale=scale / 0.8 if scale > 0 else 1.0,
                       width=0.003)
    if scale > 0:
        ax.quiverkey(arrows, 0.85, 1.04, scale, f"{scale:.3g} {length}", labelpos="E",
                     fontproperties={"size": 8})
    sc = ax.scatter(ps[:, 0], ps[:, 1], c=gaps, cmap="magma_r", s=18, edgecolors="k", linewidths=0.3)
    fig.colorbar(sc, ax=ax, label=f"gap between soil and tool [{length}]")
    lo, hi = ps.min(axis=0), ps.max(axis=0)
    reach = 4.0 * max(hi[0] - lo[0], hi[1] - lo[1])
    ax.set_xlim(lo[0] - reach, hi[0] + 1.5 * reach)
    ax.set_ylim(max(lo[1] - reach, xs[:, 1].min()), hi[1] + reach)
    ax.set_aspect("equal")
    ax.set_xlabel(f"x (travel) [{length}]")
    ax.set_ylabel(f"y [{length}]")
    ax.set_title(f"section z = {z_section:.3g} {length}: soil displacement (arrows) and gap at "
                 "the tool", fontsize=9, loc="left")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
