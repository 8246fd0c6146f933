"""Named measurements of a model's state, for case metrics and history probes.

Every function here is collective (a reduction over the ranks): call it on every rank.
History columns are whole-part figures already (forces, volumes and energies scaled by
the scene's ``symmetry_copies`` when recorded); integrals over the model are scaled here
(:func:`whole`), so no case writes a symmetry factor of its own.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import ufl

from forming.parallel import global_count, global_max, global_min, global_sum
from forming.post.fields import PlasticStrainField, plastic_field


def whole(model, value: float) -> float:
    """A figure of the modelled part scaled to the whole part (symmetry copies)."""
    return model.scene.symmetry_copies * value


def relative_rms(computed: np.ndarray, reference: np.ndarray) -> float:
    """RMS of the difference over the RMS of the reference (inf for a zero reference)."""
    ref = np.sqrt(np.mean(np.square(reference)))
    return float(np.sqrt(np.mean(np.square(computed - reference))) / ref) if ref > 0 else np.inf


def force_peak_final(rec, column: str, name: str = "punch_force") -> dict[str, float]:
    """Largest and final force of a history column (whole part: the history's) [N]."""
    force = rec.column(column)
    return {f"{name}_max_N": float(force.max()), f"{name}_final_N": float(force[-1])}


def force_mean(rec, column: str, start: float, name: str = "punch_force") -> dict[str, float]:
    """Mean force over the load parameter from ``start`` to the end [N] (trapezoid).

    A crushing core's force oscillates as layers of elements collapse one after another;
    its mean over the stroke converges where the peak does not. NaN if the run did not
    get past ``start``.
    """
    t, f = rec.column("t"), rec.column(column)
    keep = t >= start
    if keep.sum() < 2:
        return {f"{name}_mean_N": float("nan")}
    return {f"{name}_mean_N": float(np.trapezoid(f[keep], t[keep]) / (t[keep][-1] - t[keep][0]))}


def contact_metrics(rec, model) -> dict[str, float]:
    """Largest penetration over the run and the tightest tolerance of the scene's pairs."""
    return {
        "max_penetration_mm": float(rec.column("max_penetration_mm").max()),
        "penetration_tolerance_mm": min(c.tolerance for c in model.contacts),
    }


def _on_edges(x: np.ndarray, x_edge: float, y_edge: float) -> tuple[np.ndarray, np.ndarray]:
    return np.isclose(x[:, 0], x_edge), np.isclose(x[:, 1], y_edge)


def edge_lift(body, x_edge: float, y_edge: float) -> float:
    """Largest |u_z| of the nodes on the free edges ``x = x_edge`` or ``y = y_edge`` [mm]."""
    x, u = body.nodal_coordinates(), body.nodal_displacements()
    on_x, on_y = _on_edges(x, x_edge, y_edge)
    return global_max(body.mesh.comm, np.abs(u[on_x | on_y, 2]), initial=0.0)


def edge_draw_in(body, x_edge: float, y_edge: float) -> float:
    """Largest inward in-plane motion of the free edges ``x = x_edge``, ``y = y_edge`` [mm]."""
    x, u = body.nodal_coordinates(), body.nodal_displacements()
    on_x, on_y = _on_edges(x, x_edge, y_edge)
    inward = np.concatenate([-u[on_x, 0], -u[on_y, 1]])
    return global_max(body.mesh.comm, inward, initial=0.0)


def crushed_volume(model, threshold: float = 0.01, where=None) -> float:
    """Whole-part reference volume of the first body crushed beyond ``threshold`` [mm^3]."""
    return whole(model, plastic_field(model.body).crushed_volume(threshold, where))


def crushed_volume_probe(model) -> dict[str, float]:
    """History probe: the whole-part crushed volume of the first body."""
    return {"crushed_volume_mm3": crushed_volume(model)}


def crushing_depth(field: PlasticStrainField, where, height: float, levels: int = 41,
                   threshold: float = 0.01) -> float:
    """Depth below the top ``z = height`` to which at least half of ``where`` is crushed.

    Scans levels ``z0`` from the bottom up; the first band ``where & z >= z0`` of which
    at least half the volume has plastic strain above ``threshold`` gives the depth
    ``height - z0`` [mm] (0 if none).
    """
    from dolfinx import fem  # after forming: PETSc comes from dolfinx_solver

    x = ufl.SpatialCoordinate(field.body.mesh)
    level = fem.Constant(field.body.mesh, 0.0)
    band = where * ufl.conditional(ufl.lt(x[2], level), 0.0, 1.0)
    for z0 in np.linspace(0.0, height, levels):
        level.value = z0
        if field.crushed_volume(threshold, band) >= 0.5 * field.integral(band):
            return float(height - z0)
    return 0.0


def plastic_strain_max(body) -> float:
    """Largest volumetric plastic strain at a quadrature point (0 if none)."""
    return global_max(body.mesh.comm, body.plastic.evp, initial=0.0)


def plastic_strain_extremes(body) -> dict[str, float]:
    """Largest compaction and dilation of the volumetric plastic strain at a point.

    Point values, like the pointwise means of :class:`PlasticStrainField`: a mean over a
    region can then never exceed the maximum (cell means could, where compaction and
    dilation share a cell).
    """
    comm = body.mesh.comm
    evp = body.plastic.evp
    return {"crushing_strain_max": global_max(comm, evp, initial=0.0),
            "dilation_strain_max": -global_min(comm, evp, initial=0.0)}


def nodal_gap_max(contact, where: Callable[[np.ndarray], np.ndarray]) -> float:
    """Largest gap between a contact's region nodes and its tool, over nodes ``where(x)``."""
    g, x = contact.nodal_gap()
    return global_max(contact.comm, g[where(x)], initial=0.0)


def skin_shear_statistics(model, names: tuple[str, ...]) -> dict[str, float]:
    """Shear-angle range and wrinkling area fraction of each fabric body, and overall."""
    out: dict[str, float] = {}
    for name in names:
        body = model.bodies[name]
        body.update_output()
        lo, hi = body.shear_range_deg()
        out |= {f"shear_min_deg_{name}": lo, f"shear_max_deg_{name}": hi,
                f"wrinkle_area_fraction_{name}": body.wrinkle_area_fraction()}
    return {"shear_min_deg": min(out[f"shear_min_deg_{n}"] for n in names),
            "shear_max_deg": max(out[f"shear_max_deg_{n}"] for n in names),
            "wrinkle_area_fraction": max(out[f"wrinkle_area_fraction_{n}"] for n in names),
            } | out


def interface_slips(model) -> dict[str, float]:
    """Largest skin-core slip of each interface (by its second body) and overall [mm]."""
    slips = {f"skin_core_slip_max_mm_{itf.spec.other}": itf.max_slip()
             for itf in model.interfaces}
    slips |= {f"skin_core_slip_max_mm_{sl.spec.slave}": sl.max_slip() for sl in model.sliding}
    return {"skin_core_slip_max_mm": max(slips.values())} | slips


def interface_slip_at(model, axis: int, at: float) -> float:
    """Largest |slip| along ``axis`` of the interface nodes at ``x[axis] = at`` [mm]."""
    worst = 0.0
    for itf in model.interfaces:
        s, x = itf.slip()
        worst = max(worst, global_max(model.comm, np.abs(s[np.isclose(x[:, axis], at), axis]),
                                      initial=0.0))
    return worst


class InternalPower:
    """Internal virtual work of a body along a velocity field ``v(x)`` (collective).

    For a fixture that moves a face as a whole, this is the power the fixture's force
    does per unit rate of its motion (picture frame: the crosshead force from dW/dgamma).
    The form is compiled once.

    Args:
        body: The body.
    """

    def __init__(self, body):
        from dolfinx import fem  # after forming: PETSc comes from dolfinx_solver

        self._w = fem.Function(body.V)
        self._form = fem.form(body.residual(self._w))

    def __call__(self, velocity: Callable[[np.ndarray], np.ndarray]) -> float:
        """Internal virtual work along ``velocity`` (a function of the (3, n) points)."""
        from forming.parallel import assemble_scalar

        self._w.interpolate(velocity)
        return assemble_scalar(self._form)


def cell_mean_near(body, values, centre: tuple[float, float], radius: float) -> float:
    """Mean of a DG0 function over the owned cells within ``radius`` of ``centre`` (x, y)."""
    n = body.n_local_cells
    x = values.function_space.tabulate_dof_coordinates()[:n]
    near = np.hypot(x[:, 0] - centre[0], x[:, 1] - centre[1]) < radius
    vals = values.x.array[:n][near]
    count = global_count(body.mesh.comm, near)
    return global_sum(body.mesh.comm, vals) / max(count, 1)


def hemisphere_metrics(rec, model, punch_radius: float, edge: float) -> dict[str, float]:
    """The hemisphere-forming figures of the paper's "Core bending" (Fig. 11).

    Punch force, crushed volume (all and under the punch), mean compaction under the
    punch, plastic-strain extremes, lift of the free edges at ``x, y = edge``, the
    largest gap between the blank and the punch over its cap (conformity), and contact
    penetration. Whole-part figures.
    """
    evp = plastic_field(model.body)
    x = ufl.SpatialCoordinate(model.body.mesh)
    under = ufl.conditional(ufl.lt(x[0] ** 2 + x[1] ** 2, punch_radius**2), 1.0, 0.0)
    on_cap = lambda xs: np.hypot(xs[:, 0], xs[:, 1]) < 0.7 * punch_radius  # noqa: E731
    return force_peak_final(rec, "force_punch_z_N") | {
        "crushed_volume_mm3": crushed_volume(model),
        "crushed_volume_under_punch_mm3": crushed_volume(model, 0.01, under),
        "crushing_strain_mean_under_punch": evp.compaction_mean(under),
        **plastic_strain_extremes(model.body),
        "edge_lift_max_mm": edge_lift(model.body, edge, edge),
        "punch_gap_max_mm": nodal_gap_max(model.contacts[0], on_cap),
    } | contact_metrics(rec, model)
