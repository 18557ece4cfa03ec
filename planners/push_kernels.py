"""The compiled inner loops of planar pushing (numba): one sample at a time, no temporaries.

Why compiled: a nu_o evolution or a capture-region build solves the contacts of a few dozen
samples per 1 mm step for hundreds of steps; as batched numpy each step cost about 2 ms of call
overhead on arrays of a few rows (66% of a Figs. 3-5 plan). Here a step costs microseconds.
`planners.pushing` (the contact mechanics) and `planners.push_simulation` (contact detection and
the simulation) wrap these kernels in their batched APIs, documented there.

Every constant the kernels bake in lives in this file: numba's on-disk cache (``cache=True``)
is invalidated by a change of this file, never by a change of a module it imports.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

MAX_CONTACTS = 4
"""Contacts kept per sample and step (the nearest ones); a box on a flat face needs two."""
MAX_SPEED_RATIO = 10.0
"""The fastest an object point may move, in pusher speeds, before a contact solution is
taken for a degenerate one (`contact_twists`)."""
SEPARATE, STICK, SLIDE = 0, 1, 2
"""Modes of a point contact."""


@njit(cache=True)
def one_contact(
    rx: float, ry: float, nx: float, ny: float, vx: float, vy: float, mu: float, c: float
) -> tuple[float, float, float, int]:
    """`single_contact_twist` of one sample: (twist, mode)."""
    a3 = 1.0 / (c * c)
    tx, ty = -ny, nx
    # A J^T = [[1, 0], [0, 1], [-y a3, x a3]]; B = J A J^T (symmetric 2x2); f* = B^-1 v_p.
    b00, b01, b11 = 1.0 + ry * ry * a3, -rx * ry * a3, 1.0 + rx * rx * a3
    det = b00 * b11 - b01 * b01
    fx, fy = (b11 * vx - b01 * vy) / det, (b00 * vy - b01 * vx) / det
    vpn = vx * nx + vy * ny
    if vpn <= 0.0:
        return 0.0, 0.0, 0.0, SEPARATE
    fn, ft = fx * nx + fy * ny, fx * tx + fy * ty
    if abs(ft) <= mu * fn:
        return fx, fy, (-ry * fx + rx * fy) * a3, STICK
    s = 1.0 if ft > 0.0 else (-1.0 if ft < 0.0 else 0.0)
    ex, ey = nx + s * mu * tx, ny + s * mu * ty
    wz = (-ry * ex + rx * ey) * a3  # A J^T e
    # n . J v_b, with J v_b = (ex - y wz, ey + x wz)
    scale = vpn / (nx * (ex - ry * wz) + ny * (ey + rx * wz))
    return scale * ex, scale * ey, scale * wz, SLIDE


@njit(cache=True)
def one_contact_batch(
    r: np.ndarray, n: np.ndarray, vp: np.ndarray, mu: np.ndarray, c: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    twist = np.empty((len(r), 3))
    mode = np.empty(len(r), dtype=np.int64)
    for i in range(len(r)):
        vx, vy, w, k = one_contact(
            r[i, 0], r[i, 1], n[i, 0], n[i, 1], vp[i, 0], vp[i, 1], mu[i], c[i]
        )
        twist[i, 0], twist[i, 1], twist[i, 2], mode[i] = vx, vy, w, k
    return twist, mode


@njit(cache=True)
def lu_solve(k: np.ndarray, h: np.ndarray, f: np.ndarray, work: np.ndarray) -> bool:
    """k f = h by Gaussian elimination with partial pivoting into ``f``; False, with ``f``
    untouched, when a pivot is exactly zero (k singular: the pseudo-inverse decides then)."""
    size = len(h)
    work[:, :size] = k
    work[:, size] = h
    for col in range(size):
        if not _eliminate(work, col):
            return False
    for i in range(size - 1, -1, -1):
        acc = work[i, size]
        for j in range(i + 1, size):
            acc -= work[i, j] * f[j]
        f[i] = acc / work[i, i]
    return True


@njit(cache=True)
def _eliminate(work: np.ndarray, col: int) -> bool:
    """One column of Gaussian elimination on the augmented ``work``, pivoting on the largest
    entry; False if it is zero."""
    size = len(work)
    pivot = col
    for row in range(col + 1, size):
        if abs(work[row, col]) > abs(work[pivot, col]):
            pivot = row
    if work[pivot, col] == 0.0:
        return False
    for j in range(size + 1):
        work[col, j], work[pivot, j] = work[pivot, j], work[col, j]
    for row in range(col + 1, size):
        factor = work[row, col] / work[col, col]
        for j in range(col + 1, size + 1):
            work[row, j] -= factor * work[col, j]
    return True


@njit(cache=True)
def pattern_system(
    g: np.ndarray, b: np.ndarray, mu: float, pattern: np.ndarray, k: np.ndarray, h: np.ndarray
) -> None:
    """The linear system k f = h (into ``k``, ``h``) that one complementarity pattern (a mode
    per contact, `_mode_patterns`) makes of the LCP, with a 1e-10 ridge."""
    k[:] = 0.0
    h[:] = 0.0
    for i in range(len(pattern)):
        rn, rt, mode = 2 * i, 2 * i + 1, pattern[i]
        if mode == 0:  # separate: f_n = f_t = 0
            k[rn, rn] = k[rt, rt] = 1.0
            continue
        k[rn] = g[rn]  # touching: zero normal velocity
        h[rn] = b[rn]
        if mode == 1:  # stick: zero tangential velocity
            k[rt] = g[rt]
            h[rt] = b[rt]
        else:  # slide: f_t on the cone's edge
            k[rt, rt] = 1.0
            k[rt, rn] = (1.0 if mode == 2 else -1.0) * mu
    for i in range(len(h)):
        k[i, i] += 1e-10


@njit(cache=True)
def complementary(f: np.ndarray, u: np.ndarray, tol: float, mu: float, pattern: np.ndarray) -> bool:
    """Whether forces ``f`` and relative velocities ``u`` (normal, tangent per contact) meet
    the pattern's conditions within ``tol``: a separating contact does not approach, a
    touching one pushes, a sticking one stays in the friction cone, a sliding one slides
    along its force."""
    for i in range(len(pattern)):
        mode = pattern[i]
        fn, ft, un, ut = f[2 * i], f[2 * i + 1], u[2 * i], u[2 * i + 1]
        if mode == 0:
            ok = un >= -tol
        elif mode == 1:
            ok = fn >= -tol and abs(ft) <= mu * fn + tol
        else:
            ok = fn >= -tol and (1.0 if mode == 2 else -1.0) * ut >= -tol
        if not ok:
            return False
    return True


@njit(cache=True)
def lcp_solve(
    r: np.ndarray,
    n: np.ndarray,
    vp: np.ndarray,
    mu: float,
    c: float,
    patterns: np.ndarray,
    twist: np.ndarray,
    forces: np.ndarray,
) -> bool:
    """One sample of `solve_contacts` (m = len(r) contacts): the twist and forces of the first
    of ``patterns`` (simplest first) that satisfies the LCP conditions, written into ``twist``
    (3,) and ``forces`` (2m,); False when none does (jammed)."""
    m = len(r)
    size = 2 * m
    w = np.empty((3, size))  # W = [J^T n, J^T t] per contact
    b = np.empty(size)  # (n . vp, t . vp) per contact
    for i in range(m):
        nx, ny, tx, ty = n[i, 0], n[i, 1], -n[i, 1], n[i, 0]
        x, y = r[i, 0], r[i, 1]
        w[0, 2 * i], w[1, 2 * i], w[2, 2 * i] = nx, ny, -y * nx + x * ny
        w[0, 2 * i + 1], w[1, 2 * i + 1], w[2, 2 * i + 1] = tx, ty, -y * tx + x * ty
        b[2 * i] = vp[i, 0] * nx + vp[i, 1] * ny
        b[2 * i + 1] = vp[i, 0] * tx + vp[i, 1] * ty
    aw = w.copy()
    aw[2] /= c * c
    g = w.T @ aw
    b_max = np.abs(b).max()
    k, h, f, u = np.empty((size, size)), np.empty(size), np.empty(size), np.empty(size)
    work = np.empty((size, size + 1))
    for p in range(len(patterns)):
        pattern_system(g, b, mu, patterns[p], k, h)
        if not lu_solve(k, h, f, work):
            f[:] = np.linalg.pinv(k) @ h
        f_max = 0.0
        for i in range(size):  # u = g f - b and the largest force, without temporaries
            acc, f_max = 0.0, max(f_max, abs(f[i]))
            for j in range(size):
                acc += g[i, j] * f[j]
            u[i] = acc - b[i]
        if complementary(f, u, 1e-7 * (1.0 + f_max + b_max), mu, patterns[p]):
            twist[:] = aw @ f
            forces[:] = f
            return True
    twist[:], forces[:] = 0.0, 0.0
    return False


@njit(cache=True)
def lcp_batch(
    r: np.ndarray,
    n: np.ndarray,
    vp: np.ndarray,
    mu: np.ndarray,
    c: np.ndarray,
    patterns: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    big_n, m = r.shape[0], r.shape[1]
    twist = np.empty((big_n, 3))
    forces = np.empty((big_n, 2 * m))
    jammed = np.empty(big_n, dtype=np.bool_)
    for i in range(big_n):
        jammed[i] = not lcp_solve(r[i], n[i], vp[i], mu[i], c[i], patterns, twist[i], forces[i])
    return twist, forces, jammed


@njit(cache=True)
def point_polygon(
    px: float, py: float, verts: np.ndarray, k: int
) -> tuple[float, float, float, float, float]:
    """Signed distance of a point to a convex polygon (its first ``k`` vertices, negative
    inside), the outward unit normal at the nearest boundary point, and that point."""
    best_out, best_side = np.inf, -np.inf
    out_x = out_y = in_x = in_y = 0.0
    for j in range(k):
        x0, y0 = verts[j, 0], verts[j, 1]
        ex, ey = verts[(j + 1) % k, 0] - x0, verts[(j + 1) % k, 1] - y0
        e2 = ex * ex + ey * ey
        length = math.sqrt(e2)
        rx, ry = px - x0, py - y0
        side = rx * (ey / length) + ry * (-ex / length)
        t = min(max((rx * ex + ry * ey) / e2, 0.0), 1.0)
        dx, dy = px - (x0 + t * ex), py - (y0 + t * ey)
        dist = math.sqrt(dx * dx + dy * dy)
        if dist < best_out:
            best_out, out_x, out_y = dist, dx, dy
        if side > best_side:
            best_side, in_x, in_y = side, ey / length, -ex / length
    if best_side <= 0.0:
        signed, nx, ny = best_side, in_x, in_y
    else:
        scale = max(best_out, 1e-300)
        signed, nx, ny = best_out, out_x / scale, out_y / scale
    return signed, nx, ny, px - signed * nx, py - signed * ny


@njit(cache=True)
def clearance(
    centers: np.ndarray,
    polygons: np.ndarray,
    counts: np.ndarray,
    disc_centres: np.ndarray,
    disc_radii: np.ndarray,
) -> np.ndarray:
    out = np.full(len(centers), np.inf)
    for i in range(len(centers)):
        px, py = centers[i, 0], centers[i, 1]
        for q in range(len(polygons)):
            out[i] = min(out[i], point_polygon(px, py, polygons[q], counts[q])[0])
        for q in range(len(disc_radii)):
            dx, dy = px - disc_centres[q, 0], py - disc_centres[q, 1]
            d = math.sqrt(dx * dx + dy * dy) - disc_radii[q]
            out[i] = min(out[i], d)
    return out


@njit(cache=True)
def candidate_count(box: bool, counts: np.ndarray, discs: int) -> int:
    return int((4 + counts).sum()) + discs if box else len(counts) + discs


@njit(cache=True)
def candidates(
    box: bool,
    radius: float,
    hx: float,
    hy: float,
    pose: np.ndarray,
    polygons: np.ndarray,
    counts: np.ndarray,
    disc_centres: np.ndarray,
    disc_radii: np.ndarray,
    gaps: np.ndarray,
    points: np.ndarray,
    normals: np.ndarray,
) -> None:
    """`push_simulation.contacts` of one pose (a box of half extents hx, hy or a disc of
    ``radius``), written into gaps (C,), points (C, 2) and normals (C, 2)."""
    args = (polygons, counts, disc_centres, disc_radii, gaps, points, normals)
    if box:
        _box_candidates(hx, hy, pose, *args)
    else:
        _disc_candidates(radius, pose, *args)


@njit(cache=True)
def _disc_candidates(
    radius: float,
    pose: np.ndarray,
    polygons: np.ndarray,
    counts: np.ndarray,
    disc_centres: np.ndarray,
    disc_radii: np.ndarray,
    gaps: np.ndarray,
    points: np.ndarray,
    normals: np.ndarray,
) -> None:
    """A disc's candidates: the nearest point of each polygon, then of each disc."""
    x, y = pose[0], pose[1]
    for q in range(len(polygons)):
        d, nx, ny, _, _ = point_polygon(x, y, polygons[q], counts[q])
        gaps[q], normals[q, 0], normals[q, 1] = d - radius, nx, ny
        points[q, 0], points[q, 1] = x - radius * nx, y - radius * ny
    for q in range(len(disc_radii)):
        n = len(polygons) + q
        dx, dy = x - disc_centres[q, 0], y - disc_centres[q, 1]
        dist = math.sqrt(dx * dx + dy * dy)
        nx, ny = dx / max(dist, 1e-300), dy / max(dist, 1e-300)
        gaps[n], normals[n, 0], normals[n, 1] = dist - disc_radii[q] - radius, nx, ny
        points[n, 0], points[n, 1] = x - radius * nx, y - radius * ny


@njit(cache=True)
def box_corners(hx: float, hy: float, pose: np.ndarray, corners: np.ndarray) -> None:
    """The corners (4, 2), counter-clockwise, of a box of half extents hx, hy at ``pose``."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    for i, (lx, ly) in enumerate(((hx, -hy), (hx, hy), (-hx, hy), (-hx, -hy))):
        corners[i, 0], corners[i, 1] = pose[0] + (c * lx - s * ly), pose[1] + (s * lx + c * ly)


@njit(cache=True)
def _box_candidates(
    hx: float,
    hy: float,
    pose: np.ndarray,
    polygons: np.ndarray,
    counts: np.ndarray,
    disc_centres: np.ndarray,
    disc_radii: np.ndarray,
    gaps: np.ndarray,
    points: np.ndarray,
    normals: np.ndarray,
) -> None:
    """A box's candidates, per run of polygons with one vertex count: its corners against
    each polygon, then the polygons' vertices against it; then the discs against it."""
    corners = np.empty((4, 2))
    box_corners(hx, hy, pose, corners)
    n = start = 0
    while start < len(polygons):
        end = start + 1
        while end < len(polygons) and counts[end] == counts[start]:
            end += 1
        for i in range(4 * (end - start)):
            corner, q = i // (end - start), start + i % (end - start)
            gaps[n], normals[n, 0], normals[n, 1], _, _ = point_polygon(
                corners[corner, 0], corners[corner, 1], polygons[q], counts[q]
            )
            points[n] = corners[corner]
            n += 1
        for q in range(start, end):
            for j in range(counts[q]):
                d, nx, ny, points[n, 0], points[n, 1] = point_polygon(
                    polygons[q, j, 0], polygons[q, j, 1], corners, 4
                )
                gaps[n], normals[n, 0], normals[n, 1] = d, -nx, -ny
                n += 1
        start = end
    for q in range(len(disc_radii)):
        d, nx, ny, points[n, 0], points[n, 1] = point_polygon(
            disc_centres[q, 0], disc_centres[q, 1], corners, 4
        )
        gaps[n], normals[n, 0], normals[n, 1] = d - disc_radii[q], -nx, -ny
        n += 1


@njit(cache=True)
def _nearest(gaps: np.ndarray, nearest: np.ndarray) -> int:
    """The indices of the ``len(nearest)`` smallest ``gaps``, smallest first and ties to the
    first (a stable sort's first entries), written into ``nearest``; how many there are."""
    kept = 0
    for i in range(len(gaps)):
        g = gaps[i]
        if kept == len(nearest) and not g < gaps[nearest[kept - 1]]:
            continue
        j = min(kept, len(nearest) - 1)  # the slot it takes, then moved up past larger gaps
        while j > 0 and g < gaps[nearest[j - 1]]:
            nearest[j] = nearest[j - 1]
            j -= 1
        nearest[j] = i
        kept = min(kept + 1, len(nearest))
    return kept


@njit(cache=True)
def contact_twists(
    box: bool,
    radius: float,
    hx: float,
    hy: float,
    bounding_radius: float,
    poses: np.ndarray,
    mu: np.ndarray,
    c: np.ndarray,
    move: np.ndarray,
    margin: float,
    step: float,
    polygons: np.ndarray,
    counts: np.ndarray,
    disc_centres: np.ndarray,
    disc_radii: np.ndarray,
    size: int,
    patterns: tuple[np.ndarray, ...],
) -> tuple[np.ndarray, np.ndarray]:
    """`_contact_twist`, one sample at a time: the MAX_CONTACTS nearest candidates (ties to
    the first), those closer than ``margin`` solved as one contact or as the contact LCP."""
    gaps, points, normals = np.empty(size), np.empty((size, 2)), np.empty((size, 2))
    r, n, vp = np.empty((MAX_CONTACTS, 2)), np.empty((MAX_CONTACTS, 2)), np.empty((MAX_CONTACTS, 2))
    forces = np.empty(2 * MAX_CONTACTS)
    nearest = np.empty(MAX_CONTACTS, dtype=np.int64)
    twist = np.zeros((len(poses), 3))
    touching = np.zeros(len(poses), dtype=np.bool_)
    rate = margin / step
    for s in range(len(poses)):
        x, y, theta = poses[s, 0], poses[s, 1], poses[s, 2]
        candidates(
            box,
            radius,
            hx,
            hy,
            poses[s],
            polygons,
            counts,
            disc_centres,
            disc_radii,
            gaps,
            points,
            normals,
        )
        kept = _nearest(gaps, nearest)
        cos, sin = math.cos(theta), math.sin(theta)
        m = 0
        for q in range(kept):
            o = nearest[q]
            m += gaps[o] < margin
            # Into the object frame: r = R^T (point - centre), n = R^T normal; the pusher's +x
            # there is R^T (1, 0) = (cos, -sin).
            dx, dy = points[o, 0] - x, points[o, 1] - y
            r[q, 0], r[q, 1] = cos * dx + sin * dy, -sin * dx + cos * dy
            nx, ny = normals[o, 0], normals[o, 1]
            n[q, 0], n[q, 1] = cos * nx + sin * ny, -sin * nx + cos * ny
            # A step cut short by a checkpoint may be tiny: the gap still closes at most at the
            # rate a full step closes it (margin / step), never at gap / 1e-15, which flings
            # the object.
            closing = min(max(gaps[o] / move[s], -rate), rate)
            vp[q, 0], vp[q, 1] = cos - closing * n[q, 0], -sin - closing * n[q, 1]
        touching[s] = m > 0
        if m == 1:
            vx, vy, w, _ = one_contact(
                r[0, 0], r[0, 1], n[0, 0], n[0, 1], vp[0, 0], vp[0, 1], mu[s], c[s]
            )
            twist[s, 0], twist[s, 1], twist[s, 2] = vx, vy, w
        elif m > 1:
            solved = lcp_solve(
                r[:m], n[:m], vp[:m], mu[s], c[s], patterns[m], twist[s], forces[: 2 * m]
            )
            # A nearly degenerate contact set (two normals at one corner, high friction) can
            # give a solution whose points outrun the pusher many times over: no quasi-static
            # push does that, so such a sample is held like a jammed one.
            speed = math.hypot(twist[s, 0], twist[s, 1]) + bounding_radius * abs(twist[s, 2])
            pusher_speed = np.abs(vp[:m]).max()
            if not solved or speed > MAX_SPEED_RATIO * max(pusher_speed, 1.0):
                twist[s, 0], twist[s, 1], twist[s, 2] = cos, -sin, 0.0
    return twist, touching


@njit(cache=True)
def deepest_side(px: float, py: float, verts: np.ndarray, k: int) -> float:
    """How far a point lies inside a convex polygon (its first ``k`` vertices) as the largest
    signed distance to its edges' lines: negative inside, positive outside (not a distance
    there); enough to tell whether a point is inside by more than a depth."""
    best = -np.inf
    for j in range(k):
        x0, y0 = verts[j, 0], verts[j, 1]
        ex, ey = verts[(j + 1) % k, 0] - x0, verts[(j + 1) % k, 1] - y0
        best = max(best, ((px - x0) * ey - (py - y0) * ex) / math.sqrt(ex * ex + ey * ey))
    return best


@njit(cache=True)
def first_overlapped(
    shapes: np.ndarray,
    local: np.ndarray,
    ends: np.ndarray,
    shifts: np.ndarray,
    depth: float,
    bounds: tuple[float, float, float, float],
    polygons: np.ndarray,
    counts: np.ndarray,
    disc_centres: np.ndarray,
    disc_radii: np.ndarray,
) -> np.ndarray:
    """`push_simulation.first_overlapped`. A pose whose bounding circle misses the pusher's
    ``bounds`` is not tested, nor a polygon whose bounding circle the object's misses by
    ``depth``; a box overlapping a polygon that deep has one of its corners, or one of the
    polygon's vertices, inside the other by more than ``depth``."""
    centres, radii = np.zeros((len(polygons), 2)), np.zeros(len(polygons))
    for q in range(len(polygons)):  # the polygons' bounding circles
        k = counts[q]
        centres[q] = polygons[q, :k].sum(axis=0) / k
        for j in range(k):
            dx, dy = polygons[q, j, 0] - centres[q, 0], polygons[q, j, 1] - centres[q, 1]
            radii[q] = max(radii[q], math.sqrt(dx * dx + dy * dy))
    x0, x1, y0, y1 = bounds
    first = np.full(len(shifts), -1)
    corners = np.empty((4, 2))
    pose = np.empty(3)
    for m in range(len(shifts)):
        for o in range(len(shapes)):
            box, radius, r = shapes[o, 0] > 0.0, shapes[o, 1], shapes[o, 4]
            hx, hy = shapes[o, 2], shapes[o, 3]
            for i in range(ends[o], ends[o + 1]):
                x, y = local[i, 0] - shifts[m, 0], local[i, 1] - shifts[m, 1]
                if not (x + r > x0 and x - r < x1 and y + r > y0 and y - r < y1):
                    continue
                if box:
                    pose[0], pose[1], pose[2] = x, y, local[i, 2]
                    box_corners(hx, hy, pose, corners)
                if _polygons_overlap(
                    box, x, y, corners, r - depth, depth, polygons, counts, centres, radii
                ) or _discs_overlap(box, radius, x, y, corners, depth, disc_centres, disc_radii):
                    first[m] = o
                    break
            if first[m] >= 0:
                break
    return first


@njit(cache=True)
def _polygons_overlap(
    box: bool,
    x: float,
    y: float,
    corners: np.ndarray,
    reach: float,
    depth: float,
    polygons: np.ndarray,
    counts: np.ndarray,
    centres: np.ndarray,
    radii: np.ndarray,
) -> bool:
    """Whether the object (a box with ``corners``, or a disc of radius ``reach`` + ``depth``
    at x, y) overlaps one of the polygons by more than ``depth``."""
    for q in range(len(polygons)):
        dx, dy = x - centres[q, 0], y - centres[q, 1]
        if math.sqrt(dx * dx + dy * dy) - radii[q] > reach:
            continue
        if box and _box_in_polygon(corners, polygons[q], counts[q], depth):
            return True
        if not box and point_polygon(x, y, polygons[q], counts[q])[0] < reach:
            return True
    return False


@njit(cache=True)
def _discs_overlap(
    box: bool,
    radius: float,
    x: float,
    y: float,
    corners: np.ndarray,
    depth: float,
    disc_centres: np.ndarray,
    disc_radii: np.ndarray,
) -> bool:
    """Whether the object (a box with ``corners``, or a disc of ``radius`` at x, y) overlaps
    one of the discs by more than ``depth``."""
    for q in range(len(disc_radii)):
        px, py = disc_centres[q, 0], disc_centres[q, 1]
        if box:
            gap = point_polygon(px, py, corners, 4)[0]
        else:
            gap = math.sqrt((x - px) ** 2 + (y - py) ** 2) - radius
        if gap - disc_radii[q] < -depth:
            return True
    return False


@njit(cache=True)
def _box_in_polygon(corners: np.ndarray, verts: np.ndarray, k: int, depth: float) -> bool:
    """Whether a corner of the box lies inside the polygon, or a vertex of the polygon inside
    the box, by more than ``depth``."""
    for n in range(4):
        if deepest_side(corners[n, 0], corners[n, 1], verts, k) < -depth:
            return True
    for j in range(k):
        if deepest_side(verts[j, 0], verts[j, 1], corners, 4) < -depth:
            return True
    return False
