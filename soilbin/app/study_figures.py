"""Overlay figures of a study: the cases' curves, or a summary value against a swept key."""
import csv

from ..plotting import pyplot
from .study import DONE, label


def _axes(figure, study, xlabel, ylabel):
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 4.2))
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(f"{figure.title or study.title}\nunits: {study.units}", fontsize=8)
    ax.grid(alpha=0.3)
    return fig, ax


def _save(fig, ax, path):
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    pyplot().close(fig)


def _legend(case, figure, study):
    """The case's swept values that the figure does not select on (its folder name if none)."""
    fixed = {key for key, _ in figure.select}
    text = ", ".join(f"{short} = {label(case.values[key])}" for key, short in study.short.items()
                     if key in case.values and key not in fixed)
    return text or case.name


def curves_png(figure, outcomes, study, out):
    """curve.csv column y against column x, one line per case that converged a step."""
    fig, ax = _axes(figure, study, figure.x, figure.y)
    for outcome in outcomes:
        path = out / outcome.case.name / "curve.csv"
        rows = list(csv.DictReader(path.open())) if path.exists() else []
        if rows:
            ax.plot([float(r[figure.x]) for r in rows], [float(r[figure.y]) for r in rows],
                    "o-", ms=3, label=_legend(outcome.case, figure, study))
    _save(fig, ax, out / f"{figure.name}.png")


def sweep_png(figure, outcomes, study, out):
    """A summary value against a swept key, one line per value of figure.lines; cases that
    did not reach their end are left out."""
    fig, ax = _axes(figure, study, study.short[figure.x], figure.y)
    lines = {}
    for outcome in outcomes:
        values = outcome.case.values
        if (outcome.status in DONE and figure.x in values
                and outcome.summary.get(figure.y) is not None):
            key = label(values[figure.lines]) if figure.lines in values else None
            lines.setdefault(key, []).append((values[figure.x], outcome.summary[figure.y]))
    for key, points in lines.items():
        xs, ys = zip(*sorted(points))
        ax.plot(xs, ys, "o-", ms=4,
                label=None if key is None else f"{study.short[figure.lines]} = {key}")
    _save(fig, ax, out / f"{figure.name}.png")
