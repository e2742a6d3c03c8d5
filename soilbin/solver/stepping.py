"""Incremental loading with step cutting.

The load factor goes from 0 to 1 in steps of at most the scene's nominal
increment 1/steps, landing exactly on any stated load factors (``stops``) on
the way; the first step is the nominal increment halved ``first_cuts`` times.
A step whose Newton solve fails is rolled back and halved; the increment
never goes below the nominal one over 2**max_cuts, which ends the run (under
force control, at the collapse load to that resolution). The next increment
follows the last step's Newton iterations: it doubles (back toward the
nominal one) after an easy step (at most ``EASY`` iterations), halves after
a hard one (at least ``HARD``, before the next one fails), and stays
otherwise. After a cut it doubles again only once ``regrow_after_cut`` easy
steps (the cut step's own included) have converged at the smaller size (0: at
once), so that a load range where the larger step fails is not tried again at
every step. Every converged step is handed to ``on_step`` at once, so a run
that stops early leaves all its converged steps behind; its record carries the
increment the stepper tries next and the easy steps it still waits for, so
that a run can go on from it (``resume``: the records of a run whose
problem state was restored to its last step). A ``limit`` callback, asked after every converged step, may end
the run early with its message (under force control: the soil's limit is
reached, the travel running away).
"""
import dataclasses
import math
import time
from typing import Protocol, Sequence

from ..errors import ConvergenceError

#: Newton iterations of an easy step (the increment doubles) and of a hard one (it halves):
#: 5 and 10 take the footing's refine 1-4 in the fewest iterations at the scenes' residual
#: floor of 1e-6 (58, 73, 90, 95; 4 and 8 take 63, 79, 94, 99; docs/performance.md,
#: *Newton's residual floor and the step rule*).
EASY, HARD = 5, 10


class SolveResult(Protocol):
    iterations: int
    residuals: Sequence[float]


class SteppedProblem(Protocol):
    """What the load stepper drives (``problem.SoilProblem``, or a stand-in in tests)."""

    def set_load_factor(self, factor: float) -> None:
        """Load (or prescribed displacement) at this factor of the scene's magnitude."""

    def solve(self) -> SolveResult:
        """Equilibrium from the last committed state; raises ConvergenceError on failure."""

    def commit(self) -> None:
        """The converged state becomes the start of the next step."""

    def roll_back(self) -> None:
        """Back to the last committed state after a failed solve."""

    def observe(self) -> "Observation":
        """What the converged state shows along the loading direction."""


@dataclasses.dataclass(frozen=True)
class Observation:
    displacement: float     # of the driven boundary or tool, along the loading direction
    force: float            # on it, along the loading direction
    columns: dict = dataclasses.field(default_factory=dict)   # further named values per step


@dataclasses.dataclass(frozen=True)
class StepRecord:
    step: int
    load_factor: float
    displacement: float
    force: float
    newton_iterations: int
    cuts: int
    failed_iterations: int  # spent on the attempts of this step that were cut
    wall_s: float
    residuals: tuple
    columns: dict = dataclasses.field(default_factory=dict)
    cut_reason: str = ""    # why the last attempt of this step that was cut failed
    next_increment: float = 0.0   # the load factor's increment the stepper tries next
    held: int = 0           # easy steps still to converge before the increment may grow


@dataclasses.dataclass(frozen=True)
class StepperResult:
    steps: tuple
    complete: bool          # reached load factor 1
    message: str            # why it stopped early ('' when complete)
    limit_reached: bool = False   # stopped by the ``limit`` callback
    stalled: bool = False   # a step failed with the smallest increment


def run_load_steps(problem: SteppedProblem, steps, max_cuts, on_step, clock=time.perf_counter,
                   stops=(), limit=None, first_cuts=0, resume=(), regrow_after_cut=0):
    """Drive ``problem`` to load factor 1, a step ending on each of ``stops`` (load factors);
    ``limit(records)``, if given, returns why the run ends after the last record, or None.
    ``resume``: the records of the steps already taken (the problem at the last one's state);
    the run goes on from there, its records following them."""
    nominal = 1.0 / steps
    level, factor = first_cuts, 0.0      # increment = nominal / 2**level
    held = 0                             # easy steps to wait before the increment grows
    cuts, failed, reason = 0, 0, ""
    records, start = list(resume), clock()
    if records:
        last = records[-1]
        factor, start = last.load_factor, start - last.wall_s
        level = round(math.log2(nominal / last.next_increment))
        held = last.held
    while factor < 1.0 - 1e-12:
        increment = min(nominal / 2**level, 1.0 - factor)
        stop = min((s for s in stops if s > factor + 1e-12), default=None)
        if stop is not None and factor + increment > stop:
            increment = stop - factor
        problem.set_load_factor(factor + increment)
        try:
            result = problem.solve()
        except ConvergenceError as err:
            problem.roll_back()
            failed += getattr(err, "iterations", 0)
            reason = str(err)
            if level == max_cuts:
                return StepperResult(tuple(records), False,
                                     f"step to load factor {factor + increment:.6g} failed with the "
                                     f"smallest increment, 1/{steps * 2**max_cuts} ({err})",
                                     stalled=True)
            cuts += 1
            level += 1
            held = regrow_after_cut
            continue
        factor += increment
        problem.commit()
        seen = problem.observe()
        if result.iterations <= EASY and held:
            held -= 1
        elif result.iterations <= EASY:
            level = max(level - 1, 0)
        elif result.iterations >= HARD:
            level = min(level + 1, max_cuts)
        record = StepRecord(len(records) + 1, factor, seen.displacement, seen.force,
                            result.iterations, cuts, failed, clock() - start, result.residuals,
                            seen.columns, reason, nominal / 2**level, held)
        records.append(record)
        on_step(record)
        ended = limit(records) if limit is not None else None
        if ended:
            return StepperResult(tuple(records), False, ended, limit_reached=True)
        cuts, failed, reason = 0, 0, ""
    return StepperResult(tuple(records), True, "")
