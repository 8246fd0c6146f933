"""Virtual picture-frame test of the NCF skin (issue #4): the shear law, recovered.

A square ply of side L sits in a pin-jointed frame whose arms run along the fibres. The
frame imposes pure fibre rotation on the ply's edges: the two families turn towards each
other by gamma/2 each, without stretching. The shear angle goes 0 -> +gamma_max -> 0 ->
-gamma_max, so one run covers both branches. Each step gives the frame's crosshead force
from the internal virtual work along the frame's motion, normalised as the input data are
(F_norm = F L / (2 cos(phi) S), material-data.md), and compares it with the input curve.

The frame's coordinates are the fibres' (0 and 90 deg); the stitch runs along the frame's
diagonal, the fibres' bisector. Positive shear closes the fibres around the stitch.

Accuracy of the defaults (docs/validation.md, "Convergence of the shipped cases"): a
homogeneous test: the curve error is the same on 4 x 4 to 16 x 16 meshes.

Run: ``python cases/picture_frame.py`` (or ``--set shear_max_deg=60``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from forming import post
from forming.case import main, require
from forming.errors import InputError
from forming.fixtures import frame_gradient, frame_gradient_rate
from forming.job import Job
from forming.materials.fabric import NonCrimpFabric, ShearCurve
from forming.mesh import box
from forming.scene import AffineDisplacement, Body, Displacement, Scene
from forming.solver.options import ExplicitOptions, NewtonOptions
from forming.solver.stepping import StepControl


@dataclass(frozen=True)
class Params:
    """Parameters of the picture-frame case (mm, degrees)."""

    side: float = 100.0  # frame side [mm]
    thickness: float = 0.4  # ply thickness [mm]
    cells: tuple[int, ...] = (8, 8, 1)  # elements along x, y, z
    shear_max_deg: float = 55.0  # largest shear angle of the cycle [deg]
    curve: str | None = None  # CSV of the picture-frame curve; none: the shipped estimate
    max_step: float = 0.02  # largest load step (fraction of the cycle)
    programme: Literal["smooth", "linear"] = "smooth"  # legs that start and stop at rest, or
    # at constant rate (the frame's velocity reverses at once at +shear_max_deg)


def shear_programme(g_max: float, smooth: bool = True):
    """Shear angle [rad] against the load parameter: 0 -> +g_max -> 0 -> -g_max.

    Each leg (t in [0, 0.25], [0.25, 0.5], [0.5, 1]) goes at constant rate, or (smooth)
    follows the smooth step ``3x^2 - 2x^3`` of its own fraction ``x``, so that the frame
    comes to rest at every turn: at constant rate the frame's velocity reverses at +g_max
    at once, and in an explicit run the jolt sets the taut fibres ringing
    (docs/validation.md). The path of shear angles is the same, so the implicit answer is
    too.
    """
    knots = np.array([0.0, 0.25, 0.5, 1.0])
    values = np.array([0.0, g_max, 0.0, -g_max])
    if not smooth:
        return lambda t: float(np.interp(t, knots, values))

    def gamma(t: float) -> float:
        t = min(max(float(t), 0.0), 1.0)
        i = min(int(np.searchsorted(knots, t, side="right")) - 1, len(knots) - 2)
        x = (t - knots[i]) / (knots[i + 1] - knots[i])
        return float(values[i] + (values[i + 1] - values[i]) * x * x * (3.0 - 2.0 * x))

    return gamma


def build(p: Params) -> Job:
    require(p, positive=("side", "thickness"))
    if not 0.0 < p.shear_max_deg < 80.0:
        raise InputError("--set shear_max_deg", f"must lie in (0, 80), got {p.shear_max_deg}")
    curve = ShearCurve.from_csv(p.curve) if p.curve else ShearCurve.default()
    fabric = NonCrimpFabric(thickness=p.thickness, fibre_angles_deg=(0.0, 90.0), shear=curve)
    path = shear_programme(math.radians(p.shear_max_deg), p.programme == "smooth")
    mesh = box((p.side, p.side, p.thickness), tuple(p.cells))
    frame = tuple(AffineDisplacement("ply", side, lambda t: frame_gradient(path(t)),
                                     components=(0, 1))
                  for side in ("xmin", "xmax", "ymin", "ymax"))
    scene = Scene(name="picture_frame", mesh=mesh, bodies=(Body("ply", fabric),),
                  displacements=(*frame, Displacement("ply", "bottom", z=0.0,
                                                      reaction=False)))
    area = p.side**2

    power: dict = {}  # the internal power's form, compiled on the first call

    def probe(model) -> dict[str, float]:
        if not power:
            power["of"] = post.InternalPower(model.body)
        gamma = path(model.t)
        rate = frame_gradient_rate(gamma)
        dw = power["of"](lambda x: rate @ x)  # dW/dgamma [N mm] along the frame's motion
        model.body.update_output()
        lo, hi = model.body.shear_range_deg()
        return {
            "shear_deg": math.degrees(gamma),
            "frame_force_N": dw / (p.side * math.sin(math.pi / 4 - gamma / 2)),
            "normalised_force_N_per_mm": dw / (math.cos(gamma) * area),
            "input_force_N_per_mm": float(curve.torque(gamma)) / math.cos(gamma),
            "shear_field_min_deg": lo, "shear_field_max_deg": hi,
        }

    def metrics(rec, model) -> dict:
        g = rec.column("shear_deg")
        sim, ref = rec.column("normalised_force_N_per_mm"), rec.column("input_force_N_per_mm")
        out = {}
        worst = 0.0
        for name, sel in (("positive", g >= 5.0), ("negative", g <= -5.0)):
            if sel.any():
                rel = (sim[sel] - ref[sel]) / ref[sel]
                out[f"shear_curve_rmse_rel_{name}"] = float(np.sqrt(np.mean(rel**2)))
                out[f"shear_curve_max_err_rel_{name}"] = float(np.abs(rel).max())
                worst = max(worst, out[f"shear_curve_rmse_rel_{name}"])
        uniform = np.abs(rec.column("shear_field_max_deg") - rec.column("shear_field_min_deg"))
        return {"shear_curve_rmse_rel": worst, **out,
                "shear_max_deg": float(g.max()), "shear_min_deg": float(g.min()),
                "shear_field_spread_deg": float(uniform.max())}

    def plots(rec, out: Path) -> list[Path]:
        from forming.output import plot_curves

        g = rec.column("shear_deg")
        dense = np.linspace(-p.shear_max_deg, p.shear_max_deg, 201)
        ref = curve.torque(np.radians(dense)) / np.cos(np.radians(dense))
        return [plot_curves(Path(out) / "picture_frame.png",
                            [(dense, ref, f"input ({Path(curve.source).name})", "-"),
                             (g, rec.column("normalised_force_N_per_mm"), "computed", "o")],
                            "shear angle [deg]", "normalised frame force [N/mm]",
                            "Picture frame: NCF shear (positive: stitch in tension)")]

    return Job(scene=scene, steps=StepControl(initial=p.max_step, max=p.max_step,
                                              stops=(0.25, 0.5, 0.75)),
               newton=NewtonOptions(), probe=probe, metrics=metrics, plots=plots,
               field_every=5,
               # the frame drives the whole ply, whose kinetic energy stays within 2.5% of
               # the soft shear's internal energy only over 0.4 s (docs/theory.md, section 12)
               explicit=ExplicitOptions(loading_time=0.4))


if __name__ == "__main__":
    main(build, Params, "picture_frame")
