"""Load stepping with step cutting, on a scripted stand-in for the FE problem."""
import pytest

from soilbin.errors import ConvergenceError
from soilbin.solver.newton import NewtonResult
from soilbin.solver.stepping import Observation, run_load_steps


class CollapsingProblem:
    """Newton fails for load factors above ``limit`` (a collapse load)."""

    def __init__(self, limit):
        self.limit, self.trial, self.committed, self.solves = limit, 0.0, 0.0, 0

    def set_load_factor(self, factor):
        self.trial = factor

    def solve(self):
        self.solves += 1
        if self.trial > self.limit:
            raise ConvergenceError("diverged")
        return NewtonResult(3, (1.0, 1e-3, 1e-9))

    def commit(self):
        self.committed = self.trial

    def roll_back(self):
        self.trial = self.committed

    def observe(self):
        return Observation(self.committed, 10 * self.committed)


def test_reaches_full_load_in_nominal_steps():
    problem, seen = CollapsingProblem(limit=2.0), []
    result = run_load_steps(problem, steps=4, max_cuts=3, on_step=seen.append)
    assert result.complete and [r.load_factor for r in result.steps] == [0.25, 0.5, 0.75, 1.0]
    assert seen == list(result.steps) and problem.solves == 4


def test_brackets_a_collapse_load_to_the_smallest_increment():
    problem = CollapsingProblem(limit=0.63)
    result = run_load_steps(problem, steps=4, max_cuts=5, on_step=lambda r: None)
    assert not result.complete and "smallest increment, 1/128" in result.message
    last = result.steps[-1].load_factor
    assert last <= 0.63 < last + 1 / 128          # bracketed to the smallest increment
    assert problem.committed == last               # the failed trial was rolled back
    assert all(r.force == pytest.approx(10 * r.load_factor) for r in result.steps)


def test_increment_grows_back_after_a_cut():
    class Hiccup(CollapsingProblem):
        def solve(self):
            self.solves += 1
            if self.solves == 2:        # the second solve fails once
                raise ConvergenceError("hiccup")
            return NewtonResult(2, (1.0, 1e-12))

    result = run_load_steps(Hiccup(limit=9.0), steps=2, max_cuts=3, on_step=lambda r: None)
    assert [r.load_factor for r in result.steps] == [0.5, 0.75, 1.0]
    assert [r.cuts for r in result.steps] == [0, 1, 0]
    assert [r.cut_reason for r in result.steps] == ["", "hiccup", ""]   # for the progress line


def test_steps_land_on_the_stated_load_factors():
    result = run_load_steps(CollapsingProblem(limit=2.0), steps=4, max_cuts=3,
                            on_step=lambda r: None, stops=(0.3, 0.6))
    assert [r.load_factor for r in result.steps] == pytest.approx([0.25, 0.3, 0.55, 0.6, 0.85, 1.0])


def test_a_limit_ends_the_run_after_the_step_that_reaches_it():
    """The ``limit`` callback sees every converged step; the run stops at the first it names."""
    seen = []

    def limit(records):
        seen.append(len(records))
        return "limit reached" if records[-1].load_factor >= 0.5 else None

    result = run_load_steps(CollapsingProblem(limit=2.0), steps=4, max_cuts=3,
                            on_step=lambda r: None, limit=limit)
    assert not result.complete and result.limit_reached and result.message == "limit reached"
    assert [r.load_factor for r in result.steps] == [0.25, 0.5] and seen == [1, 2]


class NarrowSteps(CollapsingProblem):
    """Above load factor 0.25 a step converges only if it is at most 1/8 (in 3 iterations)."""

    def solve(self):
        self.solves += 1
        if self.trial > 0.25 and self.trial - self.committed > 0.125 + 1e-12:
            raise ConvergenceError("too large")
        return NewtonResult(3, (1.0, 1e-3, 1e-9))


@pytest.mark.parametrize("regrow_after_cut, cuts", [(0, 5), (2, 2), (5, 1)])
def test_after_a_cut_the_increment_waits_for_easy_steps_to_grow(regrow_after_cut, cuts):
    """Nominal quarters: past 0.25 every quarter fails. With the increment doubling at once
    every eighth but the last is a cut; waiting for two easy eighths (the cut one included),
    every third; for five, only the first."""
    result = run_load_steps(NarrowSteps(limit=2.0), steps=4, max_cuts=3, on_step=lambda r: None,
                            regrow_after_cut=regrow_after_cut)
    assert result.complete
    assert [r.load_factor for r in result.steps] == pytest.approx(
        [0.25, 0.375, 0.5, 0.625, 0.75, 0.875, 1.0])
    assert sum(r.cuts for r in result.steps) == cuts


def test_a_resumed_run_keeps_waiting_after_a_cut():
    """Stopped in the middle of the wait, the run goes on as if it had not stopped."""
    whole = run_load_steps(NarrowSteps(limit=2.0), steps=4, max_cuts=3, on_step=lambda r: None,
                           regrow_after_cut=5)
    problem = NarrowSteps(limit=2.0)
    problem.committed = whole.steps[3].load_factor
    resumed = run_load_steps(problem, steps=4, max_cuts=3, on_step=lambda r: None,
                             regrow_after_cut=5, resume=whole.steps[:4])
    assert whole.steps[3].held > 0
    assert [(r.load_factor, r.cuts) for r in resumed.steps] == [
        (r.load_factor, r.cuts) for r in whole.steps]
