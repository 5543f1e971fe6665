"""Readers for msim's series: .vtu files (raw appended binary, UInt64 headers) listed by a .pvd, and
the parallel HDF5 frames listed by series.xdmf (h5py, Debian's python3-h5py)."""
import re
import struct
import xml.etree.ElementTree as ET

import numpy as np

DTYPES = {"Float64": np.float64, "Int64": np.int64, "UInt8": np.uint8}


def read_vtu(path):
    """Returns dict name -> array: 'points' (n,3), 'connectivity' (m,k) for cells of k vertices
    each (2 springs as lines, 3 triangles, 4 tets), 'fixed' (n,), others."""
    with open(path, "rb") as f:
        data = f.read()
    start = data.index(b"<AppendedData")
    start = data.index(b"_", start) + 1
    header = data[:start].decode("latin-1")
    out = {}
    for m in re.finditer(r'<DataArray type="(\w+)"(?: Name="(\w+)")?(?: NumberOfComponents="(\d+)")? format="appended" offset="(\d+)"/>', header):
        dtype, name, ncomp, offset = m.group(1), m.group(2) or "points", int(m.group(3) or 1), int(m.group(4))
        pos = start + offset
        (nbytes,) = struct.unpack("<Q", data[pos:pos + 8])
        arr = np.frombuffer(data[pos + 8:pos + 8 + nbytes], dtype=DTYPES[dtype])
        out[name] = arr.reshape(-1, ncomp) if ncomp > 1 else arr
    sizes = np.diff(np.concatenate([[0], out["offsets"]]))
    k = int(sizes[0]) if len(sizes) else 2
    if len(sizes) and (sizes != k).any():
        raise ValueError(f"{path}: cells of mixed sizes")
    out["connectivity"] = out["connectivity"].reshape(-1, k)
    return out


def boundary_faces(tets):
    """The triangles of a tet mesh that belong to one tet only (its surface), each oriented
    outward for tets of positive volume."""
    faces = np.concatenate([tets[:, [1, 2, 3]], tets[:, [0, 3, 2]], tets[:, [0, 1, 3]], tets[:, [0, 2, 1]]])
    key = np.sort(faces, axis=1)
    _, first, count = np.unique(key, axis=0, return_index=True, return_counts=True)
    return faces[first[count == 1]]


def read_pvd(path):
    """Returns [(time, vtu path)] in order: each frame's part 0, its cells (a mesh's springs are
    part 1, a file of their own)."""
    import os
    root = ET.parse(path).getroot()
    base = os.path.dirname(path)
    return [(float(d.get("timestep")), os.path.join(base, d.get("file"))) for d in root.iter("DataSet") if d.get("part", "0") == "0"]


def read_xdmf(path):
    """Returns [(time, loader)] of an msim series.xdmf: loader() reads that frame's grid, a dict as
    read_vtu's (points, connectivity, fixed), from the HDF5 files the XDMF names."""
    import os
    import h5py
    base = os.path.dirname(path)
    cache = {}

    def dataset(item):
        file, name = item.strip().split(":")
        if file.startswith("frame_") or (file, name) not in cache:
            with h5py.File(os.path.join(base, file), "r") as f:
                data = f[name][:]
            if file.startswith("frame_"):
                return data
            cache[(file, name)] = data
        return cache[(file, name)]

    out = []
    root = ET.parse(path).getroot()
    series = root.find("Domain/Grid")
    # a temporal collection of frames, or one grid (NAME.xdmf); a mesh's frame is a spatial
    # collection of its cells and its springs: the cells are drawn
    for frame in (series.findall("Grid") if series.get("CollectionType") == "Temporal" else [series]):
        g = frame if frame.get("GridType") == "Uniform" else frame.find("Grid")
        items = {tag: g.find(tag).find("DataItem").text for tag in ("Topology", "Geometry")}
        items["Attribute"] = next(a for a in g.findall("Attribute") if a.get("Name") == "fixed").find("DataItem").text
        out.append((float(frame.find("Time").get("Value")),
                    lambda items=items: {"connectivity": dataset(items["Topology"]), "points": dataset(items["Geometry"]), "fixed": dataset(items["Attribute"]).reshape(-1)}))
    return out


def read_series(path):
    """[(time, loader)] of a .pvd or .xdmf series; loader() returns the frame's grid"""
    if path.endswith(".xdmf"):
        return read_xdmf(path)
    return [(t, lambda f=f: read_vtu(f)) for t, f in read_pvd(path)]
