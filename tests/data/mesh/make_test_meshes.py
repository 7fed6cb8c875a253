#!/usr/bin/env python3
"""Writes the small test meshes in this folder (run: python3 make_test_meshes.py).

cube22.msh and cube41.msh hold the same mesh (a 10 x 10 x 10 cube cut into 5 positively oriented
tets, 2 + 2 triangles on its bottom (z = 0) and top (z = 10) faces) in MSH 2.2 and 4.1 ASCII, with
sparse, unordered node ids and elements of skipped types (a point, a line, a quad, a 2nd-order
triangle). cube.obj is the cube's surface as quads in every face-corner form, with negative indices;
cube_ascii.stl and cube_binary.stl its triangles as STL; cube_ascii.vtk, cube_binary.vtk and
cube51.vtk its tets as VTK legacy files, cube_hex.vtk one with a hexahedron.
"""
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
S = 10.0
# corner c = x + 2y + 4z of the cube, listed in the files in this (scrambled) order, with these ids
ORDER = [5, 0, 7, 2, 1, 6, 3, 4]
IDS = {5: 101, 0: 7, 7: 55, 2: 3, 1: 1000, 6: 42, 3: 9, 4: 250}
def pos(c):
    return (S * (c & 1), S * ((c >> 1) & 1), S * ((c >> 2) & 1))

def vol(t):
    a, b, c, d = (pos(i) for i in t)
    u = [b[k] - a[k] for k in range(3)]; v = [c[k] - a[k] for k in range(3)]; w = [d[k] - a[k] for k in range(3)]
    return (u[1] * v[2] - u[2] * v[1]) * w[0] + (u[2] * v[0] - u[0] * v[2]) * w[1] + (u[0] * v[1] - u[1] * v[0]) * w[2]

TETS = [(0, 1, 2, 4), (3, 2, 1, 7), (5, 4, 7, 1), (6, 7, 4, 2), (1, 2, 4, 7)]
TETS = [t if vol(t) > 0 else (t[0], t[2], t[1], t[3]) for t in TETS]
BOTTOM = [(0, 2, 1), (1, 2, 3)]   # z = 0, normal -z
TOP = [(4, 5, 6), (5, 7, 6)]      # z = 10, normal +z
ids = lambda cs: " ".join(str(IDS[c]) for c in cs)

def nodes22():
    return [f"{IDS[c]} {pos(c)[0]:g} {pos(c)[1]:g} {pos(c)[2]:g}" for c in ORDER]

def write22():
    els = ["1 15 2 5 1 " + ids([0]),
           "2 1 2 5 1 " + ids([0, 1]),
           "3 3 2 0 3 " + ids([0, 1, 5, 4]),
           "4 9 2 0 3 " + ids([0, 1, 5, 4, 0, 1]),   # 6-node triangle: skipped
           "5 2 2 2 1 " + ids(BOTTOM[0]), "6 2 2 2 1 " + ids(BOTTOM[1]),
           "7 2 2 3 2 " + ids(TOP[0]), "8 2 2 3 2 " + ids(TOP[1])]
    els += [f"{20 + i} 4 2 1 1 " + ids(t) for i, t in enumerate(TETS)]
    lines = ["$MeshFormat", "2.2 0 8", "$EndMeshFormat",
             "$PhysicalNames", "4", '1 5 "edge"', '2 2 "bottom"', '2 3 "top"', '3 1 "tissue"', "$EndPhysicalNames",
             "$Comments", "anything at all", "$EndComments",
             "$Nodes", str(len(ORDER))] + nodes22() + ["$EndNodes",
             "$Elements", str(len(els))] + els + ["$EndElements"]
    open(os.path.join(HERE, "cube22.msh"), "w").write("\n".join(lines) + "\n")

def write41():
    ent = ["$Entities", "1 1 3 1",
           "1 0 0 0 0",
           "1 0 0 0 10 0 0 1 5 2 1 -1",
           "1 0 0 0 10 10 0 1 2 0",
           "2 0 0 10 10 10 10 1 3 0",
           "3 0 0 0 0 10 10 0 0",
           "1 0 0 0 10 10 10 1 1 3 1 2 3",
           "$EndEntities"]
    first, second = ORDER[:5], ORDER[5:]
    nod = ["$Nodes", f"2 8 3 1000"]
    for block in (first, second):
        nod += [f"3 1 0 {len(block)}"] + [str(IDS[c]) for c in block]
        nod += [f"{pos(c)[0]:g} {pos(c)[1]:g} {pos(c)[2]:g}" for c in block]
    nod += ["$EndNodes"]
    el = ["$Elements", "7 13 1 24",
          "0 1 15 1", "1 " + ids([0]),
          "1 1 1 1", "2 " + ids([0, 1]),
          "2 3 3 1", "3 " + ids([0, 1, 5, 4]),
          "2 3 9 1", "4 " + ids([0, 1, 5, 4, 0, 1]),
          "2 1 2 2", "5 " + ids(BOTTOM[0]), "6 " + ids(BOTTOM[1]),
          "2 2 2 2", "7 " + ids(TOP[0]), "8 " + ids(TOP[1]),
          "3 1 4 5"] + [f"{20 + i} " + ids(t) for i, t in enumerate(TETS)] + ["$EndElements"]
    lines = ["$MeshFormat", "4.1 0 8", "$EndMeshFormat",
             "$PhysicalNames", "4", '1 5 "edge"', '2 2 "bottom"', '2 3 "top"', '3 1 "tissue"', "$EndPhysicalNames"]
    lines += ent + nod + el
    open(os.path.join(HERE, "cube41.msh"), "w").write("\n".join(lines) + "\n")

def write_obj():
    # the 6 faces as quads, counter-clockwise from outside; vertex numbers are 1-based corners + 1
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    out = ["# cube surface: quads in every face-corner form", "mtllib none.mtl", "o cube"]
    out += [f"v {pos(c)[0]:g} {pos(c)[1]:g} {pos(c)[2]:g}" for c in range(8)]
    out += ["vt 0 0", "vn 0 0 1", "s off"]
    forms = [lambda i: f"{i + 1}", lambda i: f"{i + 1}/1", lambda i: f"{i + 1}/1/1", lambda i: f"{i + 1}//1",
             lambda i: f"{i - 8}", lambda i: f"{i - 8}/1/1"]
    for q, form in zip(quads, forms):
        out.append("f " + " ".join(form(i) for i in q))
    open(os.path.join(HERE, "cube.obj"), "w").write("\r\n".join(out) + "\r\n")  # CRLF on purpose

def write_stl():
    # the OBJ's quads fan-triangulated as read_obj does (a b c d -> a b c, a c d), as ASCII and binary STL
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    tris = [t for q in quads for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3]))]
    out = ["solid cube"]
    for t in tris:
        out += ["  facet normal 0 0 0", "    outer loop"]
        out += [f"      vertex {pos(c)[0]:g} {pos(c)[1]:g} {pos(c)[2]:g}" for c in t]
        out += ["    endloop", "  endfacet"]
    out.append("endsolid cube")
    open(os.path.join(HERE, "cube_ascii.stl"), "w").write("\n".join(out) + "\n")
    data = b"binary STL of the cube (tests/data/mesh/cube.obj)".ljust(80, b" ") + struct.pack("<I", len(tris))
    for t in tris:
        data += struct.pack("<12fH", 0, 0, 0, *(x for c in t for x in pos(c)), 0)
    open(os.path.join(HERE, "cube_binary.stl"), "wb").write(data)

def write_vtk():
    """The cube's tets as VTK legacy files: ASCII 3.0 (ParaView's FIELD block before the points, cells
    of lower dimensions among the tets, cell data after them: a vector, the regions), BINARY 4.2
    (big-endian floats and ints; the regions as gmsh:physical in a FIELD, after another array), ASCII
    5.1 (OFFSETS and CONNECTIVITY arrays, no regions), and one with a hexahedron (refused)."""
    pts = [pos(c) for c in range(8)]
    others = [(1, [0]), (3, [0, 1]), (5, list(BOTTOM[0]))]  # a vertex, a line, a triangle: skipped
    cells = [(10, list(t)) for t in TETS[:2]] + others + [(10, list(t)) for t in TETS[2:]]
    head = ["# vtk DataFile Version 3.0", "the cube of tests/data/mesh", "ASCII", "DATASET UNSTRUCTURED_GRID",
            "FIELD FieldData 2", "TIME 1 1 double", "0", "CYCLE 1 1 int", "0"]
    out = head + [f"POINTS {len(pts)} double"] + [" ".join(f"{x:g}" for x in p) for p in pts]
    out += [f"CELLS {len(cells)} {sum(1 + len(c) for _, c in cells)}"] + [" ".join(map(str, [len(c)] + c)) for _, c in cells]
    out += [f"CELL_TYPES {len(cells)}"] + [str(t) for t, _ in cells]
    # the tets' regions: 1 for the first two, 2 for the others (0 for the cells of lower dimensions)
    region = [1, 1, 0, 0, 0, 2, 2, 2]
    out += [f"CELL_DATA {len(cells)}", "VECTORS v float"] + ["0 0 1"] * len(cells)
    out += ["SCALARS region int 1", "LOOKUP_TABLE default"] + [str(r) for r in region]
    open(os.path.join(HERE, "cube_ascii.vtk"), "w").write("\n".join(out) + "\n")
    tets = [list(t) for t in TETS]
    data = b"# vtk DataFile Version 4.2\nthe cube, binary\nBINARY\nDATASET UNSTRUCTURED_GRID\n"
    data += f"POINTS {len(pts)} float\n".encode() + struct.pack(f">{3 * len(pts)}f", *(x for p in pts for x in p)) + b"\n"
    data += f"CELLS {len(tets)} {5 * len(tets)}\n".encode() + struct.pack(f">{5 * len(tets)}i", *(x for t in tets for x in [4] + t))
    data += f"\nCELL_TYPES {len(tets)}\n".encode() + struct.pack(f">{len(tets)}i", *([10] * len(tets))) + b"\n"
    data += f"CELL_DATA {len(tets)}\nFIELD FieldData 2\nquality 1 {len(tets)} double\n".encode()
    data += struct.pack(f">{len(tets)}d", *([0.5] * len(tets))) + b"\n"
    data += f"gmsh:physical 1 {len(tets)} int\n".encode() + struct.pack(f">{len(tets)}i", 1, 1, 2, 2, 2) + b"\n"
    open(os.path.join(HERE, "cube_binary.vtk"), "wb").write(data)
    out = ["# vtk DataFile Version 5.1", "the cube, 5.1", "ASCII", "DATASET UNSTRUCTURED_GRID",
           f"POINTS {len(pts)} float"] + [" ".join(f"{x:g}" for x in p) for p in pts]
    out += ["METADATA", "INFORMATION 0", ""]
    out += [f"CELLS {len(tets) + 1} {4 * len(tets)}", "OFFSETS vtktypeint64", " ".join(str(4 * i) for i in range(len(tets) + 1)),
            "CONNECTIVITY vtktypeint64", " ".join(str(x) for t in tets for x in t)]
    out += [f"CELL_TYPES {len(tets)}"] + ["10"] * len(tets)
    open(os.path.join(HERE, "cube51.vtk"), "w").write("\n".join(out) + "\n")
    out = ["# vtk DataFile Version 2.0", "tets and a hexahedron", "ASCII", "DATASET UNSTRUCTURED_GRID",
           f"POINTS {len(pts)} float"] + [" ".join(f"{x:g}" for x in p) for p in pts]
    out += [f"CELLS 2 {5 + 9}", "4 " + " ".join(map(str, tets[0])), "8 0 1 3 2 4 5 7 6", "CELL_TYPES 2", "10", "12"]
    open(os.path.join(HERE, "cube_hex.vtk"), "w").write("\n".join(out) + "\n")

write22()
write41()
write_obj()
write_stl()
write_vtk()
