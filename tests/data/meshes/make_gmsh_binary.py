#!/usr/bin/env python3
"""Writes the binary Gmsh files of the unit cube cut into 5 tets (cube5.msh): format 2.2 in this
machine's byte order and 4.1 in the other one (big-endian), with Gmsh's entity section. Both were
read by PETSc 3.18's Gmsh reader to the same 8 vertices, 5 tets and volume 1 when they were made.
Usage: make_gmsh_binary.py [DIR]"""
import os
import struct
import sys

NODES = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0), (0, 0, 1), (1, 0, 1), (0, 1, 1), (1, 1, 1)]
TETS = [(1, 2, 3, 5), (4, 3, 2, 8), (6, 2, 5, 8), (7, 5, 3, 8), (2, 3, 5, 8)]


def v22(e):
    b = b"$MeshFormat\n2.2 1 8\n" + struct.pack(e + "i", 1) + b"\n$EndMeshFormat\n$Nodes\n8\n"
    b += b"".join(struct.pack(e + "i3d", i + 1, *p) for i, p in enumerate(NODES))
    b += b"\n$EndNodes\n$Elements\n5\n" + struct.pack(e + "3i", 4, 5, 2)  # one header: 5 tets with 2 tags
    b += b"".join(struct.pack(e + "7i", i + 1, 1, 1, *t) for i, t in enumerate(TETS))
    return b + b"\n$EndElements\n"


def v41(e):
    b = b"$MeshFormat\n4.1 1 8\n" + struct.pack(e + "i", 1) + b"\n$EndMeshFormat\n"
    # one volume (tag 1, box 0..1, physical tag 1, no bounding surfaces)
    b += b"$Entities\n" + struct.pack(e + "4Q", 0, 0, 0, 1) + struct.pack(e + "i6dQiQ", 1, 0, 0, 0, 1, 1, 1, 1, 1, 0) + b"\n$EndEntities\n"
    b += b"$Nodes\n" + struct.pack(e + "4Q", 1, 8, 1, 8) + struct.pack(e + "3iQ", 3, 1, 0, 8) + struct.pack(e + "8Q", *range(1, 9))
    b += b"".join(struct.pack(e + "3d", *p) for p in NODES)
    b += b"\n$EndNodes\n$Elements\n" + struct.pack(e + "4Q", 1, 5, 1, 5) + struct.pack(e + "3iQ", 3, 1, 4, 5)
    b += b"".join(struct.pack(e + "5Q", i + 1, *t) for i, t in enumerate(TETS))
    return b + b"\n$EndElements\n"


if __name__ == "__main__":
    d = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(os.path.abspath(__file__))
    other = ">" if sys.byteorder == "little" else "<"
    open(os.path.join(d, "cube5_22bin.msh"), "wb").write(v22("="))
    open(os.path.join(d, "cube5_41bin_swapped.msh"), "wb").write(v41(other))
