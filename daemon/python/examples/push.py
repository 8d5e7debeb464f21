"""Draw the running world from a device's picture of it, and push a body from outside.

Run beside a running hapticd (as a member of the hapticd group):

    python3 push.py [--bus ADDRESS] [--scene blocks] [--body block] [--speed 0.3] [--out push.svg]

It switches to the scene, draws a side view (x to the right, y up) of every solid where its
body is, gives the body an impulse along +x that sets it moving at ``--speed``, follows the
pictures for a second, and draws the body's path over the world, printing how far it went.
"""

from __future__ import annotations

import argparse
import math
import time
from typing import List, Sequence, Tuple

import hapticd
from hapticd.world import Frame, Solid

Point = Tuple[float, float]


def rotate(q: Sequence[float], v: Sequence[float]) -> Tuple[float, float, float]:
    """``v`` turned by the unit quaternion ``q`` (qw, qx, qy, qz)."""
    w, x, y, z = q
    vx, vy, vz = v
    # t = 2 q×v, v' = v + w t + q×t
    tx, ty, tz = 2 * (y * vz - z * vy), 2 * (z * vx - x * vz), 2 * (x * vy - y * vx)
    return (
        vx + w * tx + (y * tz - z * ty),
        vy + w * ty + (z * tx - x * tz),
        vz + w * tz + (x * ty - y * tx),
    )


def multiply(a: Sequence[float], b: Sequence[float]) -> Tuple[float, float, float, float]:
    """The quaternion product ``a b``."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


def place(pose: Sequence[float], point: Sequence[float]) -> Tuple[float, float, float]:
    """``point`` of a frame at ``pose`` (x, y, z, qw, qx, qy, qz), in the world."""
    turned = rotate(pose[3:], point)
    return (pose[0] + turned[0], pose[1] + turned[1], pose[2] + turned[2])


def hull(points: List[Point]) -> List[Point]:
    """The convex hull of ``points``, counter-clockwise (Andrew's monotone chain)."""
    points = sorted(set(points))
    if len(points) < 3:
        return points

    def cross(o: Point, a: Point, b: Point) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: List[Point] = []
    upper: List[Point] = []
    for p in points:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    for p in reversed(points):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return lower[:-1] + upper[:-1]


def outlines(solid: Solid, frame: Frame) -> List[List[Point]]:
    """The side view of ``solid`` as the frame places it: polygons in (x, y)."""
    body = frame.bodies[solid.body] if solid.body is not None else (0, 0, 0, 1, 0, 0, 0)
    pose = place(body, solid.offset[:3]) + multiply(body[3:], solid.offset[3:])
    a, b, c = solid.size
    ring = [(math.cos(t * math.pi / 8), math.sin(t * math.pi / 8)) for t in range(16)]
    if solid.shape == "triangles":
        shapes = [[t[0:3], t[3:6], t[6:9]] for t in solid.triangles]
    elif solid.shape == "box":
        shapes = [[(sx * a, sy * b, sz * c) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]]
    elif solid.shape == "sphere":
        shapes = [[(a * u, a * v, 0.0) for u, v in ring] + [(a * u, 0.0, a * v) for u, v in ring]]
    elif solid.shape == "cylinder":
        shapes = [[(a * u, h, a * v) for u, v in ring for h in (-b / 2, b / 2)]]
    elif solid.shape == "plane":
        shapes = [[(-a / 2, 0.0, 0.0), (a / 2, 0.0, 0.0), (a / 2, -0.005, 0.0), (-a / 2, -0.005, 0.0)]]
    else:
        shapes = []
    return [hull([place(pose, p)[:2] for p in shape]) for shape in shapes]


def svg(polygons: List[Tuple[List[Point], str]], path: List[Point], out: str) -> None:
    """Write the polygons (each with its fill) and the path as an SVG picture, 800 wide."""
    points = [p for polygon, _ in polygons for p in polygon] + path
    (x0, x1), (y0, y1) = [(min(v) - 0.01, max(v) + 0.01) for v in zip(*points)]
    scale = 800 / (x1 - x0)
    height = (y1 - y0) * scale

    def to(p: Point) -> str:
        return f"{(p[0] - x0) * scale:.1f},{(y1 - p[1]) * scale:.1f}"

    lines = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="800" height="{height:.0f}">',
        '<rect width="100%" height="100%" fill="white"/>',
    ]
    for polygon, fill in polygons:
        lines.append(
            f'<polygon points="{" ".join(map(to, polygon))}" fill="{fill}" '
            'fill-opacity="0.5" stroke="#333" stroke-width="0.5"/>'
        )
    lines.append(
        f'<polyline points="{" ".join(map(to, path))}" fill="none" stroke="#d62728" '
        'stroke-width="2"/>'
    )
    lines.append("</svg>")
    with open(out, "w") as f:
        f.write("\n".join(lines) + "\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bus", help="the bus address (default: the system bus)")
    parser.add_argument("--scene", default="blocks")
    parser.add_argument("--body", default="block")
    parser.add_argument("--speed", type=float, default=0.3, help="m/s the push gives it")
    parser.add_argument("--seconds", type=float, default=1.0, help="how long to follow it")
    parser.add_argument("--out", default="push.svg")
    args = parser.parse_args()

    daemon = hapticd.connect(args.bus)
    daemon.switch_scene(args.scene)
    ids = {b.name: b.id for b in daemon.bodies}
    body = ids[args.body]
    device = daemon.devices[0]
    world = device.open_world()
    # The solids of the scene switched to, once the frames count it.
    while True:
        _, frame = world.frame()
        switches, solids = device.solids()
        if switches == frame.scene_switches:
            break
        time.sleep(0.01)
    start = daemon.body(args.body)
    daemon.apply_impulse(args.body, (args.speed * start.mass, 0.0, 0.0))
    path: List[Point] = []
    while True:
        _, now = world.frame()
        path.append(tuple(now.bodies[body][:2]))
        if now.time - frame.time > args.seconds:
            break
        time.sleep(0.01)
    colours = {True: "#999999", False: "#1f77b4"}
    polygons = [
        (outline, "#ff7f0e" if s.body == body else colours[s.fixed])
        for s in solids
        for outline in outlines(s, frame)
    ]
    svg(polygons, path, args.out)
    end = daemon.body(args.body)
    travel = math.dist(start.position, end.position)
    print(f"{args.body}: pushed at {args.speed} m/s, went {travel * 1000:.1f} mm; drawn in {args.out}")
    world.close()
    daemon.close()


if __name__ == "__main__":
    main()
