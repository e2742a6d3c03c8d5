"""The soil bin around a tool read from a CAD file (builder soil_bin_cad): the solid placed
and cut out, its faces the contact groups by the way they face, and every file or placement
it cannot use refused in one line before meshing."""
import gmsh
import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx.cpp.mesh import entities_to_geometry
from mpi4py import MPI

from soilbin.errors import InputError
from soilbin.meshes import scene_mesh
from soilbin.meshes.cad_tool import TOOL_FACES
from soilbin.records.scene import load_scene
from conftest import SCENES, make_problem

CAD = SCENES / "tine-2in-cad.toml"
COMM = MPI.COMM_WORLD
INCH = 25.4


def total(form):
    return COMM.allreduce(fem.assemble_scalar(fem.form(form)), op=MPI.SUM)


def tool_area(tm):
    """The area of each of the tool's groups, name -> area."""
    one = fem.Constant(tm.mesh, 1.0)
    ds = ufl.Measure("ds", domain=tm.mesh, subdomain_data=tm.facet_tags)
    return {name: total(one * ds(tm.boundaries[name])) for name in TOOL_FACES}


def tool_facets(tm):
    return np.concatenate([tm.facet_tags.find(tm.boundaries[name]) for name in TOOL_FACES])


def write_step(path, shape):
    """A STEP file of the solid (or surface) ``shape(occ)`` makes, in millimetres."""
    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        shape(gmsh.model.occ)
        gmsh.model.occ.synchronize()
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return path


@pytest.mark.parametrize("configuration, width", [("embedded", 1.0), ("side_wall", 2.0)])
def test_the_blade_s_cavity_is_its_faces_by_the_way_they_face(configuration, width):
    """The STEP blade (0.5 x 2 in, 6 in in the soil): the soil is the bin less the blade's
    part below the surface, its faces there in the groups of the built-in blade (half the
    blade embedded, the glass wall against its side otherwise), none on top."""
    scene = load_scene(CAD, [f"mesh.configuration={configuration}", "mesh.element_size=1.5",
                             "mesh.growth=1.8"])
    p = scene.mesh
    tm = scene_mesh(scene, COMM)
    assert tm.mesh.topology.cell_type.name == "tetrahedron"
    one = fem.Constant(tm.mesh, 1.0)
    ds = ufl.Measure("ds", domain=tm.mesh, subdomain_data=tm.facet_tags)
    length = p.behind + 0.5 + p.ahead
    assert total(one * ufl.dx(domain=tm.mesh)) == pytest.approx(
        length * p.bin_width * p.bin_depth - width * 0.5 * 6.0, rel=1e-9)
    area = tool_area(tm)
    expected = {"tool_front": width * 6.0, "tool_back": width * 6.0, "tool_side": 0.5 * 6.0,
                "tool_bottom": 0.5 * width, "tool_top": 0.0}
    assert area == pytest.approx(expected, rel=1e-9, abs=1e-12)
    assert total(one * ds(tm.boundaries["surface"])) == pytest.approx(
        length * p.bin_width - 0.5 * width, rel=1e-9)


def test_a_raked_tool_leans_back_with_its_lowest_point_at_the_tool_depth():
    """rake_angle 60: the blade turned 30 degrees about y, its top back; the tool's faces
    reach down to tool_depth and lean back by tan 30 per unit of height."""
    scene = load_scene(CAD, ["mesh.rake_angle=60", "mesh.element_size=1.5", "mesh.growth=1.8"])
    tm = scene_mesh(scene, COMM)
    facets = tool_facets(tm)
    x = tm.mesh.geometry.x[entities_to_geometry(tm.mesh._mesh, 2, facets, False).ravel()]
    lowest = COMM.allreduce(x[:, 2].min(initial=np.inf), op=MPI.MIN)
    assert lowest == pytest.approx(-6.0, abs=1e-9)
    deepest = x[np.isclose(x[:, 2], lowest)]
    top = x[np.isclose(x[:, 2], 0.0)]
    # the front edge at the surface lies tan 30 x (6 - the corner's rise) behind the tip
    rise = 0.5 * np.sin(np.radians(30.0))
    assert top[:, 0].max() == pytest.approx(deepest[:, 0].max() + 0.5 * np.cos(np.radians(30.0))
                                            - (6.0 - rise) * np.tan(np.radians(30.0))
                                            , abs=1e-9)


def plate(occ):
    """A surface, not a solid."""
    occ.addRectangle(0.0, 0.0, 0.0, 50.0, 50.0)


def ell(occ):
    """An L-shaped solid, not symmetric about any plane y = const."""
    occ.fuse([(3, occ.addBox(0.0, 0.0, 0.0, 12.7, 50.8, 200.0))],
             [(3, occ.addBox(0.0, 0.0, 0.0, 60.0, 12.7, 200.0))])


@pytest.mark.parametrize("overrides, shape, message", [
    (["mesh.tool_file=garbage.step"], None, "gmsh cannot read it"),
    (["mesh.tool_file=plate.step"], plate, "holds no closed solid"),
    (["mesh.tool_file=ell.step"], ell, "not symmetric about its mid-plane in y"),
    (["mesh.configuration=side_wall", "mesh.bin_width=1.5"], None,
     r"the tool reaches \|y\| = 2, beyond the bin's side: mesh.bin_width = 1.5 must be more"),
    (["mesh.tool_depth=10"], None, "the tool's top lies 2 below the surface"),
    (["mesh.element_size=0.1", "mesh.growth=1.01"], None,
     r"about 5.27e\+06 tetrahedra; accepted: at most 1e\+06"),
])
def test_a_tool_the_bin_cannot_hold_is_refused_before_meshing(tmp_path, overrides, shape,
                                                              message):
    (tmp_path / "garbage.step").write_text("not a STEP file")
    if shape is not None:
        write_step(tmp_path / overrides[0].split("=")[1], shape)
    overrides = [o.replace("=", f"={tmp_path}/") if o.startswith("mesh.tool_file") else o
                 for o in overrides]
    scene = load_scene(CAD, overrides)
    with pytest.raises(InputError, match=message):
        scene_mesh(scene, COMM)


@pytest.mark.parametrize("overrides, message", [
    (["mesh.tool_file=blade.stl"], "not a CAD file gmsh reads; accepted: .step, .stp, .iges"),
    (["mesh.tool_file=none.step"], "none.step': no such file"),
    (["analysis.element=hex8-bbar"], "meshes tetrahedra; use tet10-bbar"),
    (["mesh.tool_depth=12"], "tool_depth = 12.0 must be less than bin_depth = 12.0"),
])
def test_a_scene_that_cannot_mesh_its_tool_is_refused_when_read(overrides, message):
    with pytest.raises(InputError, match=message):
        load_scene(CAD, overrides)


#: The 2-in blade (0.5 x 2 x 8 in) as gmsh scripts: on the OpenCASCADE kernel, with a
#: physical group and a mesh size of its own that the builder must not take; on gmsh's
#: built-in kernel, which cannot be cut out of the bin.
GEO_BLADE = """SetFactory("OpenCASCADE");
Mesh.MeshSizeMax = 0.05;
Box(1) = {0, 0, 0, 0.5, 2, 8};
Physical Volume("blade") = {1};
"""
GEO_BUILT_IN = """Point(1) = {0, 0, 0};
l[] = Extrude {0.5, 0, 0} { Point{1}; };
s[] = Extrude {0, 2, 0} { Line{l[1]}; };
v[] = Extrude {0, 0, 8} { Surface{s[1]}; };
"""


def test_a_geo_script_is_a_tool_file_as_a_step_file_is(tmp_path):
    """The blade from a .geo script (in inches: tool_scale 1) makes the STEP blade's soil:
    the same volume and tool faces, about as many cells (the script's mesh size and physical
    group do not reach the soil); a script on the built-in kernel is refused in one line."""
    coarse = ["mesh.element_size=1.5", "mesh.growth=1.8"]
    (tmp_path / "blade.geo").write_text(GEO_BLADE)
    (tmp_path / "built-in.geo").write_text(GEO_BUILT_IN)
    meshes = [scene_mesh(load_scene(CAD, coarse + extra), COMM) for extra in (
        [], [f"mesh.tool_file={tmp_path / 'blade.geo'}", "mesh.tool_scale=1.0"])]
    volume = [total(fem.Constant(tm.mesh, 1.0) * ufl.dx(domain=tm.mesh)) for tm in meshes]
    tool = [tool_area(tm) for tm in meshes]
    assert volume[1] == pytest.approx(volume[0], rel=1e-9)
    assert tool[1] == pytest.approx(tool[0], rel=1e-9, abs=1e-12)
    assert sum(tool[0].values()) == pytest.approx(15.5)
    cells = [COMM.allreduce(tm.mesh.topology.index_map(3).size_local) for tm in meshes]
    assert cells[1] == pytest.approx(cells[0], rel=0.2)
    assert set(meshes[1].regions) == {"soil"}
    scene = load_scene(CAD, [f"mesh.tool_file={tmp_path / 'built-in.geo'}", "mesh.tool_scale=1.0"])
    with pytest.raises(InputError,
                       match=r'built-in kernel; begin it with SetFactory\("OpenCASCADE"\)'):
        scene_mesh(scene, COMM)


def test_a_section_of_tetrahedra_draws_the_nodes_within_half_a_cell_of_its_plane():
    """A tetrahedral mesh has no planes of nodes: each section of figures 8.10-8.12 draws the
    nodes within half the median diameter of the cells at the tool of its plane (the
    horizontal section at the tip depth held only the blade's own bottom nodes before)."""
    from soilbin.app.section_figures import section_panels

    problem = make_problem(CAD, "mesh.element_size=1.5", "mesh.growth=1.8")
    panels, _, _, half = section_panels(problem)
    assert 0.3 < half < 1.5
    x = problem.nodal_displacement()[0]
    counts = [(len(xs), np.count_nonzero(np.abs(x[:, normal] - plane) < 1e-9), len(tool))
              for _, normal, plane, _, xs, _, tool in panels]
    assert all(drawn >= max(on_plane, 40) and tool >= 8 for drawn, on_plane, tool in counts)
    (_, tip_on_plane, _) = counts[1]
    assert tip_on_plane < 40, counts   # the horizontal section at the tip: the tool's nodes
