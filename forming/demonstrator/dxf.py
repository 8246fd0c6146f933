"""Closed outlines in DXF files (with ezdxf): what a cutting table reads and CAD writes.

:func:`write_outline` writes one closed LWPOLYLINE in millimetres.
:func:`read_outline` reads the one closed outline of a file's modelspace: a closed
LWPOLYLINE or POLYLINE (bulges are arcs), a closed SPLINE, a CIRCLE or an ELLIPSE, or a
chain of LINE, ARC, open polyline and SPLINE pieces that meet end to end; curves are
flattened to within ``FLATTEN`` of the true curve, and lengths converted to mm from the
file's ``$INSUNITS`` (unitless taken as mm).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from forming.errors import InputError

FLATTEN = 0.01  # largest distance of the flattened polyline from a curve [mm]
JOIN = 1e-3  # pieces whose ends lie this close (relative to the drawing) meet
_CURVES = ("LWPOLYLINE", "POLYLINE", "SPLINE", "CIRCLE", "ELLIPSE", "LINE", "ARC")
_TO_MM = {0: 1.0, 1: 25.4, 2: 304.8, 4: 1.0, 5: 10.0, 6: 1000.0, 8: 0.0254, 9: 0.0254e-3,
          10: 914.4, 12: 1e-6, 13: 1e-3, 14: 100.0}  # $INSUNITS code -> mm


def write_outline(path: Path, outline: np.ndarray) -> Path:
    """The outline as one closed LWPOLYLINE (units mm) in a DXF file."""
    import ezdxf

    doc = ezdxf.new("R2010", units=4)  # 4: millimetres
    doc.modelspace().add_lwpolyline([tuple(map(float, p)) for p in outline], close=True)
    doc.saveas(path)
    return path


def read_outline(path: Path | str, field: str) -> np.ndarray:
    """The (n, 2) points [mm] of the one closed outline in a DXF file.

    Raises:
        InputError: (naming ``field`` and the file) no such file, not a DXF file, units
            without a length, no closed outline, or more than one.
    """
    import ezdxf
    from ezdxf import path as dxfpath

    path = Path(path)
    if not path.is_file():
        raise InputError(field, f"{path}: no such file")
    try:
        doc = ezdxf.readfile(path)
    except (OSError, ezdxf.DXFError) as exc:
        raise InputError(field, f"{path}: not a readable DXF file ({exc})") from exc
    units = int(doc.header.get("$INSUNITS", 0))
    if units not in _TO_MM:
        raise InputError(field, f"{path}: $INSUNITS = {units} is not a length unit this "
                         "reader knows; save the drawing in mm")
    closed, pieces = [], []
    for entity in doc.modelspace():
        if entity.dxftype() not in _CURVES:
            continue
        p = dxfpath.make_path(entity)
        pts = np.array([(v.x, v.y) for v in p.flattening(FLATTEN / _TO_MM[units])])
        if len(pts) < 2:
            continue
        if entity.dxftype() in ("CIRCLE", "ELLIPSE") or np.allclose(pts[0], pts[-1]) or (
                entity.dxftype() in ("LWPOLYLINE", "POLYLINE") and entity.is_closed):
            closed.append(pts)
        else:
            pieces.append(pts)
    if pieces:
        closed.extend(_chains(pieces, path, field))
    if not closed:
        raise InputError(field, f"{path}: no closed outline in the modelspace (a closed "
                         "polyline, spline, circle or ellipse, or lines and arcs that meet "
                         "end to end)")
    if len(closed) > 1:
        raise InputError(field, f"{path}: {len(closed)} closed outlines in the modelspace; "
                         "the blank or trim line must be the only one")
    pts = closed[0] * _TO_MM[units]
    if np.allclose(pts[0], pts[-1]):
        pts = pts[:-1]
    keep = np.r_[True, np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-9]
    return pts[keep]


def _chains(pieces: list[np.ndarray], path: Path, field: str) -> list[np.ndarray]:
    """Join open pieces end to end into closed chains; refuse what stays open."""
    scale = max(float(np.ptp(np.vstack(pieces), axis=0).max()), 1.0)
    tol = JOIN * scale
    left = list(pieces)
    chains = []
    while left:
        chain = [left.pop(0)]
        while np.linalg.norm(chain[-1][-1] - chain[0][0]) > tol:
            end = chain[-1][-1]
            for k, p in enumerate(left):
                if np.linalg.norm(p[0] - end) <= tol:
                    chain.append(left.pop(k))
                    break
                if np.linalg.norm(p[-1] - end) <= tol:
                    chain.append(left.pop(k)[::-1])
                    break
            else:
                raise InputError(field, f"{path}: the outline is open: no piece starts at "
                                 f"({end[0]:.4g}, {end[1]:.4g}) (ends must meet within "
                                 f"{tol:.2g} drawing units)")
        chains.append(np.vstack([chain[0]] + [c[1:] for c in chain[1:]]))
    return chains
