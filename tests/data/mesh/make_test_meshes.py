#!/usr/bin/env python3
"""Writes the small test meshes in this folder (run: python3 make_test_meshes.py).

cube22.msh and cube41.msh hold the same mesh (a 10 x 10 x 10 cube cut into 5 positively oriented
tets, 2 + 2 triangles on its bottom (z = 0) and top (z = 10) faces) in MSH 2.2 and 4.1 ASCII, with
sparse, unordered node ids and elements of skipped types (a point, a line, a quad, a 2nd-order
triangle). cube.obj is the cube's surface as quads in every face-corner form, with negative indices;
cube_ascii.stl and cube_binary.stl its triangles as STL; cube_ascii.vtk, cube_binary.vtk and
cube51.vtk its tets as VTK legacy files, cube_hex.vtk one with a hexahedron; cube.mesh as Medit
(with the bottom and top triangles), cube.1.node / cube.1.ele / cube.1.face as TetGen writes them
(numbered from 1, region attributes, boundary markers) and cube0.node / cube0.ele from 0 (-z);
cube_ascii.vtu, cube_binary.vtu (zlib, as meshio writes it), cube_appended.vtu (raw, in two pieces)
and cube_appended64.vtu (base64, big-endian, zlib in blocks of 16 bytes) as VTK XML.
cube.ply, cube_le.ply and cube_be.ply are the cube's surface as PLY (ASCII quads with normals and
colours; binary little-endian triangles with an edge element after the faces; binary big-endian,
doubles and uint indices), cube_poly.vtk and cube_poly.vtp as VTK polydata (legacy ASCII with
vertices, lines, a triangle strip and point data; XML with zlib-compressed binary arrays).
cube_vtk9.vtu, cube_poly_vtk9.vtp and cube_poly_vtk9.vtk are not written here: VTK 9.1 wrote them
(python3-vtk9: cube_vtk9.vtu by vtkXMLUnstructuredGridWriter's defaults from cube_ascii.vtk, the
points' range computed first; the other two by vtkXMLPolyDataWriter's defaults and
vtkPolyDataWriter in binary from cube_poly.vtk), so that the readers meet what VTK itself writes
(appended base64, zlib, an InformationKey inside a DataArray; legacy 5.1 binary with METADATA).
"""
import os
import base64
import struct
import zlib

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

def write_medit():
    """The cube as a Medit mesh: comments, values over several lines, keywords read past (Edges,
    Corners, RequiredVertices), the tets' references 1 1 2 2 2, the bottom's triangles 3, the top's 1
    (the same number as a subdomain: its group is surface_1 apart from the tets' 1)."""
    out = ["# the cube of tests/data/mesh", "MeshVersionFormatted 2", "", "Dimension", "3", "",
           "Vertices", "8"] + [f"{pos(c)[0]:g} {pos(c)[1]:g} {pos(c)[2]:g} 0" for c in range(8)]
    out += ["Edges 1", "1 2 7", "# corners of the bottom", "Corners", "2", "1 2", "RequiredVertices 1 3"]
    out += ["Triangles", str(len(BOTTOM) + len(TOP))]
    out += [" ".join(str(c + 1) for c in t) + " 3" for t in BOTTOM] + [" ".join(str(c + 1) for c in t) + " 1" for t in TOP]
    out += ["Tetrahedra", str(len(TETS))]
    out += [" ".join(str(c + 1) for c in t) + f" {1 if i < 2 else 2}" for i, t in enumerate(TETS)]
    out += ["End"]
    open(os.path.join(HERE, "cube.mesh"), "w").write("\n".join(out) + "\n")

def write_tetgen():
    """The cube as TetGen writes it: cube.1.* numbered from 1, with a node attribute and markers,
    region attributes (1 1 2 2 2) and boundary markers on the faces; cube0.* numbered
    from 0 (-z), no attributes, and no .face."""
    head = "# Generated by tetgen -pqAf cube.poly"
    node = [head, "8  3  1  1"] + [f"   {c + 1}    {pos(c)[0]:g}  {pos(c)[1]:g}  {pos(c)[2]:g}    0.5    {1 if c in (0, 1) else 0}"
                                  for c in range(8)]
    ele = [head, "5  4  1"] + [f"    {i + 1}     " + "  ".join(str(c + 1) for c in t) + f"    {1 if i < 2 else 2}"
                               for i, t in enumerate(TETS)]
    faces = [(t, 3) for t in BOTTOM] + [(t, 1) for t in TOP]
    face = [head, f"{len(faces)}  1"] + [f"    {i + 1}    " + "  ".join(str(c + 1) for c in t) + f"  {m}  -1  {i + 1}"
                                        for i, (t, m) in enumerate(faces)]
    for name, lines in (("cube.1.node", node), ("cube.1.ele", ele), ("cube.1.face", face)):
        open(os.path.join(HERE, name), "w").write("\n".join(lines) + "\n")
    node0 = ["8 3 0 0"] + [f"{c} {pos(c)[0]:g} {pos(c)[1]:g} {pos(c)[2]:g}" for c in range(8)]
    ele0 = ["5 4 0"] + [f"{i} " + " ".join(str(c) for c in t) for i, t in enumerate(TETS)] + ["# Generated by tetgen -z"]
    open(os.path.join(HERE, "cube0.node"), "w").write("\n".join(node0) + "\n")
    open(os.path.join(HERE, "cube0.ele"), "w").write("\n".join(ele0) + "\n")

def write_vtu():
    """The cube's tets in VTK XML: every array format (ascii; binary inline; appended raw and base64),
    compressed or not, both byte orders and header sizes, a triangle among the cells, the regions as
    CellEntityIds (1 1 0 2 2 2 for the tets and the triangle)."""
    pts = [x for c in range(8) for x in pos(c)]
    cells = [list(t) for t in TETS[:2]] + [list(BOTTOM[0])] + [list(t) for t in TETS[2:]]
    types = [10, 10, 5, 10, 10, 10]
    conn = [x for c in cells for x in c]
    offs = []
    for c in cells:
        offs.append((offs[-1] if offs else 0) + len(c))
    region = [1, 1, 0, 2, 2, 2]
    arrays = [("Points", "", "Float64", 3, "d", pts), ("CellData", "CellEntityIds", "Int32", 1, "i", region),
              ("Cells", "connectivity", "Int64", 1, "q", conn), ("Cells", "offsets", "Int64", 1, "q", offs),
              ("Cells", "types", "UInt8", 1, "B", types)]

    def packed(fmt, vals, order):
        return struct.pack(order + str(len(vals)) + fmt, *vals)

    def blocks(raw, hfmt, order, size):
        """VTK's compressed form: header (count, block size, last size, compressed sizes), the blocks."""
        parts = [raw[i:i + size] for i in range(0, len(raw), size)] or [b""]
        z = [zlib.compress(p) for p in parts]
        last = len(parts[-1]) if len(parts[-1]) != size else 0
        head = struct.pack(order + str(3 + len(z)) + hfmt, len(z), size, last, *(len(b) for b in z))
        return head, b"".join(z)

    def document(mode, order="<", hfmt="I", compress=0, pieces=1):
        bo = "LittleEndian" if order == "<" else "BigEndian"
        ht = "UInt32" if hfmt == "I" else "UInt64"
        attrs = f'type="UnstructuredGrid" version="1.0" byte_order="{bo}" header_type="{ht}"'
        if compress:
            attrs += ' compressor="vtkZLibDataCompressor"'
        appended = b""
        def encode(fmt, vals):
            nonlocal appended
            raw = packed(fmt, vals, order)
            if compress:
                head, body = blocks(raw, hfmt, order, compress)
            else:
                head, body = struct.pack(order + hfmt, len(raw)), raw
            if mode == "binary":
                return "format=\"binary\"", (base64.b64encode(head) + base64.b64encode(body)).decode()
            off = len(appended)
            appended += (base64.b64encode(head) + base64.b64encode(body)) if mode == "appended64" else head + body
            return f'format="appended" offset="{off}"', None
        out = ['<?xml version="1.0"?>', "<!-- the cube of tests/data/mesh -->", f"<VTKFile {attrs}>", "  <UnstructuredGrid>"]
        # two pieces: the first two tets with all the points, then the rest (with the points again)
        splits = [(0, len(cells))] if pieces == 1 else [(0, 2), (2, len(cells))]
        for lo, hi in splits:
            sub = cells[lo:hi]
            so = []
            for c in sub:
                so.append((so[-1] if so else 0) + len(c))
            data = {"Points": pts, "CellEntityIds": region[lo:hi], "connectivity": [x for c in sub for x in c],
                    "offsets": so, "types": types[lo:hi]}
            out.append(f'    <Piece NumberOfPoints="8" NumberOfCells="{len(sub)}">')
            for section in ("PointData", "CellData", "Points", "Cells"):
                out.append(f"      <{section}>")
                for sec, name, vtype, comps, fmt, _ in arrays:
                    if sec != section:
                        continue
                    vals = data[name or "Points"]
                    nm = f' Name="{name}"' if name else ""
                    if mode == "ascii":
                        text = " ".join(f"{v:g}" if fmt == "d" else str(v) for v in vals)
                        out.append(f'        <DataArray type="{vtype}"{nm} NumberOfComponents="{comps}" format="ascii">')
                        out.append(f"          {text}")
                        out.append("        </DataArray>")
                    else:
                        fa, text = encode(fmt, vals)
                        if text is None:
                            out.append(f'        <DataArray type="{vtype}"{nm} NumberOfComponents="{comps}" {fa}/>')
                        else:
                            out.append(f'        <DataArray type="{vtype}"{nm} NumberOfComponents="{comps}" {fa}>{text}</DataArray>')
                out.append(f"      </{section}>")
            out.append("    </Piece>")
        out.append("  </UnstructuredGrid>")
        doc = ("\n".join(out) + "\n").encode()
        if appended:
            enc = "base64" if mode == "appended64" else "raw"
            doc += f'  <AppendedData encoding="{enc}">\n   _'.encode() + appended + b"\n  </AppendedData>\n"
        return doc + b"</VTKFile>\n"

    for name, doc in (("cube_ascii.vtu", document("ascii")),
                      ("cube_binary.vtu", document("binary", hfmt="Q", compress=32768)),
                      ("cube_appended.vtu", document("appended", pieces=2)),
                      ("cube_appended64.vtu", document("appended64", order=">", compress=16))):
        open(os.path.join(HERE, name), "wb").write(doc)

QUADS = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
TRIS = [t for q in QUADS for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3]))]

def write_ply():
    pts = [pos(c) for c in range(8)]
    head = ["ply", "format ascii 1.0", "comment the cube of tests/data/mesh", f"element vertex {len(pts)}",
            "property float x", "property float y", "property float z", "property float nx", "property float ny",
            "property float nz", "property uchar red", "property uchar green", "property uchar blue",
            f"element face {len(QUADS)}", "property list uchar int vertex_indices", "end_header"]
    body = [f"{p[0]:g} {p[1]:g} {p[2]:g} 0 0 1 255 128 0" for p in pts] + ["4 " + " ".join(map(str, q)) for q in QUADS]
    open(os.path.join(HERE, "cube.ply"), "w").write("\n".join(head + body) + "\n")
    head = ["ply", "format binary_little_endian 1.0", f"element vertex {len(pts)}", "property float32 x",
            "property float32 y", "property float32 z", f"element face {len(TRIS)}",
            "property list uint8 int32 vertex_indices", "property int32 flags", "element edge 1",
            "property int vertex1", "property int vertex2", "end_header"]
    data = b"".join(struct.pack("<3f", *p) for p in pts)
    data += b"".join(struct.pack("<B3ii", 3, *t, 7) for t in TRIS) + struct.pack("<2i", 0, 1)
    open(os.path.join(HERE, "cube_le.ply"), "wb").write(("\n".join(head) + "\n").encode() + data)
    head = ["ply", "format binary_big_endian 1.0", f"element vertex {len(pts)}", "property double x",
            "property double y", "property double z", f"element face {len(TRIS)}",
            "property list uchar uint vertex_index", "end_header"]
    data = b"".join(struct.pack(">3d", *p) for p in pts) + b"".join(struct.pack(">B3I", 3, *t) for t in TRIS)
    open(os.path.join(HERE, "cube_be.ply"), "wb").write(("\n".join(head) + "\n").encode() + data)

def write_polydata():
    """The cube's surface as VTK polydata: five quads as POLYGONS and the +x face as a triangle
    strip (1 3 5 7: triangles 1 3 5 and 5 3 7), with a vertex, a line and point normals read past."""
    pts = [pos(c) for c in range(8)]
    polys = QUADS[:5]
    out = ["# vtk DataFile Version 3.0", "the cube's surface", "ASCII", "DATASET POLYDATA",
           f"POINTS {len(pts)} float"] + [" ".join(f"{x:g}" for x in p) for p in pts]
    out += ["VERTICES 1 2", "1 0", "LINES 1 3", "2 0 7"]
    out += [f"POLYGONS {len(polys)} {5 * len(polys)}"] + ["4 " + " ".join(map(str, q)) for q in polys]
    out += ["TRIANGLE_STRIPS 1 5", "4 1 3 5 7"]
    out += ["POINT_DATA 8", "NORMALS n float"] + ["0 0 1"] * 8
    open(os.path.join(HERE, "cube_poly.vtk"), "w").write("\n".join(out) + "\n")
    def z(fmt, vals):
        raw = struct.pack("<" + str(len(vals)) + fmt, *vals)
        comp = zlib.compress(raw)
        head = struct.pack("<4I", 1, len(raw), len(raw), len(comp))
        return (base64.b64encode(head) + base64.b64encode(comp)).decode()
    conn = [x for q in polys for x in q]
    offs = [4 * (i + 1) for i in range(len(polys))]
    doc = ['<?xml version="1.0"?>',
           '<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" header_type="UInt32" compressor="vtkZLibDataCompressor">',
           "  <PolyData>",
           f'    <Piece NumberOfPoints="8" NumberOfVerts="0" NumberOfLines="1" NumberOfStrips="1" NumberOfPolys="{len(polys)}">',
           "      <Points>",
           f'        <DataArray type="Float32" Name="Points" NumberOfComponents="3" format="binary">{z("f", [x for p in pts for x in p])}</DataArray>',
           "      </Points>",
           "      <Lines>",
           f'        <DataArray type="Int64" Name="connectivity" format="binary">{z("q", [0, 7])}</DataArray>',
           f'        <DataArray type="Int64" Name="offsets" format="binary">{z("q", [2])}</DataArray>',
           "      </Lines>",
           "      <Strips>",
           f'        <DataArray type="Int64" Name="connectivity" format="binary">{z("q", [1, 3, 5, 7])}</DataArray>',
           f'        <DataArray type="Int64" Name="offsets" format="binary">{z("q", [4])}</DataArray>',
           "      </Strips>",
           "      <Polys>",
           f'        <DataArray type="Int64" Name="connectivity" format="binary">{z("q", conn)}</DataArray>',
           f'        <DataArray type="Int64" Name="offsets" format="binary">{z("q", offs)}</DataArray>',
           "      </Polys>",
           "    </Piece>", "  </PolyData>", "</VTKFile>"]
    open(os.path.join(HERE, "cube_poly.vtp"), "w").write("\n".join(doc) + "\n")

write22()
write41()
write_obj()
write_stl()
write_vtk()
write_medit()
write_tetgen()
write_vtu()
write_ply()
write_polydata()
