"""matplotlib's pyplot on the Agg backend, imported when the first figure is drawn: the
import costs about 0.9 s CPU, which a run pays at its end, not before its first step."""


def pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt
