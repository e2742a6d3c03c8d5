"""The plateau of a long travel (a tool pushed several depths through the soil): the force
averaged over the last part of the travel, how much it still varies there and how fast it
still rises, for the run's headline (``steady_force``, ``steady_spread``, ``steady_slope``:
the last :data:`STEADY_FRACTION`) or over a longer part (``fraction``: a curve whose remeshes
cut teeth into it, docs/chapter8.md)."""
import numpy as np

#: The plateau is the last this fraction of the final displacement: the last inch of six.
STEADY_FRACTION = 1.0 / 6.0


def plateau(records, fraction=STEADY_FRACTION):
    """(displacements, forces) of the converged steps in the last ``fraction`` of the final
    displacement, the window's start interpolated on the curve from zero."""
    d = np.array([0.0] + [r.displacement for r in records])
    f = np.array([0.0] + [r.force for r in records])
    start = (1.0 - fraction) * d[-1]
    inside = d > start
    return (np.concatenate([[start], d[inside]]),
            np.concatenate([[np.interp(start, d, f)], f[inside]]))


def steady_force(records, fraction=STEADY_FRACTION):
    """The mean force over the plateau, the curve integrated over the displacement (steps of
    any length weigh by their travel)."""
    d, f = plateau(records, fraction)
    if d[-1] <= d[0]:
        return float(f[-1])
    return float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(d)) / (d[-1] - d[0]))


def steady_spread(records):
    """The force's range over the plateau, relative to its mean: how far the travel still is
    from a steady state."""
    _, f = plateau(records)
    return float((f.max() - f.min()) / steady_force(records))


def steady_slope(records, fraction=STEADY_FRACTION):
    """The slope of the straight line fitted by least squares to the force over the plateau
    (force per unit displacement; the curve between the steps taken as straight, sampled
    evenly so that steps of any length weigh by their travel): zero on a steady state, the
    rise that remains otherwise, apart from the curve's scatter about it."""
    d, f = plateau(records, fraction)
    if d[-1] <= d[0]:
        return 0.0
    x = np.linspace(d[0], d[-1], 201)
    return float(np.polyfit(x, np.interp(x, d, f), 1)[0])
