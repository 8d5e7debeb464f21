#!/usr/bin/env python3
"""Write hapticd's example meshes into this directory, the first two as Wavefront OBJ and as
glTF 2.0 (one .gltf file, its buffer embedded as base64), the parts to put together as OBJ:

- bracket: a 50 x 50 x 6 mm plate with a round hole of 8 mm radius through it (a solid
  with a hole: non-convex, genus one);
- mug: a cup of 40 mm radius and 90 mm height with 4 mm walls and a 6 mm bottom, and a
  handle (half a torus) standing off its side, as two closed shells;
- peg and holed-block: a square peg 10 mm wide and 20 mm long (its origin at its middle),
  and a block 30 mm square and 25 mm tall (its origin at the middle of its top) with a
  square hole 10.2 mm wide and 15 mm deep;
- bolt: a shank of 7.7 mm radius and 20 mm (the bracket's hole less 0.3 mm), its tip
  chamfered, under a round head of 12 mm radius (its origin where the shank meets the head);
- gear: a spur gear of 12 trapezoidal teeth, 4 mm module (24 mm pitch radius), 8 mm thick
  (its origin at its middle): two of them mesh 48 mm apart.

Units are metres, y up, triangles counter-clockwise seen from outside. Run it again after a
change (python3 config/scenes/meshes/make-meshes.py); the test of the meshes checks the files
against the formulas written here (volumes of the polygons drawn).
"""

import base64
import json
import math
import os
import struct

SEGMENTS = 32


def bracket():
    """The plate: its outer square and its hole, each as SEGMENTS points at the same angles
    (the square's by casting each angle's ray to its edge, so that its corners are among
    them), joined on the top, the bottom, outside and in the hole."""
    half, radius, thickness = 0.025, 0.008, 0.006
    vertices, triangles = [], []
    rings = {}
    for name, y in (("bottom", 0.0), ("top", thickness)):
        for which in ("outer", "inner"):
            rings[(name, which)] = len(vertices)
            for k in range(SEGMENTS):
                a = 2 * math.pi * k / SEGMENTS
                c, s = math.cos(a), math.sin(a)
                r = half / max(abs(c), abs(s)) if which == "outer" else radius
                vertices.append((r * c, y, -r * s))

    def at(name, which, k):
        return rings[(name, which)] + k % SEGMENTS

    for k in range(SEGMENTS):
        quads = [
            # Top, seen from above: outer k, outer k+1, inner k+1, inner k.
            (at("top", "outer", k), at("top", "outer", k + 1),
             at("top", "inner", k + 1), at("top", "inner", k)),
            (at("bottom", "outer", k), at("bottom", "inner", k),
             at("bottom", "inner", k + 1), at("bottom", "outer", k + 1)),
            # The outer wall, and the hole's wall facing the hole's axis.
            (at("bottom", "outer", k), at("bottom", "outer", k + 1),
             at("top", "outer", k + 1), at("top", "outer", k)),
            (at("bottom", "inner", k), at("top", "inner", k),
             at("top", "inner", k + 1), at("bottom", "inner", k + 1)),
        ]
        for a, b, c, d in quads:
            triangles += [(a, b, c), (a, c, d)]
    return vertices, triangles


def revolve(profile, centre=(0.0, 0.0, 0.0)):
    """The closed surface turning `profile` (radius, height points, from the axis out and
    back to it, counter-clockwise in the radius-height plane) about the vertical."""
    vertices, triangles = [], []
    index = []
    for r, y in profile:
        if r == 0.0:
            index.append([len(vertices)] * SEGMENTS)
            vertices.append((centre[0], centre[1] + y, centre[2]))
        else:
            row = []
            for k in range(SEGMENTS):
                a = 2 * math.pi * k / SEGMENTS
                row.append(len(vertices))
                vertices.append((centre[0] + r * math.cos(a), centre[1] + y,
                                 centre[2] - r * math.sin(a)))
            index.append(row)
    for j in range(len(profile) - 1):
        lower, upper = index[j], index[j + 1]
        for k in range(SEGMENTS):
            a, b = lower[k], lower[(k + 1) % SEGMENTS]
            c, d = upper[(k + 1) % SEGMENTS], upper[k]
            for t in ((a, b, c), (a, c, d)):
                if len(set(t)) == 3:
                    triangles.append(t)
    return vertices, triangles


def tube(path, radius):
    """A tube of `radius` along the points of `path` (a polyline in the x-y plane), its ends
    capped: a closed shell."""
    vertices, triangles = [], []
    rings = []
    for i, (x, y) in enumerate(path):
        # Along the path, and the ring's two axes across it.
        px, py = path[max(i - 1, 0)]
        nx, ny = path[min(i + 1, len(path) - 1)]
        tx, ty = nx - px, ny - py
        length = math.hypot(tx, ty)
        tx, ty = tx / length, ty / length
        ring = []
        for k in range(SEGMENTS):
            a = 2 * math.pi * k / SEGMENTS
            u, w = math.cos(a) * radius, math.sin(a) * radius
            ring.append(len(vertices))
            vertices.append((x - ty * u, y + tx * u, w))
        rings.append(ring)
    for lower, upper in zip(rings, rings[1:]):
        for k in range(SEGMENTS):
            a, b = lower[k], lower[(k + 1) % SEGMENTS]
            c, d = upper[(k + 1) % SEGMENTS], upper[k]
            triangles += [(a, b, c), (a, c, d)]
    for ring, (x, y), outward in ((rings[0], path[0], False), (rings[-1], path[-1], True)):
        centre = len(vertices)
        vertices.append((x, y, 0.0))
        for k in range(SEGMENTS):
            a, b = ring[k], ring[(k + 1) % SEGMENTS]
            triangles.append((centre, a, b) if outward else (centre, b, a))
    return vertices, triangles


def mug():
    """The cup, revolved from its profile, and the handle: half a torus of 25 mm radius
    and 5 mm tube from the cup's side, its ends in the wall."""
    outer, wall, height, bottom = 0.040, 0.004, 0.090, 0.006
    cup = revolve([(0.0, 0.0), (outer, 0.0), (outer, height), (outer - wall, height),
                   (outer - wall, bottom), (0.0, bottom)])
    bend, tube_radius, middle = 0.025, 0.005, 0.045
    # A half circle on the +x side, its ends a millimetre inside the cup's wall (so that the
    # two shells meet without a gap; the wall is 4 mm thick there, the overlap a sliver).
    start = outer - 0.001
    path = []
    for i in range(17):
        a = math.pi / 2 - math.pi * i / 16
        path.append((start + bend * math.cos(a), middle + bend * math.sin(a)))
    handle = tube(path, tube_radius)
    offset = len(cup[0])
    return (cup[0] + handle[0],
            cup[1] + [tuple(k + offset for k in t) for t in handle[1]])


class Solid:
    """A closed surface being built of flat polygons, corners at the same place shared."""

    def __init__(self):
        self.vertices, self.triangles, self.index = [], [], {}

    def corner(self, v):
        key = tuple(round(c, 12) for c in v)
        if key not in self.index:
            self.index[key] = len(self.vertices)
            self.vertices.append(tuple(v))
        return self.index[key]

    def polygon(self, points):
        """A convex polygon, counter-clockwise seen from outside, as a fan."""
        k = [self.corner(p) for p in points]
        for i in range(1, len(k) - 1):
            self.triangles.append((k[0], k[i], k[i + 1]))

    def mesh(self):
        return self.vertices, self.triangles


def square(half, y):
    """A square's corners at height y, counter-clockwise seen from above."""
    return [(half, y, half), (-half, y, half), (-half, y, -half), (half, y, -half)]


def walls(solid, lower, upper, inward=False):
    """The quads between two rings (counter-clockwise seen from above), facing away from
    their axis, or towards it."""
    n = len(lower)
    for i in range(n):
        j = (i + 1) % n
        quad = [lower[i], lower[j], upper[j], upper[i]]
        solid.polygon(quad[::-1] if inward else quad)


def peg():
    half, length = 0.005, 0.020
    s = Solid()
    bottom, top = square(half, -length / 2), square(half, length / 2)
    # Counter-clockwise seen from above is clockwise seen from below.
    walls(s, bottom, top, inward=True)
    s.polygon(top[::-1])
    s.polygon(bottom)
    return s.mesh()


def holed_block():
    outer, hole, height, depth = 0.015, 0.0051, 0.025, 0.015
    s = Solid()
    walls(s, square(outer, -height), square(outer, 0.0), inward=True)
    s.polygon(square(outer, -height))
    # The top, a trapezoid per side between the outer square and the hole's.
    big, small = square(outer, 0.0), square(hole, 0.0)
    for i in range(4):
        j = (i + 1) % 4
        s.polygon([small[i], small[j], big[j], big[i]])
    walls(s, square(hole, -depth), small)
    s.polygon(square(hole, -depth)[::-1])
    return s.mesh()


def bolt():
    shank, length, chamfer, head, thickness = 0.0077, 0.020, 0.001, 0.012, 0.006
    return revolve([(0.0, -length), (shank - chamfer, -length), (shank, -length + chamfer),
                    (shank, 0.0), (head, 0.0), (head, thickness), (0.0, thickness)])


def gear():
    teeth, module, thickness = 12, 0.004, 0.008
    pitch = module * teeth / 2
    root, tip = pitch - 1.25 * module, pitch + module
    # Each tooth a trapezoid, 0.5 of the pitch angle wide at the root and 0.25 at the tip.
    step = 2 * math.pi / teeth
    outline = []
    for k in range(teeth):
        a = k * step
        for angle, r in ((a - 0.25 * step, root), (a - 0.125 * step, tip),
                         (a + 0.125 * step, tip), (a + 0.25 * step, root)):
            outline.append((r * math.cos(angle), r * math.sin(angle)))
    s = Solid()
    low = [(x, -thickness / 2, z) for x, z in outline]
    high = [(x, thickness / 2, z) for x, z in outline]
    walls(s, low, high, inward=True)
    # The faces, fans from the axis: the outline is star-shaped about it.
    n = len(outline)
    for i in range(n):
        j = (i + 1) % n
        s.polygon([(0.0, thickness / 2, 0.0), high[j], high[i]])
        s.polygon([(0.0, -thickness / 2, 0.0), low[i], low[j]])
    return s.mesh()


def write_obj(path, name, vertices, triangles):
    with open(path, "w") as f:
        f.write(f"# hapticd's example mesh '{name}', written by make-meshes.py; metres, y up\n")
        f.write(f"o {name}\n")
        for v in vertices:
            f.write("v %.9g %.9g %.9g\n" % v)
        for t in triangles:
            f.write("f %d %d %d\n" % tuple(k + 1 for k in t))


def write_gltf(path, name, vertices, triangles):
    positions = b"".join(struct.pack("<3f", *v) for v in vertices)
    indices = b"".join(struct.pack("<3I", *t) for t in triangles)
    low = [min(v[i] for v in vertices) for i in range(3)]
    high = [max(v[i] for v in vertices) for i in range(3)]
    data = base64.b64encode(positions + indices).decode()
    document = {
        "asset": {"version": "2.0", "generator": "hapticd make-meshes.py"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": name}],
        "meshes": [{"name": name, "primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{"byteLength": len(positions) + len(indices),
                     "uri": "data:application/octet-stream;base64," + data}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": len(positions), "target": 34962},
            {"buffer": 0, "byteOffset": len(positions), "byteLength": len(indices), "target": 34963},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": len(vertices), "type": "VEC3",
             "min": low, "max": high},
            {"bufferView": 1, "componentType": 5125, "count": 3 * len(triangles), "type": "SCALAR"},
        ],
    }
    with open(path, "w") as f:
        json.dump(document, f, indent=1)
        f.write("\n")


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    for name, (vertices, triangles) in (("bracket", bracket()), ("mug", mug())):
        write_obj(os.path.join(here, name + ".obj"), name, vertices, triangles)
        write_gltf(os.path.join(here, name + ".gltf"), name, vertices, triangles)
    for name, (vertices, triangles) in (("peg", peg()), ("holed-block", holed_block()),
                                        ("bolt", bolt()), ("gear", gear())):
        write_obj(os.path.join(here, name + ".obj"), name, vertices, triangles)


if __name__ == "__main__":
    main()
