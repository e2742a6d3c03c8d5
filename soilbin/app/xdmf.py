"""An XDMF time series that a kill cannot corrupt (one process writes it; h5py, no FEniCSx).

Layout: ``NAME.xdmf`` (XML) beside a folder holding ``NAME-mesh.h5`` (points
and cells, written once; after a remesh ``NAME-mesh-1.h5``, ...) and one
``NAME-000003.h5`` per frame (every field of that frame). One temporal
collection of uniform grids, each naming its mesh and carrying all the frame's
fields: the layout meshio's ``TimeSeriesReader`` (which reads the first grid's
mesh only), ParaView's XDMF readers and pyvista read. A frame's HDF5 file is complete and
closed before the XML naming it replaces the old XML atomically, so after a
kill the series lists exactly the frames that are on disk, each readable.
"""
import os
from pathlib import Path
from xml.sax.saxutils import quoteattr

import h5py
import numpy as np

from .outdir import FRAMES_DIR

#: Attribute type by number of components.
ATTRIBUTE_TYPES = {1: "Scalar", 3: "Vector", 9: "Tensor"}


def _data_item(array, ref):
    dims = " ".join(str(n) for n in array.shape)
    number = "Int" if np.issubdtype(array.dtype, np.integer) else "Float"
    return (f'<DataItem Dimensions="{dims}" NumberType="{number}" '
            f'Precision="{array.dtype.itemsize}" Format="HDF">{ref}</DataItem>')


class XdmfSeries:
    """Frames of point and cell fields on a mesh (a new one after a remesh, :meth:`new_mesh`);
    ``information``: name -> text, written into the XML and onto every HDF5 file (e.g. the
    sign convention)."""

    def __init__(self, path, points, cells, topology_type, information):
        self.path = Path(path)
        self.folder = self.path.parent / FRAMES_DIR
        self.folder.mkdir(exist_ok=True)
        self._name = self.path.stem
        self._info = dict(information)
        self._topology_type = topology_type
        self._meshes = 0
        self._frames = []
        self.new_mesh(points, cells)

    def new_mesh(self, points, cells):
        """The frames from here on are on this mesh (after a remesh): its own HDF5 file,
        ``NAME-mesh.h5`` for the first, ``NAME-mesh-1.h5``, ... for the next."""
        self.n_points = len(points)
        mesh_file = f"{self._name}-mesh{f'-{self._meshes}' if self._meshes else ''}.h5"
        self._meshes += 1
        self._write_h5(mesh_file, {"points": np.asarray(points, dtype=float),
                                   "cells": np.asarray(cells, dtype=np.int64)})
        shape_points, shape_cells = np.shape(points), np.shape(cells)
        self._mesh_xml = (
            f'<Topology TopologyType="{self._topology_type}" '
            f'NumberOfElements="{shape_cells[0]}" NodesPerElement="{shape_cells[1]}">'
            + _data_item(np.empty(shape_cells, np.int64), f"{FRAMES_DIR}/{mesh_file}:/cells")
            + '</Topology><Geometry GeometryType="XYZ">'
            + _data_item(np.empty(shape_points), f"{FRAMES_DIR}/{mesh_file}:/points")
            + "</Geometry>")

    def _write_h5(self, name, arrays):
        with h5py.File(self.folder / name, "w") as f:
            for key, text in self._info.items():
                f.attrs[key] = text
            for key, array in arrays.items():
                f.create_dataset(key, data=array)
            f.flush()
            os.fsync(f.id.get_vfd_handle())

    def write(self, t, point_data, cell_data):
        """One frame at time ``t``: name -> array (n_points or n_cells rows)."""
        frame_file = f"{self._name}-{len(self._frames):06d}.h5"
        arrays = {**point_data, **cell_data}
        self._write_h5(frame_file, arrays)
        attributes = []
        for name, array in arrays.items():
            center = "Node" if name in point_data else "Cell"
            components = 1 if array.ndim == 1 else array.shape[1]
            attributes.append(
                f'<Attribute Name={quoteattr(name)} AttributeType="{ATTRIBUTE_TYPES[components]}" '
                f'Center="{center}">' + _data_item(array, f"{FRAMES_DIR}/{frame_file}:/{name}")
                + "</Attribute>")
        self._frames.append(f'<Grid Name="frame {len(self._frames)}" GridType="Uniform">'
                            f'{self._mesh_xml}<Time Value="{t!r}"/>{"".join(attributes)}</Grid>')
        self._write_xml()

    def _write_xml(self):
        info = "".join(f"<Information Name={quoteattr(k)} Value={quoteattr(v)}/>"
                       for k, v in self._info.items())
        text = ('<?xml version="1.0"?>\n<Xdmf Version="3.0">\n<Domain>\n' + info
                + f'\n<Grid Name="{self._name}" GridType="Collection" CollectionType="Temporal">\n'
                + "\n".join(self._frames) + "\n</Grid>\n</Domain>\n</Xdmf>\n")
        partial = self.path.with_suffix(".xdmf.partial")
        with open(partial, "w") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(partial, self.path)
