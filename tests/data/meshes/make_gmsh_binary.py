#!/usr/bin/env python3
"""Writes the binary Gmsh files of the unit cube cut into 5 tets (cube5.msh): format 2.2 in this
machine's byte order and 4.1 in the other one (big-endian), with Gmsh's entity section. Its 4.1
writer (v41_blocks) also serves tests/mesh_input.py. Both were
read by PETSc 3.18's Gmsh reader to the same 8 vertices, 5 tets and volume 1 when they were made.
Usage: make_gmsh_binary.py [DIR]"""
import os
import struct
import sys

NODES = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0), (0, 0, 1), (1, 0, 1), (0, 1, 1), (1, 1, 1)]
TETS = [(1, 2, 3, 5), (4, 3, 2, 8), (6, 2, 5, 8), (7, 5, 3, 8), (2, 3, 5, 8)]
PER = {1: 2, 2: 3, 4: 4, 15: 1}  # nodes of Gmsh's point, line, triangle and tet elements


def v22(e):
    b = b"$MeshFormat\n2.2 1 8\n" + struct.pack(e + "i", 1) + b"\n$EndMeshFormat\n$Nodes\n8\n"
    b += b"".join(struct.pack(e + "i3d", i + 1, *p) for i, p in enumerate(NODES))
    b += b"\n$EndNodes\n$Elements\n5\n" + struct.pack(e + "3i", 4, 5, 2)  # one header: 5 tets with 2 tags
    b += b"".join(struct.pack(e + "7i", i + 1, 1, 1, *t) for i, t in enumerate(TETS))
    return b + b"\n$EndElements\n"


def v41_blocks(node_blocks, element_blocks, e, size=8, entities=b""):
    """A binary 4.1 file in byte order e with size_t records of `size` bytes: node_blocks
    [(dim, entity, parametric, tags, coordinates)], element_blocks [(dim, entity, type, rows)]
    (rows: each element's tag and its nodes, one flat list); entities: a whole $Entities section"""
    z = "Q" if size == 8 else "I"

    def header(blocks, tags):  # blocks, records, smallest and largest tag
        return struct.pack(e + "4" + z, len(blocks), len(tags), min(tags), max(tags))

    b = b"$MeshFormat\n4.1 1 %d\n" % size + struct.pack(e + "i", 1) + b"\n$EndMeshFormat\n" + entities
    b += b"$Nodes\n" + header(node_blocks, [t for blk in node_blocks for t in blk[3]])
    for dim, entity, param, tags, coords in node_blocks:
        b += struct.pack(e + "3i" + z, dim, entity, param, len(tags)) + struct.pack(e + "%d%s" % (len(tags), z), *tags)
        b += struct.pack(e + "%dd" % len(coords), *map(float, coords))
    tags = [rows[k] for _, _, etype, rows in element_blocks for k in range(0, len(rows), 1 + PER[etype])]
    b += b"\n$EndNodes\n$Elements\n" + header(element_blocks, tags)
    for dim, entity, etype, rows in element_blocks:
        b += struct.pack(e + "3i" + z, dim, entity, etype, len(rows) // (1 + PER[etype])) + struct.pack(e + "%d%s" % (len(rows), z), *rows)
    return b + b"\n$EndElements\n"


def v41(e):
    # one volume (tag 1, box 0..1, physical tag 1, no bounding surfaces)
    entities = b"$Entities\n" + struct.pack(e + "4Q", 0, 0, 0, 1) + struct.pack(e + "i6dQiQ", 1, 0, 0, 0, 1, 1, 1, 1, 1, 0) + b"\n$EndEntities\n"
    return v41_blocks([(3, 1, 0, list(range(1, 9)), [c for p in NODES for c in p])],
                      [(3, 1, 4, [x for i, t in enumerate(TETS) for x in (i + 1,) + t])], e, entities=entities)


if __name__ == "__main__":
    d = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(os.path.abspath(__file__))
    other = ">" if sys.byteorder == "little" else "<"
    open(os.path.join(d, "cube5_22bin.msh"), "wb").write(v22("="))
    open(os.path.join(d, "cube5_41bin_swapped.msh"), "wb").write(v41(other))
