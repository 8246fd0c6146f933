"""Settings of the solvers, validated when built.

:class:`NewtonOptions` for the implicit solver (:mod:`forming.solver.implicit`),
:class:`ExplicitOptions` for the explicit one (:mod:`forming.solver.explicit`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Literal

from forming.errors import InputError

LINEAR_SOLVERS = ("auto", "mumps", "mumps_blr", "gamg")
# ``auto`` takes MUMPS with block low-rank compression from this many unknowns on. The
# scaling study (docs/performance.md, sandwich under the hemisphere, serial): its linear
# solve took 1.06 of the plain LU's time at 9,747 unknowns, 0.87 at 53,391, 0.45 at 212,097
BLR_FROM_UNKNOWNS = 50_000
# ``zeros="auto"`` drops a several-body Jacobian's exact zeros below this many unknowns.
# The sandwich under the hemisphere (docs/performance.md): at 53,391 unknowns (serial)
# dropping them made each Newton iteration's assembly 4.3 times slower (new non-zeros
# allocated inside the assembly as contact spreads) and the linear solve no faster; at
# 11,907 (the default mesh, 2 ranks) the run was 8% faster with them dropped, at 9,747
# (serial) level within the machine's noise; on small sandwiches (8,8,2) the assembly
# 1.6 times faster
DROP_ZEROS_BELOW = 20_000

# ``lu_precision="auto"`` factorises in single precision from this many unknowns on.
# benchmarks/lu_precision.py (docs/performance.md): 1.10-1.11 times as fast on the 20,20,4
# hemisphere (6,615 unknowns), 1.26 at 9,747, 1.38 at 53,391 (serial, the same Newton
# iterations); level at 2,028 (12,12,3), the size of the test suite's models, which keep
# the double LU
SINGLE_FROM_UNKNOWNS = 5_000


@dataclass(frozen=True)
class NewtonOptions:
    """Newton and linear-solver settings.

    Attributes:
        linear_solver: ``"auto"`` (default: ``"mumps"`` below :data:`BLR_FROM_UNKNOWNS`
            unknowns, ``"mumps_blr"`` from there, the crossing of the scaling study),
            ``"mumps"`` (direct LU), ``"mumps_blr"`` (MUMPS with
            block low-rank compression at ``blr_tolerance``, a cheaper and approximate
            LU, as the preconditioner of right-preconditioned GMRES to ``ksp_rtol``
            1e-10, with the exact LU where 30 iterations do not reach it; for large
            models: docs/performance.md) or ``"gamg"`` (GMRES +
            smoothed aggregation AMG with the model's rigid-body modes as near-null
            space, one body or several: :mod:`.linear`).
        blr_tolerance: ``mumps_blr``: MUMPS's dropping parameter CNTL(7), the relative
            accuracy of the compressed blocks; larger is cheaper per factorisation and
            costs more GMRES iterations.
        lu_precision: The precision MUMPS factorises in (``mumps`` and ``mumps_blr``):
            ``"double"``, or ``"single"``, each solve then refined in double precision
            on the true residual to 1e-10 (Richardson; FGMRES with compression), with
            the exact LU (plain, double) of the same matrix where refinement does not
            converge (in 10 iterations; 30 with compression)
            (:class:`~forming.solver.linear.RefinedLU`). The same Newton
            step to the linear tolerance; the factorisation and refinement cost 0.53-0.77
            of the double LU's time (docs/performance.md). ``"auto"`` (default): single
            from :data:`SINGLE_FROM_UNKNOWNS` unknowns on, double below. PETSc options of
            an approximate LU's solvers take the prefixes ``<prefix>approx_`` and
            ``<prefix>exact_`` (``-forming_approx_mat_mumps_icntl_8 0``).
        rtol: Residual reduction relative to the first residual of a step.
        atol: Absolute residual norm [N].
        force_rtol: Newton also stops when the residual norm is below this fraction of
            the force scale of the last converged step (largest reaction or tool force).
            It ends the slow tail that stick-slip switching of unloaded contact nodes
            causes. (Abaqus/Standard's default compares the largest nodal residual with
            5e-3 of the time-averaged nodal force, which is far below a tool's total
            force: the two numbers are not comparable as they stand.) 0 switches it off.
        max_it: Newton iterations before a step counts as failed.
        stall: Newton also gives a step up (to be cut back) once its residual has fallen
            by less than a tenth over the last ``stall`` iterations; 0 (default): only
            at ``max_it``. The backtracking line search can hold a residual constant for
            twenty iterations where the crushing core softens: on ``core_crushing`` 5
            saves 31% of the iterations, on another path (docs/performance.md). The
            window starts again where the contact multipliers change the residual.
        line_search: ``"basic"`` (full Newton step), ``"bt"`` (backtracking) or ``"l2"``
            (PETSc's secant minimisation of the residual norm along the Newton step).
        predictor: ``"extrapolate"`` (linear in the load parameter) or ``"previous"``.
        multipliers: How the contact multipliers converge. ``"newton"`` (default): inside
            the one Newton solve of a step, updated whenever the residual is within its
            tolerance but the constraints are not, which ends when both hold.
            ``"uzawa"``: a Newton solve per multiplier update (the first wave's outer
            loop, kept for comparison).
        max_augmentations: Multiplier updates per step before the step counts as failed.
        spring_escalation: When a step is cut below ``steps.min``, the interfaces'
            stabilising springs (``stabilisation`` of an interface or sliding pair) are
            stiffened by this factor and the step retried at the last accepted size, as
            Abaqus/Standard's adaptive stabilisation raises its damping where increments
            fail (:mod:`forming.springs`); 1 switches it off. A run that never stops is
            not touched.
        spring_escalation_max: The springs are stiffened to at most this many times
            their setting.
        spring_escalation_hold: Accepted steps after which a stiffened spring steps back
            down by one factor.
        spring_release: Once a step has converged, Newton solves it again from there
            with the stabilising springs at this fraction of what it converged with, and
            the step keeps that answer if the solve converges (its first otherwise);
            less of the springs' drag in the answer, at the cost of the second solve
            (:class:`~forming.springs.SpringRelease`). 1 (default): no second solve. The
            step size follows the first solve's iterations.
        zeros: The exact zeros of a several-body Jacobian: ``"drop"`` inserts none, so
            the matrix keeps only entries that were ever non-zero (an interface's facet
            forms fill their element matrices mostly with zeros), or ``"keep"``, the
            full pattern of the forms; ``"auto"`` (default) drops them below
            :data:`DROP_ZEROS_BELOW` unknowns and keeps them from there. The same
            solution to round-off. Dropped zeros make a smaller matrix, but an entry that
            becomes non-zero later (contact spreading) is a new allocation in the
            assembly, whose cost grows with the matrix (docs/performance.md).
        jacobian: How a body's own tangent enters the Jacobian: ``"compiled"``, its
            element matrices computed in one compiled loop and summed into the matrix by
            coordinate assembly (:mod:`forming.solver.tangents`; a one-body model of
            trilinear hexahedra without sliding contact), or ``"forms"``, assembled
            from its UFL form by DOLFINx; ``"auto"`` (default) takes ``"compiled"``
            where it applies. The same matrix to round-off; on the 20,20,4 hemisphere
            the assembly per Newton iteration is 2.2-2.4 times faster (docs/performance.md).
        petsc: Extra PETSc options for the SNES prefix, overriding the defaults; the
            command line (``-forming_<key> value``) overrides both.
    """

    linear_solver: Literal["auto", "mumps", "mumps_blr", "gamg"] = "auto"
    blr_tolerance: float = 1e-4
    lu_precision: Literal["auto", "double", "single"] = "auto"
    rtol: float = 1e-9
    atol: float = 1e-8
    force_rtol: float = 1e-4
    max_it: int = 25
    stall: int = 0
    line_search: Literal["basic", "bt", "l2"] = "basic"
    predictor: Literal["extrapolate", "previous"] = "extrapolate"
    multipliers: Literal["newton", "uzawa"] = "newton"
    max_augmentations: int = 25
    spring_escalation: float = 10.0
    spring_escalation_max: float = 100.0
    spring_escalation_hold: int = 10
    spring_release: float = 1.0
    zeros: Literal["auto", "drop", "keep"] = "auto"
    jacobian: Literal["auto", "compiled", "forms"] = "auto"
    petsc: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.linear_solver not in LINEAR_SOLVERS:
            raise InputError("solver.linear_solver", f"must be one of {list(LINEAR_SOLVERS)}"
                             f", got {self.linear_solver!r}")
        if not 0.0 < self.blr_tolerance < 1.0:
            raise InputError("solver.blr_tolerance", f"must be in (0, 1), got "
                             f"{self.blr_tolerance}")
        if self.lu_precision not in ("auto", "double", "single"):
            raise InputError("newton.lu_precision", f"must be 'auto', 'double' or 'single', "
                             f"got {self.lu_precision!r}")
        if self.line_search not in ("basic", "bt", "l2"):
            raise InputError("solver.line_search", f"must be 'basic', 'bt' or 'l2', got "
                             f"{self.line_search!r}")
        if self.predictor not in ("extrapolate", "previous"):
            raise InputError("solver.predictor", f"must be 'extrapolate' or 'previous', got "
                             f"{self.predictor!r}")
        if self.multipliers not in ("newton", "uzawa"):
            raise InputError("solver.multipliers", f"must be 'newton' or 'uzawa', got "
                             f"{self.multipliers!r}")
        if self.zeros not in ("auto", "drop", "keep"):
            raise InputError("newton.zeros",
                             f"must be 'auto', 'drop' or 'keep', got {self.zeros!r}")
        if self.jacobian not in ("auto", "compiled", "forms"):
            raise InputError("newton.jacobian", f"must be 'auto', 'compiled' or 'forms', "
                             f"got {self.jacobian!r}")
        if not self.force_rtol >= 0.0:
            raise InputError("solver.force_rtol", f"must be >= 0, got {self.force_rtol}")
        if self.max_it < 1:
            raise InputError("solver.max_it", f"must be >= 1, got {self.max_it}")
        if self.stall < 0:
            raise InputError("newton.stall", f"must be >= 0, got {self.stall}")
        for name in ("spring_escalation", "spring_escalation_max"):
            if not (math.isfinite(v := getattr(self, name)) and v >= 1.0):
                raise InputError(f"newton.{name}", f"must be a number >= 1, got {v!r}")
        if self.spring_escalation_hold < 1:
            raise InputError("newton.spring_escalation_hold",
                             f"must be >= 1, got {self.spring_escalation_hold}")
        if not 0.0 < self.spring_release <= 1.0:
            raise InputError("newton.spring_release",
                             f"must be in (0, 1], got {self.spring_release!r}")

    def for_size(self, unknowns: int) -> NewtonOptions:
        """These settings with every ``auto`` (solver, zeros, precision) chosen for ``unknowns``."""
        chosen = self
        if self.linear_solver == "auto":
            chosen = replace(chosen, linear_solver="mumps_blr"
                             if unknowns >= BLR_FROM_UNKNOWNS else "mumps")
        if self.zeros == "auto":
            chosen = replace(chosen, zeros="drop" if unknowns < DROP_ZEROS_BELOW else "keep")
        if self.lu_precision == "auto":
            chosen = replace(chosen, lu_precision="single" if unknowns >= SINGLE_FROM_UNKNOWNS
                             and chosen.linear_solver != "gamg" else "double")
        return chosen

    def petsc_options(self) -> dict[str, str]:
        """The SNES/KSP options these settings stand for (``auto`` not chosen: MUMPS)."""
        opts: dict[str, str] = {
            "snes_type": "newtonls",
            "snes_linesearch_type": self.line_search,
            "snes_rtol": str(self.rtol),
            "snes_atol": str(self.atol),
            "snes_stol": "0",
            "snes_max_it": str(self.max_it),
            "snes_max_funcs": "100000",
            # Dirichlet rows of the residual are in mm, the others in N: no divergence test
            "snes_divergence_tolerance": "-1",
        }
        if self.linear_solver in ("auto", "mumps", "mumps_blr"):
            opts |= self._lu_options()
        else:
            # GMRES: the foam's non-associated flow makes the tangent unsymmetric. Restarted
            # every 30 iterations (PETSc's default) it stalled on skin_sled's 0.6 mm step
            # (1000 iterations, a cut step); every 60 it converges there in 248 and the
            # sandwich hemisphere's solves are 17% faster (docs/performance.md)
            opts |= {"ksp_type": "gmres", "ksp_gmres_restart": "60", "pc_type": "gamg",
                     "ksp_rtol": "1e-10", "ksp_max_it": "1000", "pc_gamg_threshold": "0.01",
                     "mg_levels_ksp_type": "chebyshev", "mg_levels_pc_type": "jacobi"}
        return opts | dict(self.petsc)

    def _lu_options(self) -> dict[str, str]:
        """The KSP and PC options of the MUMPS solvers (``auto`` not chosen: plain, double).

        The plain LU in double precision is exact: one solve. An approximate one
        (single precision, compressed, or both) is refined on the true residual to
        1e-10, with the exact LU to fall back on (:class:`~forming.solver.linear.RefinedLU`).
        """
        # MUMPS's own scaling stays: without it (ICNTL(8) = 0) the hemisphere's
        # factorisation was 10% faster on the same path, but core_crushing took 3042
        # Newton iterations against 1809 (docs/performance.md)
        exact = {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"}
        single, blr = self.lu_precision == "single", self.linear_solver == "mumps_blr"
        if not (single or blr):
            return exact
        approx = exact | {"ksp_rtol": "1e-10", "ksp_max_it": "30"}
        if blr:
            approx |= {"mat_mumps_icntl_35": "2", "mat_mumps_cntl_7": repr(self.blr_tolerance)}
        if single:  # (a preconditioner in single precision is not one linear map: FGMRES)
            approx |= {"pc_precision": "single"}
            approx |= {"ksp_type": "fgmres"} if blr else {
                "ksp_type": "richardson", "ksp_norm_type": "unpreconditioned",
                "ksp_max_it": "10"}
        else:  # the compressed LU in double precision: GMRES on the true residual
            approx |= {"ksp_type": "gmres", "ksp_pc_side": "right"}
        # the outer KSP only calls the inner ones: its own PC (ILU by default, set up
        # at every Newton iteration) would be work thrown away
        return {"ksp_type": "python", "ksp_python_type": "forming.solver.linear.RefinedLU",
                "pc_type": "none",
                **{f"approx_{k}": v for k, v in approx.items()},
                **{f"exact_{k}": v for k, v in exact.items()}}


@dataclass(frozen=True)
class ExplicitOptions:
    """Settings of the explicit solver.

    Attributes:
        loading_time: Duration of the load programme [s] (tool stroke and every
            prescribed displacement reach their end values at this time).
        amplitude: ``"smooth"`` (Abaqus' smooth step ``10x^3 - 15x^4 + 6x^5``: the tools
            start and stop at rest) or ``"linear"`` (constant velocity from the start).
        safety: Fraction of the stable time step used, in (0, 1].
        target_time_step: Mass scaling: nodes whose stable time step is smaller get
            mass added until it reaches this value [s] (reported as
            ``mass_added_fraction``); None: no mass scaling.
        damping: Mass-proportional damping coefficient alpha [1/s] (``a += -alpha v``).
        damped_bodies: The bodies the mass-proportional damping acts on (Abaqus defines
            Rayleigh damping per material); empty: every body. A body held in place
            (a core on its support) moves only as it deforms, so damping it leaves a
            quasi-static answer alone while it stops the body ringing; a body that
            travels (a skin dragged along) would be held back by it.
        fibre_damping: Fraction of critical damping of the fabric fibres' highest mode
            (stiffness-proportional viscosity along the fibres; the linear bulk viscosity
            of Abaqus/Explicit damps solids at 0.06 in the same way); lower modes are
            damped in proportion to their frequency. 0 compiles no damping term.
        contact_damping: Fraction of critical damping of each contact node's normal
            approach on its penalty spring, with the node's physical mass (tools,
            small- and finite-sliding interfaces; LS-DYNA's VDC, typically 10-20%): a
            viscous pressure ``-c dg/dt`` joins the penalty's while the node touches.
            Undamped, light skin nodes chatter on their penalty springs and lose their
            friction history at every opening. 0: none.
        friction_filter: Time constant [s] of a low-pass filter on the pressure that
            the friction of the small-sliding interfaces reads (their stick stiffness
            ``mu p / s_el`` and slip limit ``mu p``; with ``contact_damping`` > 0). A
            stick spring whose stiffness follows a ringing pressure is a parametric
            oscillator the ringing feeds (``sandwich_bending``, docs/validation.md);
            filtered, the friction lags a changing pressure by about this time. 0: the
            pressure of each increment.
        output_interval: Load-parameter interval between history rows; None: the job's
            largest load step, at most 0.02.
        bound_every: Load-parameter span between two Gershgorin bounds of the stable
            time step (each at the start of an output interval; 0: at every interval).
            In between the step only shrinks, as the stiffest solid element stiffens.
        quasi_static_limit: Largest kinetic over internal energy of a run that counts as
            quasi-static (5%, the usual guideline for Abaqus/Explicit forming).
        integration: Solids on hexahedra: ``"full"`` (2 x 2 x 2 points, as the implicit
            solver; default) or ``"reduced"`` (one point per element with
            Flanagan-Belytschko hourglass control, as Abaqus' C3D8R: about 5 times
            cheaper, but on the shipped meshes its crushing and bending depart from the
            implicit answers, docs/validation.md) or ``"thickness"`` (one point in plane,
            two through the thickness, as an in-plane reduced solid-shell; the
            hourglass control takes the two modes they miss: the gradient of crushing
            and bending through the core is kept) or ``"adaptive"`` (thickness
            integration where the core does not crush unevenly, full integration for
            good in each element that does: ``adaptive_strain``;
            :mod:`forming.bodies.hexadaptive`). Fabric skins use their forms.
        hourglass: Hourglass stiffness coefficient kappa of reduced integration
            (``k = kappa M V |b|^2 / 3`` per element, docs/theory.md section 12).
        hourglass_plastic: Smallest fraction of its elastic hourglass stiffness a
            reduced-integration element keeps while it flows plastically (its tangent
            ratio is floored here): lower follows crushing more closely, higher keeps
            crushing elements from inverting (docs/theory.md section 12).
        hourglass_limit: Hourglass over internal energy above which a run is flagged.
        distortion_control: Corner determinant ratio (current over reference) below
            which a reduced or thickness element is held from folding by a penalty, as
            Abaqus/Explicit's distortion control (docs/theory.md section 12); its energy
            counts with the hourglass energy. 0.1 by default; 0: off. Fully integrated
            elements have none.
        adaptive_strain: Adaptive integration: an element moves to full integration when
            its most compressed corner has lost more than this share of its volume and
            its corners' volume ratios differ by more than it (docs/theory.md,
            section 12).
    """

    loading_time: float = 0.05
    amplitude: Literal["smooth", "linear"] = "smooth"
    safety: float = 0.9
    target_time_step: float | None = None
    damping: float = 0.0
    damped_bodies: tuple[str, ...] = ()
    fibre_damping: float = 0.06
    contact_damping: float = 0.2
    friction_filter: float = 0.0
    output_interval: float | None = None
    bound_every: float = 0.1
    quasi_static_limit: float = 0.05
    integration: Literal["full", "reduced", "thickness", "adaptive"] = "full"
    hourglass: float = 0.1
    hourglass_plastic: float = 0.3
    hourglass_limit: float = 0.05
    distortion_control: float = 0.1
    adaptive_strain: float = 0.005

    def __post_init__(self) -> None:
        if self.integration not in ("reduced", "full", "thickness", "adaptive"):
            raise InputError("explicit.integration", "must be 'full', 'reduced', "
                             f"'thickness' or 'adaptive', got {self.integration!r}")
        if not 0.0 < self.adaptive_strain < 1.0:
            raise InputError("explicit.adaptive_strain",
                             f"must lie in (0, 1), got {self.adaptive_strain!r}")
        if not (math.isfinite(self.hourglass) and self.hourglass >= 0):
            raise InputError("explicit.hourglass", f"must be >= 0, got {self.hourglass!r}")
        if not 0.0 <= self.hourglass_plastic <= 1.0:
            raise InputError("explicit.hourglass_plastic",
                             f"must lie in [0, 1], got {self.hourglass_plastic!r}")
        if not self.hourglass_limit > 0:
            raise InputError("explicit.hourglass_limit",
                             f"must be > 0, got {self.hourglass_limit!r}")
        if not 0.0 <= self.distortion_control < 1.0:
            raise InputError("explicit.distortion_control",
                             f"must lie in [0, 1), got {self.distortion_control!r}")
        if not (math.isfinite(self.loading_time) and self.loading_time > 0):
            raise InputError("explicit.loading_time", f"must be > 0 s, got {self.loading_time!r}")
        if self.amplitude not in ("smooth", "linear"):
            raise InputError("explicit.amplitude",
                             f"must be 'smooth' or 'linear', got {self.amplitude!r}")
        if not 0 < self.safety <= 1:
            raise InputError("explicit.safety", f"must lie in (0, 1], got {self.safety!r}")
        dt = self.target_time_step
        if dt is not None and not (math.isfinite(dt) and dt > 0):
            raise InputError("explicit.target_time_step", f"must be > 0 s, got {dt!r}")
        if not (math.isfinite(self.damping) and self.damping >= 0):
            raise InputError("explicit.damping", f"must be >= 0, got {self.damping!r}")
        if not (math.isfinite(self.fibre_damping) and 0 <= self.fibre_damping < 1):
            raise InputError("explicit.fibre_damping",
                             f"must lie in [0, 1), got {self.fibre_damping!r}")
        if not (math.isfinite(self.contact_damping) and 0 <= self.contact_damping < 1):
            raise InputError("explicit.contact_damping",
                             f"must lie in [0, 1), got {self.contact_damping!r}")
        if not (math.isfinite(self.friction_filter) and self.friction_filter >= 0):
            raise InputError("explicit.friction_filter",
                             f"must be >= 0 s, got {self.friction_filter!r}")
        if self.friction_filter > 0 and self.contact_damping == 0:
            raise InputError("explicit.friction_filter", "filters the damped interfaces' "
                             "friction: it needs explicit.contact_damping > 0 (it is 0)")
        if not (math.isfinite(self.bound_every) and 0 <= self.bound_every <= 1):
            raise InputError("explicit.bound_every",
                             f"must lie in [0, 1], got {self.bound_every!r}")
        iv = self.output_interval
        if iv is not None and not 0 < iv <= 1:
            raise InputError("explicit.output_interval", f"must lie in (0, 1], got {iv!r}")
        if not self.quasi_static_limit > 0:
            raise InputError("explicit.quasi_static_limit",
                             f"must be > 0, got {self.quasi_static_limit!r}")

    def load(self, tau: float) -> float:
        """Load parameter at time ``tau`` [s]."""
        x = min(max(tau / self.loading_time, 0.0), 1.0)
        if self.amplitude == "linear":
            return x
        return x**3 * (10.0 - 15.0 * x + 6.0 * x * x)

    def time_of(self, s: float) -> float:
        """Time at which the load parameter reaches ``s`` (inverse of :meth:`load`)."""
        if s >= 1.0:
            return self.loading_time
        if self.amplitude == "linear":
            return s * self.loading_time
        lo, hi = 0.0, 1.0
        for _ in range(60):  # bisection: the smooth step is monotone on [0, 1]
            mid = 0.5 * (lo + hi)
            if self.load(mid * self.loading_time) < s:
                lo = mid
            else:
                hi = mid
        return 0.5 * (lo + hi) * self.loading_time
