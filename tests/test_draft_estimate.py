"""McKyes & Ali narrow-blade draft (soilbin.closed_form).

No published worked example of the McKyes & Ali model (McKyes 1985 ch. 4,
McKyes & Ali 1977, Godwin & O'Dogherty 2007) could be found through search,
so the centre wedge is checked against earth-pressure closed forms it must
reproduce when the side crescents are switched off (crescents = 0: a plane
wide blade), and the crescent terms only by symmetry and linearity.
"""
import math
import subprocess
import sys
from pathlib import Path

import pytest

from soilbin.closed_form import MODEL, NoWedge, chapter_viii_cases, chapter_viii_table, narrow_tine_draft
from soilbin.closed_form.earth_pressure import rankine_passive

rad = math.radians
ROOT = Path(__file__).resolve().parent.parent


def coulomb_kp(phi, delta, theta):
    """Coulomb's passive coefficient, planar wedge, horizontal surface, wall back at theta
    from the vertical (Das, Principles of Foundation Engineering, "Coulomb's passive earth
    pressure": Kp = cos^2(phi + theta) / (cos^2 theta cos(delta - theta)
    [1 - sqrt(sin(phi + delta) sin phi / (cos(delta - theta) cos theta))]^2),
    P_p = Kp gamma H^2 / 2 inclined at delta to the wall's normal)."""
    phi, delta, theta = rad(phi), rad(delta), rad(theta)
    root = math.sqrt(math.sin(phi + delta) * math.sin(phi) / (math.cos(delta - theta) * math.cos(theta)))
    return math.cos(phi + theta) ** 2 / (math.cos(theta) ** 2 * math.cos(delta - theta) * (1 - root) ** 2)


@pytest.mark.parametrize("phi", [20.0, 33.0, 40.0])
def test_smooth_vertical_wide_blade_is_rankine_passive(phi):
    """alpha = 90, delta = 0, c = 0: H = Kp gamma d^2 w / 2 with Kp = tan^2(45 + phi/2) and
    the failure plane at beta = 45 - phi/2 (Rankine); phi = 33 gives Kp/2 = 1.6961."""
    est = narrow_tine_draft(width=1.0, depth=1.0, rake=90.0, phi=phi, delta=0.0, gamma=1.0, crescents=0)
    kp = rankine_passive(phi)
    assert est.draft == pytest.approx(kp / 2.0, rel=1e-9)
    assert est.vertical == pytest.approx(0.0, abs=1e-9)
    assert est.rupture_angle == pytest.approx(45.0 - phi / 2.0, abs=1e-5)
    assert est.rupture_distance == pytest.approx(1.0 / math.tan(rad(45.0 - phi / 2.0)), rel=1e-6)


def test_smooth_vertical_wide_blade_cohesion_is_bell():
    """c only: H = 2 c d w sqrt(Kp) (Bell); phi = 30 gives 2 sqrt(3) = 3.4641."""
    est = narrow_tine_draft(width=1.0, depth=1.0, rake=90.0, phi=30.0, delta=0.0, gamma=0.0, c=1.0,
                            crescents=0)
    assert est.draft == pytest.approx(2.0 * math.sqrt(3.0), rel=1e-9)


@pytest.mark.parametrize("rake, phi, delta", [(90.0, 33.0, 22.0), (90.0, 30.0, 10.0), (75.0, 35.0, 20.0),
                                              (60.0, 33.0, 22.0), (45.0, 30.0, 15.0)])
def test_rough_raked_wide_blade_is_coulomb_passive(rake, phi, delta):
    """The centre wedge is Coulomb's passive wedge on a wall whose back leans theta = 90 - alpha
    from the vertical under the soil: F = Kp gamma d^2 / 2 per width, H = F sin(alpha + delta),
    V = F cos(alpha + delta). Vertical, phi = 33, delta = 22 (the tine scene): Kp = 7.937,
    H = 3.748 gamma d^2 w, the soil lifting the blade by 1.514 gamma d^2 w."""
    est = narrow_tine_draft(width=1.0, depth=1.0, rake=rake, phi=phi, delta=delta, gamma=1.0, crescents=0)
    force = coulomb_kp(phi, delta, 90.0 - rake) / 2.0
    assert est.draft == pytest.approx(force * math.sin(rad(rake + delta)), rel=1e-9)
    assert est.vertical == pytest.approx(force * math.cos(rad(rake + delta)), rel=1e-9)
    if (rake, phi, delta) == (90.0, 33.0, 22.0):
        assert est.draft == pytest.approx(3.748, abs=5e-4)
        assert est.vertical == pytest.approx(-1.514, abs=5e-4)


def test_one_crescent_against_the_wall_is_half_a_double_width_tool():
    """A frictionless wall is a mirror: w against it carries half of 2w in the open soil."""
    soil = dict(depth=6.0, rake=60.0, phi=33.0, delta=22.0, gamma=0.072, c=0.1, c_a=0.05, q=0.2)
    wall = narrow_tine_draft(width=2.0, crescents=1, **soil)
    open_soil = narrow_tine_draft(width=4.0, crescents=2, **soil)
    assert wall.draft == pytest.approx(open_soil.draft / 2.0, rel=1e-9)
    assert wall.vertical == pytest.approx(open_soil.vertical / 2.0, rel=1e-9)
    assert wall.rupture_angle == pytest.approx(open_soil.rupture_angle, abs=1e-6)


def test_centre_wedge_is_linear_in_width_and_the_crescents_fade_on_wide_blades():
    """Secondary: the centre wedge alone (crescents = 0) scales with w; with the crescents a
    narrow tool costs more per unit width, and a wide one tends to the plane blade."""
    soil = dict(depth=6.0, rake=90.0, phi=33.0, delta=22.0, gamma=0.072)
    plane = {w: narrow_tine_draft(width=w, crescents=0, **soil).draft for w in (1.0, 2.0, 4.0)}
    assert plane[2.0] == pytest.approx(2.0 * plane[1.0], rel=1e-9)
    assert plane[4.0] == pytest.approx(4.0 * plane[1.0], rel=1e-9)
    ratio = [narrow_tine_draft(width=w, **soil).draft / (w * plane[1.0]) for w in (1.0, 4.0, 40.0, 4000.0)]
    assert ratio == sorted(ratio, reverse=True)
    assert ratio[0] > 5.0 and ratio[-1] == pytest.approx(1.0, abs=0.01)


def test_rake_and_the_vertical_force():
    """Secondary: a low rake needs less draft and pulls the tool in; a vertical rough tine is
    lifted; the rupture reaches r = d (cot alpha + cot beta) ahead, r' to the side."""
    soil = dict(width=2.0, depth=6.0, phi=33.0, delta=22.0, gamma=0.072)
    steep, low = narrow_tine_draft(rake=90.0, **soil), narrow_tine_draft(rake=30.0, **soil)
    assert low.draft < steep.draft
    assert low.vertical > 0.0 > steep.vertical
    cot_a, cot_b = 1.0 / math.tan(rad(30.0)), 1.0 / math.tan(rad(low.rupture_angle))
    assert low.rupture_distance == pytest.approx(6.0 * (cot_a + cot_b), rel=1e-9)
    assert low.crescent_extent == pytest.approx(6.0 * math.sqrt(cot_b**2 + 2 * cot_a * cot_b), rel=1e-9)


def test_adhesion_adds_to_the_draft_and_lifts_the_tool():
    base = dict(width=2.0, depth=6.0, rake=45.0, phi=33.0, delta=22.0, gamma=0.072)
    dry, sticky = narrow_tine_draft(**base), narrow_tine_draft(c_a=0.1, **base)
    assert sticky.draft > dry.draft
    assert sticky.vertical < dry.vertical


def test_bad_input():
    with pytest.raises(ValueError, match="crescents"):
        narrow_tine_draft(2.0, 6.0, 90.0, 33.0, 22.0, 0.072, crescents=3)
    with pytest.raises(ValueError, match="rake"):
        narrow_tine_draft(2.0, 6.0, 120.0, 33.0, 22.0, 0.072)


def test_chapter_viii_cases():
    cases = chapter_viii_cases()
    assert [c[0] for c in cases] == ["8.2", "8.3", "8.4", "8.5", "8.6", "8.7", "8.8", "8.9"]
    assert all(e.model == MODEL for *_, e in cases)
    vertical = {w: e.draft for fig, w, rake, e in cases if rake == 90.0 and e.crescents == 2}
    assert vertical[1.0] < vertical[2.0] < vertical[3.0] < vertical[4.0]
    table = chapter_viii_table()
    assert table.count("\n") == len(cases) + 1 and "| 8.9 | 2 | 30 | 2 |" in table


def test_closed_form_imports_no_finite_element_stack():
    code = ("import sys, soilbin.closed_form; "
            "print(sorted(m for m in ('dolfinx', 'gmsh', 'petsc4py', 'matplotlib', 'ufl') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_each_tool_scene_gets_the_estimate_of_the_whole_tool():
    """estimates.material_draft_estimate: the scene's geometry, soil (phi, c), gravity and interface
    (delta, c_a); against the glass wall one crescent; embedded (a half model whose forces
    the tool reports for the whole tool) both."""
    from soilbin.app.estimates import material_draft_estimate
    from soilbin.records.scene import load_scene

    scene = ROOT / "scenes" / "tine-2in-90deg.toml"
    dp = ["regions.soil=drucker_prager", "materials.drucker_prager.c=0.05"]
    wall = material_draft_estimate(load_scene(scene, dp))
    assert wall == narrow_tine_draft(2.0, 6.0, 90.0, phi=33.0, delta=22.0, gamma=0.072, c=0.05,
                                     crescents=1, strength="material drucker_prager")
    embedded = material_draft_estimate(load_scene(scene, dp + ["mesh.configuration=embedded",
                                                               "mesh.rake_angle=45"]))
    whole = narrow_tine_draft(2.0, 6.0, 45.0, phi=33.0, delta=22.0, gamma=0.072, c=0.05,
                              strength="material drucker_prager")
    assert embedded == whole     # the FE reports the whole tool across the symmetry plane
    bonded = material_draft_estimate(load_scene(scene, dp + ["tool.bonded=true"]))
    assert bonded == narrow_tine_draft(2.0, 6.0, 90.0, phi=33.0, delta=33.0, gamma=0.072, c=0.05,
                                       c_a=0.05, crescents=1, strength="material drucker_prager")
    cap = material_draft_estimate(load_scene(scene))   # the modified cap: its failure surface's
    assert cap == narrow_tine_draft(2.0, 6.0, 90.0, phi=cap.phi, delta=22.0, gamma=0.072, c=cap.c,
                                    crescents=1, strength=cap.strength)
    assert 45.0 < cap.phi < 55.0 and cap.strength == "failure surface linearised at I1 = 2.86 psi"
    with pytest.raises(NoWedge, match="phi = 50.6 from the failure surface"):
        material_draft_estimate(load_scene(scene, ["tool.bonded=true"]))   # 90 + 2 phi > 180
    assert material_draft_estimate(load_scene(ROOT / "scenes" / "column-elastic.toml")) is None


def test_the_tine_scene_estimates_with_the_laboratory_strength():
    """[tool.estimate] of the tine scene: phi = 33 deg, c = 0 of section VII.5 (75 lb against
    the wall, 129 lb embedded), then the cap surface's (832, 1540 lb) beside it; a bonded tool
    is fully rough with the laboratory phi, and the cap surface's wedge cannot form then."""
    from soilbin.app.estimates import draft_estimate, draft_estimates, material_draft_estimate
    from soilbin.records.scene import load_scene

    scene = ROOT / "scenes" / "tine-2in-90deg.toml"
    lab = {"phi": 33.0, "gamma": 0.072, "strength": "laboratory, section VII.5"}
    wall, cap = draft_estimates(load_scene(scene))
    assert wall == narrow_tine_draft(2.0, 6.0, 90.0, delta=22.0, crescents=1, **lab)
    assert cap == material_draft_estimate(load_scene(scene))
    embedded = [e.draft for e in draft_estimates(load_scene(scene, ["mesh.configuration=embedded"]))]
    assert [round(wall.draft), round(cap.draft)] == [75, 832]
    assert [round(d, -1) for d in embedded] == [130, 1540]
    bonded = load_scene(scene, ["tool.bonded=true"])
    assert draft_estimates(bonded) == [draft_estimate(bonded)]
    assert draft_estimate(bonded) == narrow_tine_draft(2.0, 6.0, 90.0, delta=33.0, crescents=1, **lab)


def test_a_tool_file_is_estimated_as_the_flat_blade_of_its_width():
    """The STEP blade (scenes/tine-2in-cad.toml, embedded) is the built-in 2-in blade 6 in
    deep: its faces span 1 in of y, half of the blade, so McKyes & Ali gives the embedded
    hex blade's drafts, named as a flat blade 2 in wide; against the glass wall one
    crescent."""
    import sys
    sys.path.insert(0, str(ROOT / "tests"))
    from conftest import make_problem
    from soilbin.app.estimates import blade_of, draft_estimates
    from soilbin.records.scene import load_scene

    coarse = ["mesh.element_size=1.5", "mesh.growth=1.8"]
    cad = make_problem(ROOT / "scenes" / "tine-2in-cad.toml", *coarse)
    blade = blade_of(cad.scene, cad)
    assert (blade.width, blade.depth, blade.rake, blade.crescents) == (
        pytest.approx(2.0, rel=1e-9), 6.0, 90.0, 2)
    assert blade_of(cad.scene) is None   # a file's width is read from its mesh
    hexes = draft_estimates(load_scene(ROOT / "scenes" / "tine-2in-108lb.toml"))
    files = draft_estimates(cad.scene, blade)
    assert [f.draft for f in files] == pytest.approx([h.draft for h in hexes], rel=1e-9)
    assert files[0].model == f"{MODEL}, as a flat blade 2 in wide"
    wall = make_problem(ROOT / "scenes" / "tine-2in-cad.toml", *coarse,
                        "mesh.configuration=side_wall")
    assert blade_of(wall.scene, wall).crescents == 1


@pytest.mark.parametrize("key, value", [("phi", "90"), ("phi", "-1"), ("c", "-0.1"), ("c", "inf"),
                                        ("phi", "'33'")])
def test_estimate_strength_out_of_range_is_refused(key, value):
    from soilbin.errors import InputError
    from soilbin.records.scene import load_scene
    with pytest.raises(InputError, match=f"tool.estimate.{key}"):
        load_scene(ROOT / "scenes" / "tine-2in-90deg.toml", [f"tool.estimate.{key}={value}"])


def test_keys_list_the_estimate_strength():
    from soilbin.app.keys import scene_keys
    from soilbin.records.scene import load_scene
    rows = {key: (value, accepted, doc) for key, value, accepted, doc
            in scene_keys(load_scene(ROOT / "scenes" / "tine-2in-90deg.toml"))}
    assert rows["tool.estimate.phi"][:2] == (33.0, "[0, 90)")
    assert rows["tool.estimate.c"][:2] == (0.0, "[0, 1e+20]")
    assert rows["tool.estimate.source"][0] == "laboratory, section VII.5"
    assert all(rows[f"tool.estimate.{key}"][2] for key in ("phi", "c", "source"))


@pytest.mark.parametrize("phi, c", [(20.0, 0.0), (33.0, 0.05), (45.0, 1.0)])
def test_compression_cone_inverts_back_to_mohr_coulomb(phi, c):
    from soilbin.closed_form import mohr_coulomb_of_compression_cone
    from soilbin.models.matching import Matching
    alpha, k = Matching.COMPRESSION_CONE.coefficients(c, phi)
    assert mohr_coulomb_of_compression_cone(alpha, k) == pytest.approx((phi, c), rel=1e-12, abs=1e-14)
    with pytest.raises(ValueError, match="alpha"):
        mohr_coulomb_of_compression_cone(0.6, k)       # steeper than any Mohr–Coulomb meridian


def test_straight_failure_surface_keeps_its_own_strength():
    """A Drucker–Prager cone written as F(I1) = k + alpha I1 is its own tangent at any depth."""
    from soilbin.closed_form import passive_wedge_strength
    from soilbin.models.matching import Matching
    alpha, k = Matching.COMPRESSION_CONE.coefficients(0.05, 33.0)
    for depth in (2.0, 6.0, 20.0):
        s = passive_wedge_strength(lambda I1: (k + alpha * I1, alpha), 0.072, depth)
        assert (s.phi, s.c) == pytest.approx((33.0, 0.05), rel=1e-12)


@pytest.mark.parametrize("B", [0.0, 0.11])   # DiMaggio–Sandler and the modified cap, VII.5
def test_curved_failure_surface_is_linearised_at_the_passive_state(B):
    """The returned envelope touches sqrt(J2) = A + B I1 - C exp(-beta I1) at I1*, and I1* is
    the Rankine passive state's first invariant at mid-depth, 3/2 (1 + Kp) gamma d/2."""
    from soilbin.closed_form import passive_wedge_strength
    from soilbin.models.matching import Matching

    def failure(I1):
        e = 5.6 * math.exp(-0.062 * I1)
        return 5.6 + B * I1 - e, B + 0.062 * e

    s = passive_wedge_strength(failure, 0.072, 6.0)
    kp = rankine_passive(s.phi)
    assert s.I1 == pytest.approx(1.5 * (1.0 + kp) * 0.072 * 3.0, rel=1e-10)
    alpha, k = Matching.COMPRESSION_CONE.coefficients(s.c, s.phi)
    F, dF = failure(s.I1)
    assert (alpha, k + alpha * s.I1) == pytest.approx((dF, F), rel=1e-10)
    assert s.c >= 0.0 and 30.0 < s.phi < 60.0      # steep at low confinement (A = C: no c at I1 = 0)
