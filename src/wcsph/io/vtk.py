"""ParaView output: one .vtu per output time for the fluid (written with meshio), one .vtu
for the static walls, and .pvd collections that tie them into a time series. Every file is
written atomically (``atomic``): a run killed at any moment leaves each file either whole or
absent, never truncated."""
import os
import xml.etree.ElementTree as ET
from contextlib import contextmanager
from pathlib import Path

import meshio
import numpy as np


@contextmanager
def atomic(path):
    """Yield a temporary path beside ``path``; on success rename it to ``path`` (an atomic
    replace on POSIX and Windows), on failure remove it."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        try:
            tmp.unlink()
        except OSError:
            pass
        raise


def write_text(path, text):
    with atomic(path) as tmp:
        with open(tmp, "w") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())


def write_points(path, x, point_data):
    """Particles as VTK vertex cells; ``x`` is (dim, N), vectors in ``point_data`` too."""
    n = x.shape[1]
    pts = np.zeros((n, 3))
    pts[:, : x.shape[0]] = x.T
    data = {}
    for k, a in point_data.items():
        a = np.asarray(a)
        if a.ndim == 2:
            v = np.zeros((n, 3), dtype=a.dtype)
            v[:, : a.shape[0]] = a.T
            a = v
        data[k] = a
    mesh = meshio.Mesh(pts, [("vertex", np.arange(n).reshape(-1, 1))], point_data=data)
    with atomic(path) as tmp:
        mesh.write(tmp, file_format="vtu")


def write_pvd(path, entries):
    """``entries``: (time, part, file name) triples; ParaView reads parts as one dataset."""
    root = ET.Element("VTKFile", type="Collection", version="0.1", byte_order="LittleEndian")
    coll = ET.SubElement(root, "Collection")
    for t, part, name in entries:
        ET.SubElement(coll, "DataSet", timestep=f"{t:.9g}", group="", part=str(part), file=name)
    ET.indent(root)
    with atomic(path) as tmp:
        ET.ElementTree(root).write(tmp, xml_declaration=True, encoding="utf-8")


#: VTK's names of the numpy types meshio writes
_VTK_TYPES = {"float32": "Float32", "float64": "Float64", "int64": "Int64", "int32": "Int32", "uint8": "UInt8"}


def write_pvtu(path, pieces, point_data):
    """The .pvtu that joins ``pieces`` (.vtu files of ``write_points``, one per rank) into one
    dataset; ``point_data`` gives the arrays' names, types and components (as for
    ``write_points``; vectors have 3 components there)."""
    root = ET.Element("VTKFile", type="PUnstructuredGrid", version="0.1", byte_order="LittleEndian")
    grid = ET.SubElement(root, "PUnstructuredGrid", GhostLevel="0")
    pd = ET.SubElement(grid, "PPointData")
    for k, a in point_data.items():
        a = np.asarray(a)
        ET.SubElement(pd, "PDataArray", type=_VTK_TYPES[a.dtype.name], Name=k,
                      NumberOfComponents="3" if a.ndim == 2 else "1")
    pts = ET.SubElement(grid, "PPoints")
    ET.SubElement(pts, "PDataArray", type="Float64", Name="points", NumberOfComponents="3")
    for name in pieces:
        ET.SubElement(grid, "Piece", Source=name)
    ET.indent(root)
    with atomic(path) as tmp:
        ET.ElementTree(root).write(tmp, xml_declaration=True, encoding="utf-8")


def write_image(path, origin, spacing, counts, point_data):
    """A VTK image (.vti): nodes origin + i * spacing per axis, ``counts`` nodes per axis (3
    of each; 1 along an axis the grid does not span), x fastest; ``point_data`` arrays of
    shape (n,) or (3, n), inline base64 binary (ParaView, VisIt and meshio's vtk readers)."""
    import base64

    ext = " ".join(f"0 {c - 1}" for c in counts)
    root = ET.Element("VTKFile", type="ImageData", version="0.1", byte_order="LittleEndian",
                      header_type="UInt32")
    img = ET.SubElement(root, "ImageData", WholeExtent=ext, Origin=" ".join(f"{o:.9g}" for o in origin),
                        Spacing=" ".join(f"{s:.9g}" for s in spacing))
    pd = ET.SubElement(ET.SubElement(img, "Piece", Extent=ext), "PointData")
    for name, a in point_data.items():
        a = np.asarray(a)
        data = np.ascontiguousarray(a.T if a.ndim == 2 else a).astype(a.dtype.newbyteorder("<"))
        raw = data.tobytes()
        arr = ET.SubElement(pd, "DataArray", type=_VTK_TYPES[a.dtype.name], Name=name, format="binary",
                            NumberOfComponents=str(a.shape[0] if a.ndim == 2 else 1))
        arr.text = base64.b64encode(np.uint32(len(raw)).tobytes() + raw).decode("ascii")
    with atomic(path) as tmp:
        ET.ElementTree(root).write(tmp, xml_declaration=True, encoding="utf-8")


def read_image(path):
    """(origin, spacing, counts, {name: (n, components) array}) of a .vti of ``write_image``."""
    import base64

    img = ET.parse(path).getroot().find("ImageData")
    ext = [int(v) for v in img.get("WholeExtent").split()]
    types = {v: k for k, v in _VTK_TYPES.items()}
    out = {}
    for a in img.iter("DataArray"):
        raw = base64.b64decode(a.text)
        n = int(np.frombuffer(raw[:4], "<u4")[0])
        data = np.frombuffer(raw[4:4 + n], np.dtype(types[a.get("type")]).newbyteorder("<"))
        out[a.get("Name")] = data.reshape(-1, int(a.get("NumberOfComponents")))
    return ([float(v) for v in img.get("Origin").split()], [float(v) for v in img.get("Spacing").split()],
            [ext[1] - ext[0] + 1, ext[3] - ext[2] + 1, ext[5] - ext[4] + 1], out)
