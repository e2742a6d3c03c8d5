"""The quadratic simplices (tet10, tet10-bbar, tri6, tri6-bbar) on the builders' meshes split
into tetrahedra (triangles): the verification problems of chapter VII against their closed
forms, as the bricks meet them."""
import csv
import math

import pytest

from soilbin.closed_form.verification import (column_settlement, prandtl_limit_pressure,
                                              unconfined_strength)


@pytest.mark.parametrize("element", ["tet10", "tet10-bbar"])
def test_the_tetrahedral_column_settles_pL_over_M(solve, element):
    """VII.1, eq. 7.1: a linear displacement field, which P2 holds exactly."""
    summary, _ = solve("column-elastic", f"analysis.element={element}")
    assert summary["n_cells"] == 6 * 6   # each brick of the 1 x 1 x 6 grid in six
    assert summary["top_settlement"] == pytest.approx(column_settlement(100.0, 10.0, 9000.0, 0.2),
                                                      rel=1e-8)


def test_the_tetrahedral_block_collapses_at_the_mohr_coulomb_stress(solve):
    """VII.2, eq. 7.7: the stress is uniform, so the collapse is exact on any cells."""
    summary, _ = solve("block-drucker-prager", "analysis.element=tet10-bbar")
    assert summary["collapse_stress"] == pytest.approx(unconfined_strength(500.0, 30.0), rel=1e-6)


@pytest.mark.parametrize("nu", [0.3, pytest.param(0.49, marks=pytest.mark.slow)])
def test_mean_dilatation_triangles_reach_prandtl_and_plain_ones_lock(solve, nu):
    """VII.4: tri6-bbar (P2/P0) on the 2D footing mesh (edge cells 0.02 ft) within 0.2% of
    (2 + pi) c at any Poisson's ratio; plain tri6 must meet the isochoric flow at every point
    and overestimates it by more than 0.8% (docs/verification.md)."""
    coarse = ("mesh.dimension=2", "mesh.edge_size=0.02", f"materials.clay.nu={nu}")
    bbar, _ = solve("strip-footing-von-mises", *coarse, "analysis.element=tri6-bbar")
    plain, _ = solve("strip-footing-von-mises", *coarse, "analysis.element=tri6")
    exact = prandtl_limit_pressure(17.5)
    assert abs(bbar["limit_pressure"] / exact - 1.0) < 0.002
    assert plain["limit_pressure"] / exact - 1.0 > 0.008


def test_the_tetrahedral_column_follows_log_strain_in_large_deformation(solve):
    """VII.1, eq. 7.6, updated Lagrangian on tetrahedra: sigma = M ln(L / (L - w)) to 30%
    of the height, as the bricks (the same curve to 1e-12: the column strains uniformly)."""
    summary, out = solve("column-elastic-large", "analysis.element=tet10-bbar")
    with open(out / "curve.csv") as f:
        rows = [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]
    bricks, _ = solve("column-elastic-large")   # into the same folder: the curve read first
    M, L = 9000.0 * 0.8 / (1.2 * 0.6), 10.0
    assert rows[-1]["displacement"] / L >= 0.3
    for row in rows:
        assert row["pressure"] == pytest.approx(M * math.log(L / (L - row["displacement"])), rel=5e-3)
    assert summary["top_settlement"] == pytest.approx(bricks["top_settlement"], rel=1e-12)
