"""The discrete model of a scene: spaces, quadrature-point material data and forms.

Stress and tangent of a solid live in quadrature Functions that a numba kernel
fills before each residual evaluation; history (plastic strain) lives in plain
arrays and is allocated only for a plastic material. See ``docs/theory.md``.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import basix.ufl
import numpy as np
import ufl
from dolfinx import fem  # noqa: I001
from mpi4py import MPI

from forming import compat  # noqa: F401  (imports dolfinx the right way)
from forming.domain import BodyDomain
from forming.materials.solids import PointMaterial, evaluate
from forming.scene import AffineDisplacement, Body, Displacement, Scene

log = logging.getLogger(__name__)
_R2 = math.sqrt(2.0)


def mandel_to_tensor(s):
    """UFL 3x3 symmetric tensor from a Mandel 6-vector."""
    return ufl.as_matrix(
        [
            [s[0], s[5] / _R2, s[4] / _R2],
            [s[5] / _R2, s[1], s[3] / _R2],
            [s[4] / _R2, s[3] / _R2, s[2]],
        ]
    )


def tensor_to_mandel(e):
    """Mandel 6-vector of a symmetric UFL tensor."""
    return ufl.as_vector([e[0, 0], e[1, 1], e[2, 2], _R2 * e[1, 2], _R2 * e[0, 2], _R2 * e[0, 1]])


class KernelFailure(RuntimeError):
    """The point kernel failed (inverted element or return mapping)."""


@dataclass
class PlasticState:
    """Converged and trial history of a plastic body (arrays over quadrature points)."""

    ep: np.ndarray
    evp: np.ndarray
    ep_trial: np.ndarray
    evp_trial: np.ndarray

    @classmethod
    def zeros(cls, n: int) -> PlasticState:
        """State of an undeformed body with ``n`` points."""
        return cls(np.zeros((n, 6)), np.zeros(n), np.zeros((n, 6)), np.zeros(n))

    def commit(self) -> None:
        """Accept the trial state."""
        self.ep[:] = self.ep_trial
        self.evp[:] = self.evp_trial

    def snapshot(self) -> tuple[np.ndarray, np.ndarray]:
        """Copy of the converged state."""
        return self.ep.copy(), self.evp.copy()

    def restore(self, snap: tuple[np.ndarray, np.ndarray]) -> None:
        """Return to a snapshot."""
        self.ep[:], self.evp[:] = snap
        self.ep_trial[:], self.evp_trial[:] = snap


class SolidBody:
    """A deformable body: displacement, quadrature material data and its forms.

    Args:
        body: The scene's body.
        scene: The scene (quadrature degree).
        domain: Where the body lives (its mesh and measures).
    """

    def __init__(self, body: Body, scene: Scene, domain: BodyDomain):
        self.body = body
        self.domain = domain
        msh = domain.mesh
        self.mesh = msh
        self.material: PointMaterial = body.material
        q = scene.quadrature_degree or (2 if body.degree == 1 else 4)
        self.quadrature_degree = q
        self.V = fem.functionspace(msh, ("Lagrange", body.degree, (3,)))
        self.u = fem.Function(self.V, name="u")
        cell = msh.basix_cell()
        self.QS = fem.functionspace(msh, basix.ufl.quadrature_element(cell, value_shape=(6,),
                                                                      degree=q))
        self.QD = fem.functionspace(msh, basix.ufl.quadrature_element(cell, value_shape=(6, 6),
                                                                      degree=q))
        self.S = fem.Function(self.QS, name="S")
        self.D = fem.Function(self.QD, name="D")
        self.n_local_cells, self.cells = domain.n_owned_cells, domain.own_cells
        self._qdofs = self.QS.dofmap.list[self.cells].ravel()
        self.n_points = self._qdofs.size
        (self.dx,) = domain.dx(q)  # solve forms: on the scene mesh
        self.own_dx = domain.own_dx(q)  # post-processing: on the body's mesh
        F = self.deformation_gradient()
        C = F.T * F
        self._C_expr = fem.Expression(
            ufl.as_vector([C[i, j] for i in range(3) for j in range(3)] + [ufl.det(F)]),
            self.QS.element.interpolation_points,
        )
        self.plastic: PlasticState | None = (
            PlasticState.zeros(self.n_points) if self.material.plastic else None
        )
        self._evp_cells = None  # cell means of the plastic strain (output)
        if self.plastic is not None:
            self._evp_cells = fem.Function(fem.functionspace(msh, ("DG", 0)),
                                           name="volumetric_plastic_strain")
        self._evaluated_at: np.ndarray | None = None
        self.load_increment = 0.0  # step in the load parameter (viscous regularisation)
        self.kernel_seconds = 0.0
        self._warm_kernel()

    def _warm_kernel(self) -> None:
        """Compile (or load from cache) the numba kernel before timing starts."""
        c = np.eye(3).reshape(1, 9)
        evaluate(self.material, c, want_tangent=True)

    def deformation_gradient(self):
        """UFL deformation gradient."""
        return ufl.Identity(3) + ufl.grad(self.u)

    def first_piola(self):
        """UFL first Piola-Kirchhoff stress from the quadrature stress."""
        return self.deformation_gradient() * mandel_to_tensor(self.S)

    def residual(self, v) -> ufl.Form:
        """Internal virtual work."""
        return ufl.inner(self.first_piola(), ufl.grad(v)) * self.dx

    def jacobian(self, du, v) -> ufl.Form:
        """Consistent linearisation of :meth:`residual` using the quadrature tangent."""
        F = self.deformation_gradient()
        dF = ufl.grad(du)
        dE = ufl.sym(F.T * dF)
        dE_m = tensor_to_mandel(dE)
        dS_m = ufl.as_vector([sum(self.D[i, j] * dE_m[j] for j in range(6)) for i in range(6)])
        dP = dF * mandel_to_tensor(self.S) + F * mandel_to_tensor(dS_m)
        return ufl.inner(dP, ufl.grad(v)) * self.dx

    # -- quadrature-point update ---------------------------------------------------------
    def update_material(self, want_tangent: bool = True, frozen: bool = False) -> None:
        """Evaluate stress (and tangent, trial state) at the current displacement.

        ``frozen`` evaluates a plastic material elastically about its committed plastic
        state (the unloading stiffness); call :meth:`invalidate` afterwards.

        Raises:
            KernelFailure: An element is inverted or a return mapping failed.
        """
        key = self.u.x.array
        if (not frozen and self._evaluated_at is not None and want_tangent <= self._has_tangent
                and np.array_equal(self._evaluated_at, key)):
            return
        t0 = time.perf_counter()
        cj = self._C_expr.eval(self.mesh, self.cells).reshape(-1, 10)
        n_inverted = int(np.count_nonzero(cj[:, 9] <= 0.0))
        if n_inverted:  # C alone cannot tell an inverted element
            self._evaluated_at = None
            raise KernelFailure(f"{n_inverted} quadrature points: inverted elements (det F <= 0)")
        cm = cj[:, :9]
        ps = self.plastic
        res = evaluate(
            self.material, cm, None if ps is None else ps.ep, None if ps is None else ps.evp,
            want_tangent=want_tangent, load_increment=self.load_increment, frozen=frozen,
        )
        self.kernel_seconds += time.perf_counter() - t0
        if res.n_failed:
            self._evaluated_at = None
            what = "inverted elements" if res.worst_status == 1 else "return mapping failed"
            raise KernelFailure(f"{res.n_failed} quadrature points: {what}")
        self.S.x.array.reshape(-1, 6)[self._qdofs] = res.S
        if want_tangent:
            self.D.x.array.reshape(-1, 36)[self._qdofs] = res.D
        if frozen:
            self._evaluated_at = None
            return
        if ps is not None:
            ps.ep_trial[:] = res.ep
            ps.evp_trial[:] = res.evp
        self._evaluated_at = key.copy()
        self._has_tangent = want_tangent

    def invalidate(self) -> None:
        """Forget the cached evaluation (after the state or ``u`` changed outside SNES)."""
        self._evaluated_at = None

    def contact_stiffness(self) -> float:
        """Largest diagonal elastic modulus [MPa] (sets default contact penalties)."""
        return float(np.max(np.diag(self.material.kernel_data().cel)))

    # -- outputs -------------------------------------------------------------------------
    def output_fields(self) -> dict[str, list[fem.Function]]:
        """ParaView fields besides the displacement: file stem -> functions."""
        return {} if self._evp_cells is None else {"plastic_strain": [self._evp_cells]}

    def update_output(self) -> None:
        """Cell means of the converged plastic strain into the output fields."""
        if self.plastic is not None:
            f = self._evp_cells
            f.x.array[: self.n_local_cells] = self.cell_average(self.plastic.evp)
            f.x.scatter_forward()

    def min_det_F(self) -> float:
        """Smallest Jacobian determinant over the quadrature points of all ranks."""
        cj = self._C_expr.eval(self.mesh, self.cells[: self.n_local_cells]).reshape(-1, 10)
        local = float(cj[:, 9].min()) if cj.size else np.inf
        return self.mesh.comm.allreduce(local, op=MPI.MIN)

    def cell_average(self, values: np.ndarray) -> np.ndarray:
        """Average of point values over each local cell (owned cells only)."""
        per_cell = values.reshape(len(self.cells), -1)[: self.n_local_cells]
        return per_cell.mean(axis=1)

    def volumetric_plastic_strain(self) -> np.ndarray | None:
        """Converged volumetric plastic strain per quadrature point (None if elastic)."""
        return None if self.plastic is None else self.plastic.evp


class DirichletSet:
    """Prescribed displacements of a scene with their reaction-force forms.

    Args:
        scene: The scene.
        bodies: Its discrete bodies by name.
        residual: ``residual(body_name, w)``: the body's full residual (internal forces
            minus every external force on it) tested with ``w``; a reaction is its value
            for ``w`` = 1 on the face's dofs of one component.
    """

    def __init__(self, scene: Scene, bodies: dict, residual: Callable):
        self.items: list[tuple[Displacement, int, fem.Constant]] = []
        self.bcs: list[fem.DirichletBC] = []
        self.bc_bodies: list[str] = []  # the body of each entry of ``bcs``
        self._reaction_forms: dict[str, fem.Form] = {}
        # per reaction: its body and the indicator w (reaction = residual vector . w)
        self.reaction_weights: dict[str, tuple[str, fem.Function]] = {}
        self.affine: list[tuple[AffineDisplacement, int, fem.Function]] = []
        for d in scene.displacements:
            body = bodies[d.body]
            facets = body.domain.facets(d.region)
            if isinstance(d, AffineDisplacement):
                for comp in d.components:
                    Vc, _ = body.V.sub(comp).collapse()
                    u_bc = fem.Function(Vc)
                    dofs = fem.locate_dofs_topological((body.V.sub(comp), Vc), 2, facets)
                    self.bcs.append(fem.dirichletbc(u_bc, dofs, body.V.sub(comp)))
                    self.bc_bodies.append(d.body)
                    self.affine.append((d, comp, u_bc))
                continue
            for comp, _path in d.components():
                Vc = body.V.sub(comp)
                dofs = fem.locate_dofs_topological(Vc, 2, facets)
                const = fem.Constant(body.mesh, 0.0)
                self.bcs.append(fem.dirichletbc(const, dofs, Vc))
                self.bc_bodies.append(d.body)
                self.items.append((d, comp, const))
                if d.reaction:
                    w = fem.Function(body.V)
                    Vsub, sub_map = body.V.sub(comp).collapse()
                    dofs_sub = fem.locate_dofs_topological((body.V.sub(comp), Vsub), 2, facets)[0]
                    w.x.array[dofs_sub] = 1.0
                    key = f"{d.region}_{'xyz'[comp]}"
                    if len(bodies) > 1:
                        key = f"{d.body}_{key}"
                    self.reaction_weights[key] = (d.body, w)
                    self._reaction_forms[key] = fem.form(
                        residual(d.body, w), entity_maps=_entity_maps(bodies) or None)

    def set_load(self, t: float) -> None:
        """Set the prescribed values at load parameter ``t``."""
        for d, comp, const in self.items:
            const.value = d.value(comp, t)
        for d, comp, u_bc in self.affine:
            row = np.asarray(d.gradient(t), dtype=float)[comp]
            u_bc.interpolate(lambda x, row=row: row @ x)

    def reactions(self, comm: MPI.Comm) -> dict[str, float]:
        """Reaction forces [N] on the recorded faces, summed over ranks."""
        return {
            k: comm.allreduce(fem.assemble_scalar(f), op=MPI.SUM)
            for k, f in self._reaction_forms.items()
        }


def _entity_maps(bodies: dict) -> list:
    """Entity maps of every body with a mesh of its own."""
    return [m for b in bodies.values() for m in b.domain.entity_maps]


def _extent_min(msh) -> float:
    """Smallest edge of the bounding box of a mesh over all ranks [mm]."""
    x = msh.geometry.x
    lo = [msh.comm.allreduce(float(x[:, i].min(initial=np.inf)), op=MPI.MIN) for i in range(3)]
    hi = [msh.comm.allreduce(float(x[:, i].max(initial=-np.inf)), op=MPI.MAX) for i in range(3)]
    return float(min(h - lo_ for lo_, h in zip(lo, hi, strict=True)))


def make_body(body: Body, scene: Scene, domain: BodyDomain):
    """The discrete body for a scene body: a fabric layer or a (plastic) solid."""
    from forming.fabric_body import FabricBody
    from forming.materials.fabric import NonCrimpFabric

    if isinstance(body.material, NonCrimpFabric):
        return FabricBody(body, scene, domain)
    return SolidBody(body, scene, domain)


class Model:
    """The discrete model of a scene: bodies, loads, tool contacts and interfaces.

    Each body has its own displacement field; the residual is one form per body
    (:meth:`residuals`), coupled through the interfaces between bodies.
    """

    def __init__(self, scene: Scene):
        from forming.contact.interface import InterfaceTerm, interface_entities
        from forming.contact.terms import ContactTerm

        self.scene = scene
        md = scene.mesh
        self.comm = md.mesh.comm
        self._t = self._t_committed = 0.0
        domains = {b.name: BodyDomain.create(md, b.region) for b in scene.bodies}
        self.bodies = {b.name: make_body(b, scene, domains[b.name]) for b in scene.bodies}
        self.entity_maps = _entity_maps(self.bodies)
        thickness = {name: _extent_min(b.mesh) for name, b in self.bodies.items()}
        self.tractions = []
        for tr in scene.tractions:
            body = self.bodies[tr.body]
            const = fem.Constant(md.mesh, np.zeros(3))
            self.tractions.append((tr, const, body.domain.ds(tr.region)))
        self.contacts = [
            ContactTerm(c, scene.tool(c.tool), self.bodies[c.body], thickness[c.body])
            for c in scene.contacts
        ]
        self.interfaces = []
        if scene.interfaces:
            data = [(i + 1, interface_entities(md, domains[itf.body], domains[itf.other],
                                               itf.region))
                    for i, itf in enumerate(scene.interfaces)]
            dS = ufl.Measure("dS", domain=md.mesh, subdomain_data=data,
                             metadata={"quadrature_rule": "vertex", "quadrature_degree": 1})
            self.interfaces = [
                InterfaceTerm(itf, self.bodies[itf.body], self.bodies[itf.other], dS(i + 1),
                              min(thickness[itf.body], thickness[itf.other]))
                for i, itf in enumerate(scene.interfaces)
            ]
        self.constraints = [*self.contacts, *self.interfaces]
        tests = {n: ufl.TestFunction(b.V) for n, b in self.bodies.items()}
        self.dirichlet = DirichletSet(
            scene, self.bodies, lambda name, w: self._residual_terms(tests | {name: w})[name])

    @property
    def t(self) -> float:
        """Load parameter of the current state."""
        return self._t

    def bounding_box(self) -> np.ndarray:
        """Reference bounding box of the mesh, (min xyz, max xyz), over all ranks."""
        x = self.scene.mesh.mesh.geometry.x
        lo = [self.comm.allreduce(x[:, i].min(), op=MPI.MIN) for i in range(3)]
        hi = [self.comm.allreduce(x[:, i].max(), op=MPI.MAX) for i in range(3)]
        return np.array([lo, hi])

    def tool_bounds(self) -> tuple[float, ...]:
        """Box in which tool surfaces are drawn: the body's box, padded."""
        box = self.bounding_box()
        pad = 0.35 * float(np.max(box[1] - box[0]))
        return tuple(float(v) for i in range(3) for v in (box[0, i] - pad, box[1, i] + pad))

    def tool_resolution(self) -> float:
        """Grid spacing for drawing tool surfaces [mm]."""
        b = self.tool_bounds()
        return max(b[1] - b[0], b[3] - b[2], b[5] - b[4]) / 120.0

    @property
    def body(self) -> SolidBody:
        """The first body of the scene (the only one in a single-body scene)."""
        return next(iter(self.bodies.values()))

    @property
    def names(self) -> list[str]:
        """Body names in block order."""
        return list(self.bodies)

    def _residual_terms(self, tests: dict) -> dict[str, ufl.Form]:
        """Residual form of every body, tested with ``tests[name]``."""
        forms = {}
        for name, body in self.bodies.items():
            v = tests[name]
            form = body.residual(v)
            for tr, const, ds in self.tractions:  # only when the scene has loads
                if tr.body == name:
                    form = form - ufl.dot(const, v) * ds
            for c in self.contacts:
                if c.contact.body == name:
                    form = form + c.residual(v)
            forms[name] = form
        for itf in self.interfaces:
            r1, r2 = itf.residuals(tests[itf.spec.body], tests[itf.spec.other])
            forms[itf.spec.body] = forms[itf.spec.body] + r1
            forms[itf.spec.other] = forms[itf.spec.other] + r2
        return forms

    def residuals(self) -> list[ufl.Form]:
        """One residual form per body, in :attr:`names` order."""
        tests = {n: ufl.TestFunction(b.V) for n, b in self.bodies.items()}
        forms = self._residual_terms(tests)
        return [forms[n] for n in self.names]

    def jacobians(self) -> list[list[ufl.Form | None]]:
        """Blocks ``J[i][j] = dF_i/du_j`` (None where body j does not enter F_i).

        Diagonal blocks use each body's consistent tangent; contact, traction-free
        interface and coupling terms are differentiated by UFL.
        """
        tests = {n: ufl.TestFunction(b.V) for n, b in self.bodies.items()}
        trials = {n: ufl.TrialFunction(b.V) for n, b in self.bodies.items()}
        blocks: dict[tuple[str, str], ufl.Form] = {}

        def add(i: str, j: str, form) -> None:
            blocks[i, j] = form if (i, j) not in blocks else blocks[i, j] + form

        for name, body in self.bodies.items():
            add(name, name, body.jacobian(trials[name], tests[name]))
            for c in self.contacts:
                if c.contact.body == name:
                    add(name, name, ufl.derivative(c.residual(tests[name]), body.u,
                                                   trials[name]))
        for itf in self.interfaces:
            a, b = itf.spec.body, itf.spec.other
            r = dict(zip((a, b), itf.residuals(tests[a], tests[b]), strict=True))
            for i in (a, b):
                for j in (a, b):
                    add(i, j, ufl.derivative(r[i], self.bodies[j].u, trials[j]))
        return [[blocks.get((i, j)) for j in self.names] for i in self.names]

    def set_load(self, t: float) -> None:
        """Apply the loading programme at ``t`` (prescribed displacements, tool positions)."""
        self._t = t
        for b in self.bodies.values():
            b.load_increment = t - self._t_committed
            b.invalidate()
        self.dirichlet.set_load(t)
        for tr, const, _ds in self.tractions:
            const.value[:] = tr.value(t)
        for c in self.constraints:
            c.set_load(t)

    def commit(self) -> None:
        """Accept the converged state as history."""
        self._t_committed = self._t
        for b in self.bodies.values():
            if b.plastic is not None:
                b.plastic.commit()
            b.invalidate()
        for c in self.constraints:
            c.commit()

    def snapshot(self) -> dict:
        """Copy of the converged state (displacements, history, contact multipliers)."""
        return {
            "bodies": [(b.u.x.array.copy(),
                        None if b.plastic is None else b.plastic.snapshot())
                       for b in self.bodies.values()],
            "contacts": [c.snapshot() for c in self.constraints],
        }

    def restore(self, snap: dict) -> None:
        """Return to a snapshot."""
        for b, (u, hist) in zip(self.bodies.values(), snap["bodies"], strict=True):
            b.u.x.array[:] = u
            if hist is not None:
                b.plastic.restore(hist)
            b.invalidate()
        for c, cs in zip(self.constraints, snap["contacts"], strict=True):
            c.restore(cs)
