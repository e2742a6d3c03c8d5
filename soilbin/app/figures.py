"""PNG figures of a run: the load–displacement curve and, with a tool, a section around it."""
import numpy as np
from mpi4py import MPI

from ..plotting import pyplot


def curve_png(records, scene, path, estimate=None):
    """Force along the loading direction against displacement, one marker per converged step;
    with a closed-form draft ``estimate`` (DraftEstimate), a horizontal reference line."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(5.5, 4))
    ax.plot([0.0] + [r.displacement for r in records], [0.0] + [r.force for r in records], "o-", ms=3)
    if estimate is not None:
        ax.axhline(estimate.draft, color="tab:red", ls="--", lw=1,
                   label=f"{estimate.model} (phi = {estimate.phi:.3g} deg, c = {estimate.c:.3g}): "
                         f"{estimate.draft:.3g}")
        ax.legend(fontsize=8)
    ax.set_xlabel(f"displacement along {scene.loading.direction.value} [length]")
    ax.set_ylabel(f"force along {scene.loading.direction.value} [force]")
    ax.set_title(f"{scene.name}\nunits: {scene.units}", fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def tool_section_png(problem, path, depth_fraction=0.5):
    """Horizontal section through the tool at a fraction of its depth, on the initial
    geometry: soil displacement vectors (x-y) and the gap between soil and tool (rank 0
    draws; data gathered)."""
    x, displacement = problem.nodal_displacement()
    points, gap = problem.tool.gap()
    comm = problem.comm
    z_section = comm.allreduce(points[:, 2].min(initial=np.inf), op=MPI.MIN) * depth_fraction
    spacing = comm.allreduce(np.diff(np.unique(np.round(x[:, 2], 9))).min(initial=np.inf),
                             op=MPI.MIN)
    near = np.abs(x[:, 2] - z_section) <= 0.5 * spacing
    on_section = np.abs(points[:, 2] - z_section) <= 0.5 * spacing
    data = comm.gather((x[near], displacement[near], points[on_section], gap[on_section]), root=0)
    if comm.rank != 0:
        return
    xs, us, ps, gaps = (np.concatenate(parts) for parts in zip(*data))
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 4.5))
    scale = np.abs(us[:, :2]).max()
    arrows = ax.quiver(xs[:, 0], xs[:, 1], us[:, 0], us[:, 1], np.linalg.norm(us[:, :2], axis=1),
                       angles="xy", scale_units="xy", scale=scale / 0.8 if scale > 0 else 1.0,
                       width=0.003)
    if scale > 0:
        ax.quiverkey(arrows, 0.85, 1.04, scale, f"{scale:.3g} [length]", labelpos="E",
                     fontproperties={"size": 8})
    sc = ax.scatter(ps[:, 0], ps[:, 1], c=gaps, cmap="magma_r", s=18, edgecolors="k", linewidths=0.3)
    fig.colorbar(sc, ax=ax, label="gap soil-tool [length]")
    lo, hi = ps.min(axis=0), ps.max(axis=0)
    reach = 4.0 * max(hi[0] - lo[0], hi[1] - lo[1])
    ax.set_xlim(lo[0] - reach, hi[0] + 1.5 * reach)
    ax.set_ylim(max(lo[1] - reach, xs[:, 1].min()), hi[1] + reach)
    ax.set_aspect("equal")
    ax.set_xlabel("x (travel) [length]")
    ax.set_ylabel("y [length]")
    ax.set_title(f"section z = {z_section:.3g}: soil displacement (arrows) and gap at the tool\n"
                 f"units: {problem.scene.units}", fontsize=8, loc="left")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
