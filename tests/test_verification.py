"""The verification scenes of the dissertation, chapter VII, against closed forms."""
import csv

import pytest

from soilbin.closed_form.verification import (column_settlement, prandtl_limit_pressure,
                                              unconfined_strength)


@pytest.mark.parametrize("E, nu, p", [(9000.0, 0.2, 100.0), (2.5e4, 0.45, 7.0), (1.0, -0.3, 1e-3)])
def test_column_settles_pL_over_M(solve, E, nu, p):
    """VII.1, eq. 7.1: w = p L / M, for any E, nu, p."""
    summary, _ = solve("column-elastic", f"materials.soil.E={E}", f"materials.soil.nu={nu}",
                       f"loading.magnitude={p}")
    L = 10.0   # the scene's column height, mesh.lz
    assert summary["pressure"] == pytest.approx(p, rel=1e-10)
    assert summary["top_settlement"] == pytest.approx(column_settlement(p, L, E, nu), rel=1e-8)


@pytest.mark.parametrize("control, magnitude", [("force", 100.0), ("displacement", 0.1)])
def test_a_first_step_cut_to_2_to_the_minus_30_still_settles_pL_over_M(solve, control, magnitude):
    """The first step at 2^-30 of the load sets Newton's force scale; the rounding of the
    larger loads after it must not pass the residual floor (each step then stagnated from
    about 1e-5 of the load on, the 16th step, until the smallest increment failed)."""
    summary, out = solve("column-elastic", f"loading.control={control}",
                         f"loading.magnitude={magnitude}", "loading.first_cuts=30",
                         "loading.max_cuts=30")
    assert summary["status"] == "complete"
    with open(out / "curve.csv") as f:
        assert sum(1 for _ in csv.DictReader(f)) > 30
    exact = magnitude if control == "displacement" else column_settlement(magnitude, 10.0, 9000.0,
                                                                          0.2)
    assert summary["top_settlement"] == pytest.approx(exact, rel=1e-8)


def test_the_footing_in_other_units_takes_the_same_iterations_to_the_same_limit(solve):
    """E and c in units 1e9 times larger (the lengths kept): the same Newton iterations and
    the limit pressure scaled to 1e-9. The residual's prescribed rows hold the footing's
    mismatch x - g (in) at a step's first iterate; counted in its norm beside forces of 1e-9
    of the scene's, they made the first step's tolerance (rtol times that norm) so loose
    that the run read 113.8 psi instead of 111.7 in 10 iterations instead of 46 (plain
    quad4, whose rows are all forces)."""
    limits = []
    for scale in (1.0, 1e-9):
        summary, _ = solve("strip-footing-von-mises", "analysis.element=quad4",
                           f"materials.clay.E={30000.0 * scale!r}",
                           f"materials.clay.c={17.5 * scale!r}")
        assert summary["status"] == "complete"
        limits.append((summary["newton_iterations"], summary["limit_pressure"] / scale))
    assert limits[1][0] == limits[0][0]
    assert limits[1][1] == pytest.approx(limits[0][1], rel=1e-9)


@pytest.mark.parametrize("c, phi", [(500.0, 30.0), (100.0, 10.0), (20.0, 45.0)])
def test_block_collapses_at_mohr_coulomb_uniaxial_strength(solve, c, phi):
    """VII.2, eq. 7.7: the compression cone gives 2c cos(phi)/(1 - sin(phi)) (1732 psf)."""
    strength = unconfined_strength(c, phi)
    # displace to three times the yield settlement whatever the strength
    settle = 3 * strength / 500000.0
    summary, _ = solve("block-drucker-prager", f"materials.soil.c={c}", f"materials.soil.phi={phi}",
                       f"loading.magnitude={settle}")
    assert summary["collapse_stress"] == pytest.approx(strength, rel=0.01)
    assert summary["collapse_stress"] == pytest.approx(strength, rel=1e-6)   # homogeneous: exact


@pytest.mark.parametrize("c, E", [(17.5, 30000.0), (10.0, 20000.0)])
def test_rigid_footing_limit_pressure_prandtl(solve, c, E):
    """VII.4: the rigid footing's limit pressure within 3% of (2 + pi) c (default mesh)."""
    summary, out = solve("strip-footing-von-mises", f"materials.clay.c={c}", f"materials.clay.E={E}")
    assert summary["status"] == "complete"
    assert summary["limit_pressure"] == pytest.approx(prandtl_limit_pressure(c), rel=0.03)
    # the curve reached its plateau: the last two steps carry the same load to 0.1%
    with open(out / "curve.csv") as f:
        pressure = [float(row["pressure"]) for row in csv.DictReader(f)]
    assert pressure[-1] == pytest.approx(pressure[-2], rel=1e-3)


def test_plain_bilinear_quadrilaterals_lock(solve):
    """Why the footing scene uses quad4-bbar: plain quad4 overestimates the limit by > 5%."""
    summary, _ = solve("strip-footing-von-mises", "analysis.element=quad4")
    assert summary["limit_pressure"] > 1.05 * prandtl_limit_pressure(17.5)


@pytest.mark.parametrize("steps", [10, 1])
def test_flexible_strip_load_collapses_near_prandtl(solve, steps):
    """VII.4 under force control: the last converged load brackets the collapse load. In one
    nominal step (100 psi, above the limit) no step reaches the criterion's reference: the
    run ends where no larger load converges (1/64 of the load apart), and that is the
    collapse pressure (it read none)."""
    summary, out = solve("strip-load-von-mises", f"loading.steps={steps}")
    assert summary["status"] == "collapse" and summary["converged"]
    assert summary["collapse_pressure"] == pytest.approx(prandtl_limit_pressure(17.5), rel=0.03)
    with open(out / "curve.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == summary["n_steps"]
    assert float(rows[-1]["pressure"]) == pytest.approx(summary["collapse_pressure"])


@pytest.mark.slow
def test_container_footing_drucker_prager_is_stiffer_than_the_cap(solve):
    """VII.5: the dissertation's ranking, Drucker-Prager the stiffest (at 0.1 in)."""
    coarse = ("loading.magnitude=0.1", "loading.steps=4")
    dp, _ = solve("container-footing", *coarse)
    cap, _ = solve("container-footing", *coarse, "regions.soil=modified_cap")
    assert dp["footing_pressure"] > 3.0 * cap["footing_pressure"] > 0.0
