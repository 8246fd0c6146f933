"""Compiled closest-point kernels on triangle surfaces (numba).

For each point and a candidate facet these kernels return what a contact needs:

* the signed distance (sign from the angle-weighted pseudo-normal of the feature the
  closest point lies on: face, edge or vertex) and its gradient ``n`` (the gap's normal);
* the traction's direction ``m``: the facet's corner normals interpolated at the closest
  point (Phong-like smoothing, corner normals averaged only over faces within the
  crease angle), so that the direction turns continuously over smooth regions of a
  triangulated tool instead of jumping by the facets' angle; on crease edges and at
  crease vertices it is ``n`` itself, which turns round the sharp edge;
* ``dm/dx``, the direction's derivative with respect to the point (the Jacobian's
  share).

3-vectors are tuples of floats, so nothing is allocated inside the loops.
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True, inline="always")
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@numba.njit(cache=True, inline="always")
def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@numba.njit(cache=True, inline="always")
def _axpy(t, x, y):
    """``y + t x``."""
    return (y[0] + t * x[0], y[1] + t * x[1], y[2] + t * x[2])


@numba.njit(cache=True, inline="always")
def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@numba.njit(cache=True, inline="always")
def _vec(rows, i):
    return (rows[i, 0], rows[i, 1], rows[i, 2])


@numba.njit(cache=True, inline="always")
def _corner(cn, f, k):
    return (cn[f, k, 0], cn[f, k, 1], cn[f, k, 2])


@numba.njit(cache=True)
def closest_on_triangle(x, a, b, c):
    """Closest point of triangle abc to x, its feature and its coordinates.

    Ericson (2005), section 5.1.5. Feature: 0 face, 1/2/3 vertex a/b/c, 4/5/6 edge
    ab/bc/ca. Coordinates: on the face ``(v, w)`` with ``c = a + v ab + w ac``; on edge
    ``k`` the fraction ``s`` from its first vertex (``F[f, k]``) to its second.
    """
    ab = _sub(b, a)
    ac = _sub(c, a)
    ap = _sub(x, a)
    d1 = _dot(ab, ap)
    d2 = _dot(ac, ap)
    if d1 <= 0.0 and d2 <= 0.0:
        return a, 1, 0.0, 0.0
    bp = _sub(x, b)
    d3 = _dot(ab, bp)
    d4 = _dot(ac, bp)
    if d3 >= 0.0 and d4 <= d3:
        return b, 2, 0.0, 0.0
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        s = d1 / (d1 - d3)
        return _axpy(s, ab, a), 4, s, 0.0
    cp = _sub(x, c)
    d5 = _dot(ab, cp)
    d6 = _dot(ac, cp)
    if d6 >= 0.0 and d5 <= d6:
        return c, 3, 0.0, 0.0
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        t = d2 / (d2 - d6)
        return _axpy(t, ac, a), 6, 1.0 - t, 0.0  # the edge runs from c to a
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return _axpy(w, _sub(c, b), b), 5, w, 0.0
    denom = 1.0 / (va + vb + vc)
    v = vb * denom
    w = vc * denom
    return _axpy(w, ac, _axpy(v, ab, a)), 0, v, w


@numba.njit(cache=True, inline="always")
def _on_facet(x, f, vertices, faces):
    return closest_on_triangle(x, _vec(vertices, faces[f, 0]), _vec(vertices, faces[f, 1]),
                               _vec(vertices, faces[f, 2]))


@numba.njit(cache=True)
def _write_rotation(out, i, m, size, grad_m):
    """``out[i] = (I - m m) / |m~| grad_m`` (the derivative of a normalised vector)."""
    for a in range(3):
        for b in range(3):
            acc = 0.0
            for k in range(3):
                acc += ((a == k) - m[a] * m[k]) * grad_m[k][b]
            out[i, a, b] = acc / size


@numba.njit(cache=True)
def project(points, cand, vertices, faces, fn, en, vn, cn, smooth_edge, smooth_vertex,
            out_d, out_n, out_c, out_m, out_k):
    """Distance, gap normal, closest point, traction direction and its derivative.

    The inputs are the (n, 3) ``points`` and the facet ``cand`` of each; the surface's
    ``vertices`` and ``faces``; the face normals ``fn`` and the face-edge and vertex
    pseudo-normals ``en``, ``vn`` (signs); the (m, 3, 3) corner normals ``cn``; whether
    each face edge is smooth (``smooth_edge``, (m, 3)) and whether no crease meets a
    vertex (``smooth_vertex``). The outputs ``out_d, out_n, out_c, out_m, out_k`` are
    (n,), (n, 3), (n, 3), (n, 3) and (n, 3, 3).
    """
    for i in range(points.shape[0]):
        f = cand[i]
        x = _vec(points, i)
        c, feature, s1, s2 = _on_facet(x, f, vertices, faces)
        if feature == 0:
            pn = _vec(fn, f)
        elif feature <= 3:
            pn = _vec(vn, faces[f, feature - 1])
        else:
            k = feature - 4
            pn = (en[f, k, 0], en[f, k, 1], en[f, k, 2])
        r = _sub(x, c)
        dist = math.sqrt(_dot(r, r))
        sign = 1.0 if _dot(r, pn) >= 0.0 else -1.0
        out_d[i] = sign * dist
        n = (sign * r[0] / dist, sign * r[1] / dist, sign * r[2] / dist) if dist > 1e-12 \
            else pn
        for j in range(3):
            out_c[i, j] = c[j]
            out_n[i, j] = n[j]
        if feature == 0:  # interpolated corner normals, barycentric
            a, b, cc = (_vec(vertices, faces[f, 0]), _vec(vertices, faces[f, 1]),
                        _vec(vertices, faces[f, 2]))
            lam = (1.0 - s1 - s2, s1, s2)
            mt = (0.0, 0.0, 0.0)
            for k in range(3):
                mt = _axpy(lam[k], _corner(cn, f, k), mt)
            size = math.sqrt(_dot(mt, mt))
            m = (mt[0] / size, mt[1] / size, mt[2] / size)
            nf = _vec(fn, f)
            area2 = _dot(_cross(_sub(b, a), _sub(cc, a)), nf)
            grads = (_cross(nf, _sub(cc, b)), _cross(nf, _sub(a, cc)), _cross(nf, _sub(b, a)))
            g = [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]
            for k in range(3):
                ck = _corner(cn, f, k)
                for p in range(3):
                    for q in range(3):
                        g[p][q] += ck[p] * grads[k][q] / area2
            grad_m = ((g[0][0], g[0][1], g[0][2]), (g[1][0], g[1][1], g[1][2]),
                      (g[2][0], g[2][1], g[2][2]))
            for j in range(3):
                out_m[i, j] = m[j]
            _write_rotation(out_k, i, m, size, grad_m)
        elif feature >= 4 and smooth_edge[f, feature - 4]:  # along a smooth edge
            k = feature - 4
            e = _sub(_vec(vertices, faces[f, (k + 1) % 3]), _vec(vertices, faces[f, k]))
            c0, c1 = _corner(cn, f, k), _corner(cn, f, (k + 1) % 3)
            mt = _axpy(s1, _sub(c1, c0), c0)
            size = math.sqrt(_dot(mt, mt))
            m = (mt[0] / size, mt[1] / size, mt[2] / size)
            e2 = _dot(e, e)
            dc = _sub(c1, c0)
            grad_m = ((dc[0] * e[0] / e2, dc[0] * e[1] / e2, dc[0] * e[2] / e2),
                      (dc[1] * e[0] / e2, dc[1] * e[1] / e2, dc[1] * e[2] / e2),
                      (dc[2] * e[0] / e2, dc[2] * e[1] / e2, dc[2] * e[2] / e2))
            for j in range(3):
                out_m[i, j] = m[j]
            _write_rotation(out_k, i, m, size, grad_m)
        elif 1 <= feature <= 3 and smooth_vertex[faces[f, feature - 1]]:
            m = _corner(cn, f, feature - 1)  # the vertex's own normal: constant
            for j in range(3):
                out_m[i, j] = m[j]
                for q in range(3):
                    out_k[i, j, q] = 0.0
        else:  # a crease edge or vertex: the distance's gradient, turning round it
            t = (0.0, 0.0, 0.0)
            if feature >= 4:
                k = feature - 4
                e = _sub(_vec(vertices, faces[f, (k + 1) % 3]), _vec(vertices, faces[f, k]))
                length = math.sqrt(_dot(e, e))
                t = (e[0] / length, e[1] / length, e[2] / length)
            scale = sign / dist if dist > 1e-12 else 0.0
            for a in range(3):
                out_m[i, a] = n[a]
                for b in range(3):
                    out_k[i, a, b] = scale * ((a == b) - n[a] * n[b] - t[a] * t[b])


@numba.njit(cache=True)
def closest_in_rings(points, facet, ring_ptr, ring, vertices, faces):
    """Move each point's ``facet`` to the closest facet of its one-ring (in place)."""
    for i in range(points.shape[0]):
        x = _vec(points, i)
        best = facet[i]
        best_r2 = np.inf
        for k in range(ring_ptr[facet[i]], ring_ptr[facet[i] + 1]):
            f = ring[k]
            c, _feature, _s1, _s2 = _on_facet(x, f, vertices, faces)
            r = _sub(x, c)
            r2 = _dot(r, r)
            if r2 < best_r2:
                best_r2 = r2
                best = f
        facet[i] = best


@numba.njit(cache=True)
def corner_normals(faces, fn, vf_ptr, vf_face, vf_angle, cos_crease):
    """Corner normals (m, 3, 3) of a surface.

    At each face corner, the angle-weighted mean of the normals of the faces round the
    vertex that are within the crease angle of the face.
    """
    m = faces.shape[0]
    out = np.zeros((m, 3, 3))
    for f in range(m):
        for k in range(3):
            v = faces[f, k]
            acc = (0.0, 0.0, 0.0)
            for j in range(vf_ptr[v], vf_ptr[v + 1]):
                g = vf_face[j]
                if _dot(_vec(fn, g), _vec(fn, f)) >= cos_crease:
                    acc = _axpy(vf_angle[j], _vec(fn, g), acc)
            size = math.sqrt(_dot(acc, acc))
            for j in range(3):
                out[f, k, j] = acc[j] / size
    return out
