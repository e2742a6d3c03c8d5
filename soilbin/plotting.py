"""matplotlib's pyplot on the Agg backend, imported when the first figure is drawn: the
import costs about 0.9 s CPU, which a run pays at its end, not before its first step."""
import textwrap


def pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def wrapped(title, width=80):
    """A title on lines of at most ``width`` characters, broken between words."""
    return textwrap.fill(title, width, break_on_hyphens=False)
