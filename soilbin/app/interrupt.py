"""SIGTERM and SIGINT as an exception the run can answer, and sections they must not cut.

Inside :func:`handlers`, either signal raises :class:`Interrupted` in the main
thread (not KeyboardInterrupt, and nothing a bare ``except Exception``
catches), so the run writes its summary with status "interrupted" and the
command line exits with 128 + the signal number, without a traceback. Inside
:func:`deferred` (writing a curve row or a frame of fields) a signal is held
until the section ends, so no file is left half written.
"""
import contextlib
import signal

SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Interrupted(BaseException):
    """The process got SIGINT or SIGTERM."""

    def __init__(self, signum):
        self.signum = signum
        self.name = signal.Signals(signum).name
        super().__init__(f"interrupted by {self.name}")

    @property
    def exit_status(self):
        return 128 + self.signum


_state = {"deferring": 0, "pending": None}


def _handler(signum, frame):
    if _state["deferring"]:
        _state["pending"] = signum
        return
    raise Interrupted(signum)


@contextlib.contextmanager
def kept():
    """The SIGINT and SIGTERM handlers of now, back on leaving (gmsh sets SIGINT's to the
    default on import and to the one it found then on finalize)."""
    previous = {s: signal.getsignal(s) for s in SIGNALS}
    try:
        yield
    finally:
        for s, old in previous.items():
            if old is not None:   # None: a handler not set from Python
                signal.signal(s, old)


@contextlib.contextmanager
def handlers():
    """SIGINT and SIGTERM raise Interrupted while inside (the old handlers come back after)."""
    with kept():
        for s in SIGNALS:
            signal.signal(s, _handler)
        yield


@contextlib.contextmanager
def deferred():
    """Hold SIGINT and SIGTERM until the section ends, then raise Interrupted."""
    _state["deferring"] += 1
    try:
        yield
    finally:
        _state["deferring"] -= 1
        pending, _state["pending"] = _state["pending"], None
        if pending is not None and not _state["deferring"]:
            raise Interrupted(pending)
        _state["pending"] = pending
