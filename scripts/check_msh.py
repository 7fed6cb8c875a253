#!/usr/bin/env python3
"""Checks Gmsh .msh files (ASCII 2.2 or 4.1) written by scripts/make_scenes.sh.

Pure python (no numpy, no gmsh module). For each file it prints: format, nodes, tets (per
physical volume), boundary triangles of the tet mesh (faces used by one tet), interior faces
((4 tets - boundary) / 2), interior faces between two volume groups, triangles per physical surface, bounding box, inverted tets and the
worst / mean element quality as two measures computed here, both 1 for a regular tet:
  mean ratio   = 12 (3 V)^(2/3) / sum of the 6 squared edge lengths
  radius ratio = 3 r_in / R_circ
and the share of tets with mean ratio below 0.3.

  scripts/check_msh.py FILE.msh [--expect N] [--tol 0.05] [--json]

With --expect it exits 1 if the tet count is outside N (1 +- tol). Also checks that every
triangle of a physical surface group lies on the tet mesh's boundary or on an internal
interface (shared by exactly two tets of different volumes) and that every node is used.
"""
import argparse
import json
import math
import sys


def _lines(path):
    with open(path) as f:
        for line in f:
            yield line.strip()


def read_msh(path):
    """Returns dict: version, nodes {tag: (x,y,z)}, tets [(tags4, phys)], tris [(tags3, phys)],
    names {(dim, phys): name}."""
    it = _lines(path)
    version = None
    names = {}
    nodes = {}
    tets, tris = [], []
    entity_phys = {}  # (dim, entity tag) -> first physical tag (4.1)
    for line in it:
        if line == "$MeshFormat":
            parts = next(it).split()
            version = parts[0]
            if parts[1] != "0":
                raise SystemExit(f"{path}: binary .msh is not supported")
        elif line == "$PhysicalNames":
            for _ in range(int(next(it))):
                p = next(it).split(maxsplit=2)
                names[(int(p[0]), int(p[1]))] = p[2].strip('"')
        elif line == "$Entities" and version.startswith("4"):
            counts = [int(c) for c in next(it).split()]
            for dim, n in enumerate(counts):
                for _ in range(n):
                    p = next(it).split()
                    tag = int(p[0])
                    k = 4 if dim == 0 else 7
                    nphys = int(p[k])
                    phys = [int(x) for x in p[k + 1:k + 1 + nphys]]
                    entity_phys[(dim, tag)] = phys[0] if phys else 0
        elif line == "$Nodes":
            if version.startswith("2"):
                for _ in range(int(next(it))):
                    p = next(it).split()
                    nodes[int(p[0])] = tuple(float(x) for x in p[1:4])
            else:
                nblocks = int(next(it).split()[0])
                for _ in range(nblocks):
                    p = next(it).split()
                    n = int(p[3])
                    if p[2] != "0":
                        raise SystemExit(f"{path}: parametric nodes are not supported")
                    tags = [int(next(it)) for _ in range(n)]
                    for t in tags:
                        nodes[t] = tuple(float(x) for x in next(it).split()[:3])
        elif line == "$Elements":
            if version.startswith("2"):
                for _ in range(int(next(it))):
                    p = [int(x) for x in next(it).split()]
                    etype, ntags = p[1], p[2]
                    phys = p[3] if ntags > 0 else 0
                    vs = p[3 + ntags:]
                    if etype == 4:
                        tets.append((tuple(vs), phys))
                    elif etype == 2:
                        tris.append((tuple(vs), phys))
            else:
                nblocks = int(next(it).split()[0])
                for _ in range(nblocks):
                    edim, etag, etype, n = (int(x) for x in next(it).split())
                    phys = entity_phys.get((edim, etag), 0)
                    for _ in range(n):
                        vs = tuple(int(x) for x in next(it).split()[1:])
                        if etype == 4:
                            tets.append((vs, phys))
                        elif etype == 2:
                            tris.append((vs, phys))
    return dict(version=version, nodes=nodes, tets=tets, tris=tris, names=names)


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def norm(a):
    return math.sqrt(dot(a, a))


def tet_quality(p0, p1, p2, p3):
    """Returns (signed volume, mean ratio, radius ratio)."""
    a, b, c = sub(p1, p0), sub(p2, p0), sub(p3, p0)
    vol6 = dot(a, cross(b, c))
    vol = vol6 / 6.0
    edges = [a, b, c, sub(p2, p1), sub(p3, p1), sub(p3, p2)]
    l2 = sum(dot(e, e) for e in edges)
    mean_ratio = 12.0 * (3.0 * abs(vol)) ** (2.0 / 3.0) / l2 if l2 > 0 else 0.0
    # inradius r = 3V / total face area; circumradius from the standard formula
    area = 0.5 * (norm(cross(a, b)) + norm(cross(b, c)) + norm(cross(c, a)) +
                  norm(cross(sub(p2, p1), sub(p3, p1))))
    r_in = 3.0 * abs(vol) / area if area > 0 else 0.0
    la, lb, lc = dot(a, a), dot(b, b), dot(c, c)
    num = cross(b, c)
    num = tuple(la * num[i] for i in range(3))
    t = cross(c, a)
    num = tuple(num[i] + lb * t[i] for i in range(3))
    t = cross(a, b)
    num = tuple(num[i] + lc * t[i] for i in range(3))
    r_circ = norm(num) / (2.0 * abs(vol6)) if vol6 != 0 else float("inf")
    radius_ratio = 3.0 * r_in / r_circ if r_circ > 0 else 0.0
    return vol, mean_ratio, radius_ratio


def check(path):
    m = read_msh(path)
    nodes, tets, tris, names = m["nodes"], m["tets"], m["tris"], m["names"]
    face_count = {}
    face_owner_phys = {}
    used = set()
    worst_mr, worst_rr, sum_mr, n_bad, inverted, volume = 1.0, 1.0, 0.0, 0, 0, 0.0
    per_volume = {}
    worst_at = [0.0, 0.0, 0.0]
    for vs, phys in tets:
        used.update(vs)
        per_volume[phys] = per_volume.get(phys, 0) + 1
        vol, mr, rr = tet_quality(*(nodes[v] for v in vs))
        if vol <= 0:
            inverted += 1
        volume += abs(vol)
        if mr < worst_mr:
            worst_at = [sum(nodes[v][i] for v in vs) / 4 for i in range(3)]
        worst_mr, worst_rr = min(worst_mr, mr), min(worst_rr, rr)
        sum_mr += mr
        n_bad += mr < 0.3
        for f in ((vs[1], vs[2], vs[3]), (vs[0], vs[2], vs[3]), (vs[0], vs[1], vs[3]),
                  (vs[0], vs[1], vs[2])):
            key = tuple(sorted(f))
            face_count[key] = face_count.get(key, 0) + 1
            face_owner_phys.setdefault(key, set()).add(phys)
    boundary = sum(1 for c in face_count.values() if c == 1)
    nonmanifold = sum(1 for c in face_count.values() if c > 2)
    interface = sum(1 for k, c in face_count.items() if c == 2 and len(face_owner_phys[k]) == 2)
    interior = (4 * len(tets) - boundary) // 2
    per_surface = {}
    stray = 0
    for vs, phys in tris:
        per_surface[phys] = per_surface.get(phys, 0) + 1
        key = tuple(sorted(vs))
        c = face_count.get(key, 0)
        if not (c == 1 or (c == 2 and len(face_owner_phys[key]) == 2)):
            stray += 1
    lo = [min(nodes[v][i] for v in used) for i in range(3)] if used else [0, 0, 0]
    hi = [max(nodes[v][i] for v in used) for i in range(3)] if used else [0, 0, 0]
    return dict(
        file=path, format=m["version"], nodes=len(nodes), unused_nodes=len(nodes) - len(used),
        tets=len(tets), boundary_triangles=boundary, interior_faces=interior, interface_faces=interface,
        nonmanifold_faces=nonmanifold, inverted_tets=inverted, volume=volume,
        tets_per_volume={names.get((3, p), str(p)): n for p, n in sorted(per_volume.items())},
        triangles_per_surface={names.get((2, p), str(p)): n for p, n in sorted(per_surface.items())},
        group_triangles_not_on_boundary=stray,
        bbox_min=lo, bbox_max=hi,
        worst_mean_ratio=worst_mr, worst_tet_centroid=worst_at, worst_radius_ratio=worst_rr,
        mean_mean_ratio=sum_mr / max(1, len(tets)), share_mean_ratio_below_0_3=n_bad / max(1, len(tets)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="+")
    ap.add_argument("--expect", type=int, help="expected tet count (Table 1)")
    ap.add_argument("--tol", type=float, default=0.05)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    ok = True
    for path in args.files:
        r = check(path)
        bad = (r["inverted_tets"] or r["nonmanifold_faces"] or r["unused_nodes"] or
               r["group_triangles_not_on_boundary"])
        if args.expect:
            r["expected_tets"] = args.expect
            r["deviation"] = r["tets"] / args.expect - 1.0
            bad = bad or abs(r["deviation"]) > args.tol
        ok = ok and not bad
        if args.json:
            print(json.dumps(r))
            continue
        dev = f" ({100 * r['deviation']:+.2f}% vs {args.expect})" if args.expect else ""
        print(f"{path}: MSH {r['format']}, {r['nodes']} nodes, {r['tets']} tets{dev}")
        print(f"  tets per volume group: {r['tets_per_volume']}")
        print(f"  boundary triangles {r['boundary_triangles']}, interior faces {r['interior_faces']}, "
              f"interface faces between volume groups {r['interface_faces']}, triangles per surface group: {r['triangles_per_surface']}")
        print("  bbox [{:.2f} {:.2f} {:.2f}] .. [{:.2f} {:.2f} {:.2f}], volume {:.0f}".format(
            *r["bbox_min"], *r["bbox_max"], r["volume"]))
        print(f"  quality: worst mean ratio {r['worst_mean_ratio']:.3f} (mean {r['mean_mean_ratio']:.3f}, "
              f"{100 * r['share_mean_ratio_below_0_3']:.2f}% < 0.3), worst radius ratio "
              f"{r['worst_radius_ratio']:.3f}; worst tet at "
              + "[{:.1f} {:.1f} {:.1f}]".format(*r["worst_tet_centroid"]))
        if bad:
            print(f"  FAIL: inverted {r['inverted_tets']}, non-manifold faces {r['nonmanifold_faces']}, "
                  f"unused nodes {r['unused_nodes']}, group triangles off the boundary "
                  f"{r['group_triangles_not_on_boundary']}", file=sys.stderr)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
