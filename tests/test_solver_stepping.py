"""Step sizes from the Newton iteration count, and the iterations of cut attempts."""
from soilbin.errors import ConvergenceError
from soilbin.solver.newton import NewtonFailure, NewtonResult
from soilbin.solver.stepping import EASY, HARD, Observation, run_load_steps


class Scripted:
    """Newton takes the scripted iterations, one entry per solve; None fails after 3."""

    def __init__(self, script):
        self.script, self.factor, self.committed = list(script), 0.0, 0.0

    def set_load_factor(self, factor):
        self.factor = factor

    def solve(self):
        iterations = self.script.pop(0)
        if iterations is None:
            raise NewtonFailure("diverged", 3)
        return NewtonResult(iterations, (1.0,) * (iterations + 1))

    def commit(self):
        self.committed = self.factor

    def roll_back(self):
        self.factor = self.committed

    def observe(self):
        return Observation(self.committed, 0.0)


def factors(script, steps=4, max_cuts=3, first_cuts=0):
    result = run_load_steps(Scripted(script), steps, max_cuts, lambda r: None,
                            first_cuts=first_cuts)
    return [r.load_factor for r in result.steps], result


def test_a_hard_step_halves_the_next_and_easy_steps_grow_back():
    seen, _ = factors([HARD, EASY, EASY, EASY, EASY, EASY])
    assert seen == [0.25, 0.375, 0.625, 0.875, 1.0]


def test_middling_steps_keep_the_increment():
    seen, _ = factors([HARD, EASY + 1, EASY + 1, EASY, EASY, EASY, EASY])
    assert seen == [0.25, 0.375, 0.5, 0.625, 0.875, 1.0]


def test_the_first_step_starts_cut_and_easy_steps_grow_back():
    seen, result = factors([EASY] * 6, first_cuts=2)
    assert seen == [0.0625, 0.1875, 0.4375, 0.6875, 0.9375, 1.0]
    assert [r.cuts for r in result.steps] == [0] * 6


def test_cut_attempts_are_counted_on_the_step_that_converges():
    seen, result = factors([None, None] + [3] * 6)
    assert seen == [0.0625, 0.1875, 0.4375, 0.6875, 0.9375, 1.0]
    assert [r.failed_iterations for r in result.steps][:2] == [6, 0]
    assert [r.cuts for r in result.steps][:2] == [2, 0]


def test_a_plain_convergence_error_counts_no_iterations():
    class Failing(Scripted):
        def solve(self):
            if self.script and self.script[0] is None:
                self.script.pop(0)
                raise ConvergenceError("no count")
            return super().solve()

    result = run_load_steps(Failing([None, 2, 2, 2, 2, 2]), 4, 3, lambda r: None)
    assert result.complete and result.steps[0].failed_iterations == 0
