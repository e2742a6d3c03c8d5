"""The soil-bin builder's gmsh geometry (declaration: :mod:`.soil_bin`)."""
from .blocks import block_grid, entities_within, on_plane
from .soil_bin import SoilBinParams, tool_faces


def soil_blocks(p: SoilBinParams, simplices: bool) -> None:
    """The (xi, y, z) block grid without the blade's block, mapped to x = xi + shear(z) blend(xi)."""
    d, back = p.tool_depth, p.tip - p.blade

    def mapping(xi, y, z):
        blend = min(xi / back, 1.0, (p.length - xi) / p.ahead)
        return xi - max(z + d, 0.0) / d * p.run * blend, y, z

    block_grid(*p.segments(), keep=lambda i, j, k: (i, j, k) != (1, 0, 1), mapping=mapping,
               simplices=simplices)


def geometry(p: SoilBinParams, simplices: bool):
    soil_blocks(p, simplices)
    cavity = entities_within(2, x=(p.behind, p.tip), y=(0.0, p.span), z=(-p.tool_depth, 0.0))
    boundaries = {name: on_plane(2, cavity, *plane) for name, plane in tool_faces(p).items()}
    boundaries |= {
        "surface": entities_within(2, z=0.0),
        "base": entities_within(2, z=-p.bin_depth),
        "symmetry": entities_within(2, y=0.0),
        "side": entities_within(2, y=p.bin_width),
        "front_end": entities_within(2, x=p.length),
        "back_end": entities_within(2, x=0.0),
    }
    return {"soil": entities_within(3)}, boundaries
