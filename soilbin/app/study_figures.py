"""Overlay figures of a study: the cases' curves, or a summary value against a swept key.

Axes read as quantities with units ("draft [lb]", "rake [°]", figure_labels), legends
as the cases' labels or their swept values in words ("tool width 2 in").
"""
import csv

from cycler import cycler

from ..plotting import pyplot, wrapped
from .figure_labels import FROM_REST, column_label, key_label, key_value, summary_label
from .study import DONE


def _axes(figure, study, xlabel, ylabel):
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(wrapped(figure.title or study.title), fontsize=9)
    ax.grid(alpha=0.3)
    return fig, ax


#: A legend of more entries than this goes to the right of the axes, the figure widened for it:
#: inside, fifteen entries covered half the curves.
LEGEND_INSIDE = 8


def _finish(fig, ax):
    entries = len(ax.get_legend_handles_labels()[0])
    if entries > LEGEND_INSIDE:
        width, height = fig.get_size_inches()
        fig.set_size_inches(width + 3.0, height)
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    elif entries:
        ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def _save(fig, path):
    fig.savefig(path, dpi=120)
    pyplot().close(fig)


def legend(case, figure, study):
    """The case's label, then the swept values that neither it names nor the figure selects
    on, in words; its folder name if that leaves nothing."""
    fixed = {key for key, _ in figure.select} | set(case.named)
    words = [key_value(key, case.values[key], case.scene) for key in study.short
             if key in case.values and key not in fixed]
    if case.label:
        words.insert(0, case.label)
    return ", ".join(words) or case.name


def curves_figure(figure, outcomes, study, out):
    """curve.csv column y against column x, one line per case that converged a step (from
    the initial state where both are zero there): the first ten solid in the default
    colours, the next ten dashed and the next dotted in them."""
    scene = study.cases[0].scene
    start = [0.0] if figure.x in FROM_REST and figure.y in FROM_REST else []
    fig, ax = _axes(figure, study, column_label(figure.x, scene), column_label(figure.y, scene))
    colours = pyplot().rcParams["axes.prop_cycle"].by_key()["color"]
    ax.set_prop_cycle(cycler(linestyle=["-", "--", ":"]) * cycler(color=colours))
    for outcome in outcomes:
        path = out / outcome.case.name / "curve.csv"
        rows = list(csv.DictReader(path.open())) if path.exists() else []
        if rows:
            ax.plot(start + [float(r[figure.x]) for r in rows],
                    start + [float(r[figure.y]) for r in rows],
                    marker="o", ms=3, label=legend(outcome.case, figure, study))
    return _finish(fig, ax)


def curves_png(figure, outcomes, study, out):
    _save(curves_figure(figure, outcomes, study, out), out / f"{figure.name}.png")


def sweep_figure(figure, outcomes, study):
    """A summary value against a swept key, one line per value of figure.lines; cases that
    did not reach their end are left out."""
    scene = study.cases[0].scene
    fig, ax = _axes(figure, study, key_label(figure.x, scene), summary_label(figure.y, scene))
    lines = {}
    for outcome in outcomes:
        values = outcome.case.values
        if (outcome.status in DONE and figure.x in values
                and outcome.summary.get(figure.y) is not None):
            key = values.get(figure.lines) if figure.lines else None
            lines.setdefault(key, []).append((values[figure.x], outcome.summary[figure.y]))
    for key, points in lines.items():
        xs, ys = zip(*sorted(points))
        ax.plot(xs, ys, "o-", ms=4,
                label=None if key is None else key_value(figure.lines, key, scene))
    return _finish(fig, ax)


def sweep_png(figure, outcomes, study, out):
    _save(sweep_figure(figure, outcomes, study), out / f"{figure.name}.png")
