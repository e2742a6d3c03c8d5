"""The soil's limit under force control: the first step whose displacement per unit of load
increment runs away (COLLAPSE_COMPLIANCE times a secant compliance), for the run's headline
and to end a run that has reached it; the load stepper's settings of a scene, that limit
among them."""
from ..records.scene import COLLAPSE_COMPLIANCE, Control


def collapse_step(loads, displacements, reference=1):
    """Index of the first step (of curves starting at zero, not included) whose displacement
    increment per unit load increment is at least COLLAPSE_COMPLIANCE times the secant
    compliance displacements[reference] / loads[reference] (by default the first step's),
    or None."""
    compliance = displacements[reference] / loads[reference]
    for k in range(1, len(loads)):
        dp, dw = loads[k] - loads[k - 1], displacements[k] - displacements[k - 1]
        if dw >= COLLAPSE_COMPLIANCE * compliance * dp:
            return k
    return None


def nominal_step(factors, nominal):
    """Index of the first step (of load factors starting at zero) at the nominal increment
    ``nominal`` or beyond, or None: the secant compliance there is the collapse criterion's
    reference (:func:`collapse_limit`)."""
    return next((k for k, factor in enumerate(factors) if k and factor >= nominal * (1 - 1e-9)),
                None)


def collapse_pressure(records, nominal=None, at_limit=False):
    """The pressure of the first step whose settlement increment per unit pressure increment
    is at least COLLAPSE_COMPLIANCE times the secant one at the first step of the load factor
    ``nominal`` (None: the first step), as :func:`collapse_limit` ends a run; where no step
    is, and the run ended at the soil's limit all the same (``at_limit``: no step past the
    last converged), the last step's pressure; else None."""
    pressures = [0.0] + [r.columns["pressure"] for r in records]
    reference = 1 if nominal is None else nominal_step(
        [0.0] + [r.load_factor for r in records], nominal)
    k = None if reference is None else collapse_step(
        pressures, [0.0] + [r.displacement for r in records], reference)
    if k is None and at_limit and records:
        return pressures[-1]
    return None if k is None else pressures[k]


def collapse_limit(scene):
    """Under force control with ``until_collapse``: the stepper's ``limit`` that ends the run
    at the first step whose travel per unit of applied load is COLLAPSE_COMPLIANCE times the
    secant compliance at the first nominal load step, 1/steps of the load (the soil's limit:
    the travel runs away), else None. Not the first step's own compliance: where that step
    was cut to a small fraction of the nominal one in a soil that is stiff only at first (a
    normally consolidated cap soil leaves its elastic range at about 1/1000 of the tine's
    draft), the compaction that follows would read as a runaway."""
    loading = scene.loading
    if loading.control is not Control.FORCE or not loading.until_collapse:
        return None

    def limit(records):
        loads = [0.0] + [r.load_factor * loading.magnitude for r in records]
        reference = nominal_step([0.0] + [r.load_factor for r in records], 1.0 / loading.steps)
        displacements = [0.0] + [r.displacement for r in records]
        if reference is None or collapse_step(loads, displacements, reference) is None:
            return None
        last = records[-1]
        return (f"the soil's limit: at load {loads[-1]:.6g} the displacement per unit load of "
                f"step {last.step} is at least {COLLAPSE_COMPLIANCE:g} times the secant one at "
                f"load {loads[reference]:.6g} (displacement {last.displacement:.6g})")
    return limit


def stepping(scene):
    """The load stepper's settings of ``scene``: ``run_load_steps``'s keywords but the problem,
    ``on_step``, ``stops`` and ``resume``."""
    loading = scene.loading
    return dict(steps=loading.steps, max_cuts=loading.max_cuts, limit=collapse_limit(scene),
                first_cuts=loading.first_cuts, regrow_after_cut=loading.regrow_after_cut)
