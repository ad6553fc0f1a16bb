"""Recipes and plans: how a method becomes a stage table for one scene, state and step.

A :class:`Recipe` is the data part of a method that knows how to build one step of
it as a list of :class:`Stage` records for a given scene, initial momentum ``m0``
and step ``h``; :func:`compile_plan` turns the list into the arrays the driver runs
(:class:`Plan`). Recipes never look at method or scene names: they read the scene's
:class:`~liebody.scenes.Capabilities`, body and torque model.

The recipes:

* :class:`AxisSplitting` — the symmetric 5-rotation splitting of ``T`` into exact axis
  sub-flows (McLachlan 1993; Reich 1994; Dullweber, Leimkuhler & McLachlan 1997),
  with the axis ordering chosen per orbit (:mod:`liebody._ordering`) or fixed;
* :class:`SR2Splitting` — symmetric body + one rotation (Touma & Wisdom 1994;
  Hairer & Vilmart 2006);
* :class:`BestSplitting` — whichever of the two keeps the energy better on the orbit;
* :class:`DMVFlow` — the discrete Moser–Veselov step (RATTLE on SO(3)), preprocessed
  to order 4–10 by Hairer & Vilmart's modified moments;
* :class:`ExactFlow` — the exact free-body flow;
* :class:`Composition` — a symmetric composition of any base recipe;
* :class:`Baseline` — a classical one-stage method (explicit Euler, RK4, ...).

The free-flow recipes (the first five) integrate a free body as they are and a
torqued or damped scene as ``side(h/2) drift(h) side(h/2)``: the scene's torque kick
or dissipation step around the recipe's free flow (:func:`scene_step`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from liebody import _ordering
from liebody._kernels import stages as S

__all__ = ["AxisSplitting", "Baseline", "BestSplitting", "Composition", "DMVFlow",
           "ExactFlow", "Plan", "Recipe", "SR2Splitting", "Stage", "compile_plan", "compose"]


# ----------------------------------------------------------------------------------------
# stages
# ----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Stage:
    """One stage of a step: a map of ``kinds`` run for ``coef * h``.

    Attributes
    ----------
    kind
        A stage kind code of :mod:`liebody._kernels.stages`.
    coef
        Fraction of the step ``h`` the stage runs for (negative in some compositions).
    clock
        Fraction of ``h`` the clock advances by after the stage.
    axis
        Body axis of an axis rotation.
    rate
        Rate of a rotation (``rate * m_k^2 / 2`` or ``rate * |m|^2 / 2``).
    moments
        Principal moments (DMV, exact flow, dissipation, baselines).
    torque, c
        Torque code and constants (kicks, baselines).
    eps
        Dissipation strength (dissipation, baselines).
    """

    kind: int
    coef: float
    clock: float = 0.0
    axis: int = 0
    rate: float = 0.0
    moments: tuple[float, float, float] = (0.0, 0.0, 0.0)
    torque: int = S.TORQUE_NONE
    c: tuple[float, float, float] = (0.0, 0.0, 0.0)
    eps: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in S.KINDS:
            raise ValueError(f"unknown stage kind {self.kind!r}; known: {sorted(S.KINDS)}")
        if self.axis not in (0, 1, 2):
            raise ValueError(f"stage axis must be 0, 1 or 2, got {self.axis!r}")

    def row(self) -> list[float]:
        """The parameter row (the named slots of :mod:`~liebody._kernels.stages`)."""
        p = [0.0] * S.N_PARAMS
        p[S.P_I1], p[S.P_I2], p[S.P_I3] = (float(v) for v in self.moments)
        p[S.P_RATE] = float(self.rate)
        p[S.P_TORQUE] = float(self.torque)
        p[S.P_C1], p[S.P_C2], p[S.P_C3] = (float(v) for v in self.c)
        p[S.P_EPS] = float(self.eps)
        return p

    def scaled(self, g: float) -> Stage:
        """The stage run for ``g`` times as long (its clock advance scaled alike)."""
        return replace(self, coef=self.coef * g, clock=self.clock * g)

    def same_flow(self, other: Stage) -> bool:
        """Whether ``other`` is a flow of the same Hamiltonian (so the two may be merged)."""
        return (S.KINDS[self.kind].mergeable and other.kind == self.kind
                and other.axis == self.axis and other.row() == self.row())

    @property
    def identity(self) -> bool:
        """A stage that does nothing: zero time, or a rotation at zero rate."""
        return self.coef == 0.0 or (S.KINDS[self.kind].rotation and self.rate == 0.0)


def rotation(axis: int, coef: float, rate: float, recurring: bool = False,
             clock: float = 0.0) -> Stage:
    """Exact flow of ``rate * m_axis^2 / 2``; ``recurring`` when ``m_axis`` is constant."""
    return Stage(S.AXIS_RECURRING if recurring else S.AXIS, coef, clock, axis=axis, rate=rate)


def sphere(coef: float, rate: float, clock: float = 0.0) -> Stage:
    """Exact flow of ``rate * |m|^2 / 2``."""
    return Stage(S.SPHERE, coef, clock, rate=rate)


# ----------------------------------------------------------------------------------------
# plans
# ----------------------------------------------------------------------------------------


@dataclass
class Plan:
    """A method made concrete for one scene, initial state and step: a stage table.

    ``family`` is the driver family (``stages.F_*``) that runs it; ``info`` records the
    set-up choices (axis ordering, base of a composition, ...), shown as
    ``Trajectory.info``.
    """

    kinds: np.ndarray
    axes: np.ndarray
    coefs: np.ndarray
    clock: np.ndarray
    params: np.ndarray
    merge_ends: bool
    family: int
    info: dict = field(default_factory=dict)

    @property
    def n_stages(self) -> int:
        return int(self.kinds.shape[0])


def compile_plan(stages: list[Stage], info: dict | None = None) -> Plan:
    """Build a :class:`Plan`: drop identity stages, merge adjacent flows of one Hamiltonian."""
    merged: list[Stage] = []
    for st in stages:
        if st.identity:
            continue  # e.g. the R rotation of SR2 on a symmetric body
        if merged and merged[-1].same_flow(st):
            both = replace(merged[-1], coef=merged[-1].coef + st.coef,
                           clock=merged[-1].clock + st.clock)
            merged.pop()
            if both.coef != 0.0 or both.clock != 0.0:
                merged.append(both)
            continue
        merged.append(st)
    if not merged:  # a flow that does nothing (e.g. every rate zero)
        merged = [sphere(1.0, 0.0, clock=1.0)]
    first, last = merged[0], merged[-1]
    kinds = np.array([s.kind for s in merged], dtype=np.int64)
    return Plan(
        kinds=kinds,
        axes=np.array([s.axis for s in merged], dtype=np.int64),
        coefs=np.array([s.coef for s in merged], dtype=np.float64),
        clock=np.array([s.clock for s in merged], dtype=np.float64),
        params=np.array([s.row() for s in merged], dtype=np.float64).reshape(-1, S.N_PARAMS),
        merge_ends=len(merged) > 1 and first.same_flow(last),
        family=S.family_of(kinds),
        info=dict(info or {}),
    )


def compose(base: list[Stage], coefficients) -> list[Stage]:
    """Stages of the composition ``S(g_s h) ... S(g_1 h)`` of a base step (``g_1`` first)."""
    return [st.scaled(g) for g in coefficients for st in base]


# ----------------------------------------------------------------------------------------
# the free-body pieces
# ----------------------------------------------------------------------------------------


def _moments(body) -> tuple[float, float, float]:
    return tuple(float(v) for v in body.moments)


def _recurring(body, k: int) -> bool:
    """``m_k`` is a constant of the free motion: ``k`` is the symmetry axis (or a sphere)."""
    return body.is_spherical or body.symmetry_axis == k


def axis_stages(body, ordering) -> list[Stage]:
    """``a(h/2) b(h/2) c(h) b(h/2) a(h/2)``: the 5-rotation splitting in ``ordering``."""
    a, b, c = ordering
    I = _moments(body)

    def rot(k, coef, clock=0.0):
        return rotation(k, coef, 1.0 / I[k], _recurring(body, k), clock)

    return [rot(a, 0.5), rot(b, 0.5), rot(c, 1.0, clock=1.0), rot(b, 0.5), rot(a, 0.5)]


def sr2_stages(body, variant) -> list[Stage]:
    """``R(h/2) S(h) R(h/2)`` with ``S`` the exact flow of a symmetric body (two stages)."""
    a, b, c = variant
    I = _moments(body)
    rate_r, rate_c = _ordering.sr2_rates(I, variant)
    return [rotation(b, 0.5, rate_r, _recurring(body, b)),
            sphere(1.0, 1.0 / I[a], clock=1.0),
            rotation(c, 1.0, rate_c, _recurring(body, c)),
            rotation(b, 0.5, rate_r, _recurring(body, b))]


def symmetric_flow_stages(body) -> tuple[list[Stage], str] | None:
    """The exact flow of a spherical or symmetric body (trig only), or ``None``.

    A symmetric body (symmetry axis ``s``, transverse moment ``I_perp``) flows as a
    sphere rotation at rate ``1/I_perp`` and a rotation about ``e_s`` at rate
    ``1/I_s - 1/I_perp``; the two commute, so this is exact.
    """
    I = _moments(body)
    if body.is_spherical:
        return [sphere(1.0, 3.0 / sum(I), clock=1.0)], "sphere"
    s = body.symmetry_axis
    if s is None:
        return None
    i_perp = 0.5 * (I[(s + 1) % 3] + I[(s + 2) % 3])
    return [sphere(1.0, 1.0 / i_perp, clock=1.0),
            rotation(s, 1.0, 1.0 / I[s] - 1.0 / i_perp, recurring=True)], "symmetric"


def exact_stage(body) -> Stage:
    return Stage(S.EXACT, 1.0, 1.0, moments=_moments(body))


def scene_free_flow(scene, m0, ordering=None) -> tuple[list[Stage], dict]:
    """The free flow a splitting uses as its drift between kicks on ``scene``.

    A spherical or symmetric body gets its exact flow (trig functions only), unless
    the scene asks for ``free_flow="axes"``; otherwise ``free_flow="exact"`` gives the
    elliptic exact flow and ``"auto"``/``"axes"`` the 5-rotation axis splitting (the
    ordering given, or the best for the orbit of ``m0``).
    """
    body = scene.body
    sym = symmetric_flow_stages(body)
    if sym is not None and (scene.free_flow != "axes" or body.is_spherical):
        stages, kind = sym
        return stages, {"free_flow": kind}
    if scene.free_flow == "exact":
        return [exact_stage(body)], {"free_flow": "elliptic"}
    if ordering is None:
        ordering, _ = _ordering.best_axis_ordering(body.moments, m0)
    return axis_stages(body, ordering), {"free_flow": f"axes {tuple(ordering)}"}


def scene_step(scene, drift: list[Stage], info: dict) -> tuple[list[Stage], dict]:
    """``side(h/2) drift(h) side(h/2)`` with the scene's torque kick or dissipation step.

    An orientation-only torque gets exact kicks on both sides (merged between steps);
    a torque that depends on the momentum closes the step with the adjoint (implicit)
    kick, so the step stays symmetric; dissipation gets its second-order step ``D``.
    """
    caps = scene.capabilities
    info = dict(info)
    if caps.dissipative:
        side = Stage(S.DAMP, 0.5, moments=_moments(scene.body), eps=float(scene.dissipation))
        return [side, *drift, side], info
    model = scene.torque_model()
    kick = Stage(S.KICK, 0.5, torque=model.code, c=model.constants)
    closing = kick
    if "momentum" in caps.torque:
        closing = replace(kick, kind=S.KICK_IMPLICIT)
        info["kicks"] = "explicit/implicit (L-dependent torque)"
    return [kick, *drift, closing], info


# ----------------------------------------------------------------------------------------
# recipes
# ----------------------------------------------------------------------------------------


class Recipe:
    """How a method builds one step: ``stages(scene, m0, h) -> (stages, info)``."""

    #: composition coefficients applied to the base (``(1.0,)`` for a base method)
    coefficients: tuple[float, ...] = (1.0,)

    def stages(self, scene, m0, h: float) -> tuple[list[Stage], dict]:  # pragma: no cover
        raise NotImplementedError


class FreeFlowRecipe(Recipe):
    """A free-body flow; on a torqued or damped scene, the drift of ``side-drift-side``.

    Subclasses give :meth:`free` (the method on a free body) and may override
    :meth:`drift` (the free flow between kicks; by default the same).
    """

    def free(self, scene, m0, h: float) -> tuple[list[Stage], dict]:  # pragma: no cover
        raise NotImplementedError

    def drift(self, scene, m0, h: float) -> tuple[list[Stage], dict]:
        return self.free(scene, m0, h)

    def stages(self, scene, m0, h: float) -> tuple[list[Stage], dict]:
        if scene.capabilities.free:
            return self.free(scene, m0, h)
        return scene_step(scene, *self.drift(scene, m0, h))


@dataclass(frozen=True)
class AxisSplitting(FreeFlowRecipe):
    """The 5-rotation splitting ``a(h/2) b(h/2) c(h) b(h/2) a(h/2)``, order 2.

    ``ordering=None`` chooses the ordering whose ``h^2`` energy-error term varies least
    over the orbit (Fassò 2003); a fixed ``(a, b, c)`` is used as given. On torqued
    scenes the drift is :func:`scene_free_flow`.
    """

    ordering: tuple[int, int, int] | None = None

    def __post_init__(self) -> None:
        if self.ordering is not None and sorted(self.ordering) != [0, 1, 2]:
            raise ValueError(f"ordering must be a permutation of (0, 1, 2), got {self.ordering}")

    def _ordering(self, scene, m0) -> tuple[tuple[int, int, int], dict]:
        if self.ordering is not None:
            return tuple(self.ordering), {"axis_ordering": tuple(self.ordering)}
        order, score = _ordering.best_axis_ordering(scene.moments, m0)
        return order, {"axis_ordering": order, "energy_error_constant": score}

    def free(self, scene, m0, h):
        order, info = self._ordering(scene, m0)
        return axis_stages(scene.body, order), info

    def drift(self, scene, m0, h):
        return scene_free_flow(scene, m0, self.ordering)


@dataclass(frozen=True)
class SR2Splitting(FreeFlowRecipe):
    """``R(h/2) S(h) R(h/2)``: exact symmetric-body flow ``S`` plus one axis rotation ``R``.

    Order 2; exact for a symmetric body. The variant is chosen per orbit like the axis
    ordering. Free bodies only (its drift is not defined between kicks).
    """

    def free(self, scene, m0, h):
        variant, score = _ordering.best_sr2_variant(scene.moments, m0)
        return sr2_stages(scene.body, variant), {"sr2_variant": variant,
                                                  "energy_error_constant": score}

    def drift(self, scene, m0, h):
        raise ValueError("SR2 has no drift between kicks: it integrates free bodies only")


@dataclass(frozen=True)
class BestSplitting(FreeFlowRecipe):
    """The better second-order base for the orbit: :class:`AxisSplitting` or :class:`SR2Splitting`.

    On torqued scenes the axis splitting's drift (:func:`scene_free_flow`).
    """

    def free(self, scene, m0, h):
        order, s_axis = _ordering.best_axis_ordering(scene.moments, m0)
        variant, s_sr2 = _ordering.best_sr2_variant(scene.moments, m0)
        if s_sr2 <= s_axis:
            return sr2_stages(scene.body, variant), {
                "base": "sr2", "sr2_variant": variant, "energy_error_constant": s_sr2}
        return axis_stages(scene.body, order), {
            "base": "splitting2", "axis_ordering": order, "energy_error_constant": s_axis}

    def drift(self, scene, m0, h):
        return scene_free_flow(scene, m0)


@dataclass(frozen=True)
class DMVFlow(FreeFlowRecipe):
    """The discrete Moser–Veselov step (RATTLE on SO(3)) of order 2, or preprocessed.

    ``order = 2``: the DMV step with the body's moments (Moser & Veselov 1991). Orders
    4, 6, 8, 10: the same step with Hairer & Vilmart's modified moments, which depend on
    ``h`` and the invariants of ``m0`` only (free bodies only).
    """

    order: int = 2

    def __post_init__(self) -> None:
        if self.order not in (2, 4, 6, 8, 10):
            raise ValueError(f"DMV order must be 2, 4, 6, 8 or 10, got {self.order}")

    def free(self, scene, m0, h):
        if self.order == 2:
            return [Stage(S.DMV, 1.0, 1.0, moments=_moments(scene.body))], {}
        mod = dmv_modified_moments(scene.moments, m0, h, self.order)
        if not all(np.isfinite(v) and v > 0.0 for v in mod):
            raise ValueError(
                f"dt = {h:g} is too large for preprocessed DMV of order {self.order}: its "
                f"modified moments {tuple(round(v, 6) for v in mod)} are not all positive "
                f"(the h^2 and h^4 corrections of Hairer-Vilmart's series dominate); "
                f"reduce dt")
        return [Stage(S.DMV, 1.0, 1.0, moments=mod)], {"modified_moments": mod}

    def drift(self, scene, m0, h):
        if self.order != 2:
            raise ValueError("preprocessed DMV integrates free bodies only")
        return [Stage(S.DMV, 1.0, 1.0, moments=_moments(scene.body))], {"free_flow": "dmv"}


@dataclass(frozen=True)
class ExactFlow(FreeFlowRecipe):
    """The exact free-body flow as one stage (elliptic functions; trig when symmetric)."""

    def free(self, scene, m0, h):
        return [exact_stage(scene.body)], {}


@dataclass(frozen=True)
class Composition(Recipe):
    """A symmetric composition ``S(g_s h) ... S(g_1 h)`` of a second-order base recipe.

    ``coefficients`` are the full list of fractions ``g_i`` of the step given to the
    base, in order (palindromic; ``sum g = 1``).
    """

    base: Recipe
    coefficients: tuple[float, ...]

    def stages(self, scene, m0, h):
        base, info = self.base.stages(scene, m0, h)
        return compose(base, self.coefficients), info


@dataclass(frozen=True)
class Baseline(Recipe):
    """A classical one-stage method on ``(q, L)``: torque and dissipation inside the stage."""

    kind: int

    def __post_init__(self) -> None:
        if self.kind not in (S.EULER, S.RK4, S.LIE_EULER, S.RKMK4):
            raise ValueError(f"not a baseline stage kind: {self.kind!r}")

    def stages(self, scene, m0, h):
        model = scene.torque_model()
        return [Stage(self.kind, 1.0, 1.0, moments=_moments(scene.body), torque=model.code,
                      c=model.constants, eps=float(scene.dissipation))], {}


# ----------------------------------------------------------------------------------------
# Hairer-Vilmart modified moments
# ----------------------------------------------------------------------------------------


def dmv_modified_moments(moments, m0, h: float, order: int) -> tuple[float, float, float]:
    """Hairer–Vilmart modified moments ``1/I_i^mod = CSS / I_i + CDD``.

    ``CSS = 1 + sum_k s_k(N, H)`` and ``CDD = sum_k d_k(N, H)``, with homogeneous
    polynomials of degree ``k = 1 .. order/2 - 1`` in ``N = h^2 |m|^2 / 2`` and
    ``H = h^2 sum m_i^2 / (2 I_i)`` whose coefficients are the rational functions of the
    moments of Hairer & Vilmart (J. Phys. A 39 (2006) 13225, Table 1, and their
    DMV10 routine for orders 8 and 10). They depend only on the invariants, so they
    are computed once per run.
    """
    I1, I2, I3 = (float(v) for v in moments)
    m = np.asarray(m0, dtype=float)
    N = 0.5 * h * h * float(m @ m)
    H = 0.5 * h * h * float(np.sum(m * m / np.array([I1, I2, I3])))
    det = I1 * I2 * I3
    det2, det3, det4 = det**2, det**3, det**4
    s1, s2, s3, s4 = (I1**k + I2**k + I3**k for k in (1, 2, 3, 4))
    i1, i2, i3, i4 = (I1**-k + I2**-k + I3**-k for k in (1, 2, 3, 4))

    def tau(b: int, c: int) -> float:
        """sum over i of (I_j^b + I_k^b) / I_i^c (the paper's tau_{b,c})."""
        return ((I1**b + I2**b) / I3**c + (I2**b + I3**b) / I1**c
                + (I3**b + I1**b) / I2**c)

    t11, t12, t21, t13, t31, t22 = tau(1, 1), tau(1, 2), tau(2, 1), tau(1, 3), tau(3, 1), \
        tau(2, 2)
    # degree 1 (order 4)
    css = 1.0 + (s1 / (6.0 * det)) * N - (i1 / 3.0) * H
    cdd = -N / (3.0 * det) + (s1 / (6.0 * det)) * H
    if order >= 6:  # degree 2
        css += ((s2 / det - i1) / (30.0 * det) * N * N + (1.0 - t11) / (30.0 * det) * N * H
                + (3.0 * s1 / det + 2.0 * i2) / 60.0 * H * H)
        cdd += (-s1 / det2 / 60.0 * N * N + (i1 / det / 10.0 - s2 / det2 / 60.0) * N * H
                - (9.0 + t11) / det / 60.0 * H * H)
    if order >= 8:  # degree 3
        css += ((4.0 * det + 17.0 * s3 - 15.0 * det * t11) / (2520.0 * det3) * N**3
                + (9.0 * s1 + 10.0 * det * i2 - 6.0 * t21) / (420.0 * det2) * N * N * H
                + ((6.0 * t12 - 100.0 * i1) * det + 53.0 * s2) / (2520.0 * det2) * N * H * H
                + (15.0 - det * i3 - 2.0 * t11) / (630.0 * det) * H**3)
        cdd += ((34.0 * det * i1 - 19.0 * s2) / (2520.0 * det3) * N**3
                + (s3 + 2.0 * det * t11 - 85.0 * det) / (1260.0 * det3) * N * N * H
                + (47.0 * s1 + 13.0 * t21 - 38.0 * det * i2) / (2520.0 * det2) * N * H * H
                + (9.0 * det * i1 + det * t12 - 11.0 * s2) / (1260.0 * det2) * H**3)
    if order >= 10:  # degree 4
        css += ((62.0 * s4 - 94.0 * det * t21 + 66.0 * det2 * i2 + 81.0 * det * s1)
                / (45360.0 * det4) * N**4
                + (-77.0 * t31 + 75.0 * det * t12 + 214.0 * s2 - 240.0 * det * i1)
                / (22680.0 * det3) * N**3 * H
                + (26.0 * det * t22 + 55.0 * s3 + 204.0 * det - 50.0 * det2 * i3
                   - 59.0 * det * t11) / (7560.0 * det3) * N * N * H * H
                + (137.0 * det * i2 - det * t13 + 3.0 * s1 - 69.0 * t21)
                / (11340.0 * det2) * N * H**3
                + (2.0 * det2 * i4 + 5.0 * det * t12 - 171.0 * det * i1 + 159.0 * s2)
                / (45360.0 * det2) * H**4)
        cdd += ((60.0 * t11 * det - 61.0 * s3 - 247.0 * det) / (45360.0 * det4) * N**4
                + (54.0 * det * s1 - s4 + 218.0 * det * t21 - 426.0 * det2 * i2)
                / (45360.0 * det4) * N**3 * H
                + (125.0 * det * i1 - 5.0 * t31 - 130.0 * s2 + 4.0 * det * t12)
                / (7560.0 * det3) * N * N * H * H
                + (67.0 * s3 - 735.0 * det - 15.0 * det * t22 + 87.0 * det * t11
                   + 34.0 * det2 * i3) / (22680.0 * det3) * N * H**3
                + (165.0 * s1 - det * t13 - 9.0 * t21 - 145.0 * det * i2)
                / (45360.0 * det2) * H**4)
    return tuple(1.0 / (css / I + cdd) for I in (I1, I2, I3))
