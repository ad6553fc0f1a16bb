"""The method registry: methods are data.

Each method is a :class:`Method` record (name, family, order, geometric
properties, scenes it supports, cost per step) plus a recipe that turns it into a
*stage table* for a given body, initial state and step (see
:mod:`liebody._kernels.driver`). Compositions are a coefficient table applied to a
second-order base by one routine, :func:`compose`. :func:`methods` builds the public
table from the same records, so documentation and tests read one truth.

Literature: ``../shared/theory/integrators-literature.md`` sections 1–7, 11.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from liebody import _modified
from liebody._kernels import stages as _drv

__all__ = ["COMPOSITIONS", "Method", "MethodTable", "Plan", "compose", "get", "methods", "plan"]

# ----------------------------------------------------------------------------------------
# composition coefficients (palindromic, centre included once): literature section 6
# ----------------------------------------------------------------------------------------


def _palindrome(half: tuple[float, ...], centre: float) -> tuple[float, ...]:
    return (*half, centre, *reversed(half))


_SUZUKI_G = 1.0 / (4.0 - 4.0 ** (1.0 / 3.0))

#: name -> palindromic coefficients ``gamma_i`` of ``S(gamma_s h) ... S(gamma_1 h)``
COMPOSITIONS: dict[str, tuple[float, ...]] = {
    "strang": (1.0,),
    # Suzuki 1990, 5 stages, order 4
    "suzuki4": _palindrome((_SUZUKI_G, _SUZUKI_G), 1.0 - 4.0 * _SUZUKI_G),
    # Kahan & Li 1997 s9odr6, order 6
    "kahanli6": _palindrome(
        (0.39216144400731413928, 0.33259913678935943860, -0.70624617255763935981,
         0.08221359629355080023),
        0.79854399093482996340),
    # Kahan & Li 1997 s17odr8, order 8
    "kahanli8": _palindrome(
        (0.13020248308889008088, 0.56116298177510838456, -0.38947496264484728641,
         0.15884190655515560090, -0.39590389413323757734, 0.18453964097831570709,
         0.25837438768632204729, 0.29501172360931029887),
        -0.60550853383003451170),
}


# ----------------------------------------------------------------------------------------
# records
# ----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Method:
    """A registered integrator and its declared properties.

    Attributes
    ----------
    name
        Public name passed as ``integrate(..., method=name)``.
    family
        ``"splitting"``, ``"composition"``, ``"rattle"``, ``"exact"`` or ``"baseline"``.
    order
        Classical order (``math.inf`` for the exact flow).
    symplectic, reversible
        Symplectic (Lie–Poisson in ``L``) and time-reversible (symmetric). On torqued
        scenes these hold for conservative, orientation-only torques.
    keeps_casimir
        On a free body: keeps ``|L|`` (and, for every method that acts by rotations,
        spatial ``L``) to round-off.
    keeps_energy
        On a free body: keeps the energy to round-off.
    scenes
        Scene classes the method can integrate.
    cost
        Cost of one step in words (measured figures: ``bench/step_cost.py``).
    coefficients
        Composition coefficients applied to the base (``(1.0,)`` for a base method).
    """

    name: str
    family: str
    order: float
    symplectic: bool
    reversible: bool
    keeps_casimir: bool
    keeps_energy: bool
    scenes: tuple[str, ...]
    cost: str
    coefficients: tuple[float, ...] = (1.0,)
    description: str = ""

    def supports(self, scene) -> bool:
        return type(scene).__name__ in self.scenes


@dataclass
class Plan:
    """A method made concrete for one body, initial state and step: a stage table."""

    kinds: np.ndarray
    axes: np.ndarray
    coefs: np.ndarray
    clock: np.ndarray
    params: np.ndarray
    merge_ends: bool
    info: dict = field(default_factory=dict)

    @property
    def n_stages(self) -> int:
        return int(self.kinds.shape[0])


_FREE = ("FreeBody",)
_CONSERVATIVE = ("FreeBody", "HeavyTop", "TorqueBody")
_ALL = (*_CONSERVATIVE, "DampedBody")

_REGISTRY: dict[str, Method] = {}


def _register(method: Method) -> Method:
    _REGISTRY[method.name] = method
    return method


_register(Method(
    "exact", "exact", math.inf, True, True, True, True, _FREE,
    "one elliptic-function evaluation per output sample (no time stepping)",
    description="Exact free-body flow (Jacobi elliptic functions, Carlson R_F/R_J; "
                "trig functions only for symmetric bodies), evaluated at the output times."))
_register(Method(
    "splitting2", "splitting", 2, True, True, True, False, _ALL,
    "4 axis rotations (4 sin/cos pairs), end rotations merged",
    description="Symmetric 5-rotation splitting of T into exact axis sub-flows; the axis "
                "ordering is chosen per orbit from the leading modified-Hamiltonian term."))
_register(Method(
    "sr2", "splitting", 2, True, True, True, False, _FREE,
    "1 quaternion exponential + 2 axis rotations",
    description="Symmetric-body + one-rotation splitting (Touma–Wisdom, Hairer–Vilmart SR2): "
                "exact for symmetric bodies, far more accurate for nearly symmetric ones."))
_register(Method(
    "rattle", "rattle", 2, True, True, True, True, _CONSERVATIVE,
    "1 implicit 3x3 solve (about 5-8 fixed-point iterations, no trig)",
    description="RATTLE on SO(3) in its discrete Moser–Veselov quaternion form; the implicit "
                "equation is solved to round-off (fixed point, Newton fallback)."))
for _name, _comp, _order in (("splitting4", "suzuki4", 4), ("splitting6", "kahanli6", 6),
                             ("splitting8", "kahanli8", 8)):
    _register(Method(
        _name, "composition", _order, True, True, True, False, _CONSERVATIVE,
        f"{len(COMPOSITIONS[_comp])} base steps ({_comp})",
        coefficients=COMPOSITIONS[_comp],
        description=f"{_comp} composition of the best second-order splitting for the orbit."))
_register(Method(
    "dmv4", "rattle", 4, False, True, True, True, _FREE,
    "1 DMV step with modified moments (same cost as rattle)",
    description="Hairer–Vilmart preprocessed DMV of order 4 (modified moments from the "
                "invariants); Poisson in L but not symplectic for (q, L)."))
for _order in (6, 8, 10):
    _register(Method(
        f"dmv{_order}", "rattle", _order, False, True, True, True, _FREE,
        "1 DMV step with modified moments (same cost as rattle)",
        description=f"Hairer–Vilmart preprocessed DMV of order {_order}."))
_register(Method(
    "euler", "baseline", 1, False, False, False, False, _ALL, "1 right-hand side",
    description="Explicit Euler on (q, L) in R^7, no renormalisation: energy, |L| and |q| "
                "grow every step. Kept to show failure."))
_register(Method(
    "rk4", "baseline", 4, False, False, False, False, _ALL, "4 right-hand sides",
    description="Classical RK4 on (q, L) in R^7, no renormalisation: energy, |L| and |q| "
                "drift. Kept to show failure."))
_register(Method(
    "lie_euler", "baseline", 1, False, False, True, False, _ALL,
    "1 quaternion exponential",
    description="Lie–Euler (coadjoint form): stays on SO(3), keeps |L|, drives L to the "
                "maximum-energy axis."))
_register(Method(
    "rkmk4", "baseline", 4, False, False, True, False, _ALL,
    "4 quaternion exponentials",
    description="Runge–Kutta–Munthe-Kaas with the RK4 tableau: on SO(3), keeps |L|, energy "
                "drifts linearly."))


class MethodTable(tuple):
    """The registry as an immutable sequence of :class:`Method`, printed as a table."""

    _cols = ("name", "family", "order", "symplectic", "reversible", "keeps_casimir",
             "keeps_energy", "scenes", "cost")

    def names(self) -> list[str]:
        return [m.name for m in self]

    def __getitem__(self, key):
        if isinstance(key, str):
            for m in self:
                if m.name == key:
                    return m
            raise KeyError(key)
        return super().__getitem__(key)

    def rows(self) -> Iterator[tuple[str, ...]]:
        for m in self:
            vals = []
            for c in self._cols:
                v = getattr(m, c)
                if c == "order":
                    v = "exact" if math.isinf(v) else str(int(v))
                elif isinstance(v, bool):
                    v = "yes" if v else "no"
                elif isinstance(v, tuple):
                    v = ", ".join(v)
                vals.append(str(v))
            yield tuple(vals)

    def __str__(self) -> str:
        rows = [self._cols, *self.rows()]
        widths = [max(len(r[i]) for r in rows) for i in range(len(self._cols))]
        lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip()
                 for r in rows]
        lines.insert(1, "  ".join("-" * w for w in widths))
        return "\n".join(lines)

    def to_markdown(self) -> str:
        """The table in Markdown (``docs/methods.md`` embeds it; a test keeps it current)."""
        head = "| " + " | ".join(self._cols) + " |"
        rule = "|" + "---|" * len(self._cols)
        body = ["| " + " | ".join(r) + " |" for r in self.rows()]
        return "\n".join([head, rule, *body])

    def _repr_pretty_(self, p, cycle):  # pragma: no cover - IPython display
        p.text(str(self))


def methods() -> MethodTable:
    """All registered methods with their declared properties (a printable table)."""
    return MethodTable(_REGISTRY.values())


def get(name) -> Method:
    """Look a method up by name (a :class:`Method` is returned unchanged)."""
    if isinstance(name, Method):
        return name
    if not isinstance(name, str):
        raise TypeError(f"method must be a method name (str), got {type(name).__name__}")
    try:
        return _REGISTRY[name]
    except KeyError:
        known = ", ".join(sorted(_REGISTRY))
        raise ValueError(f"unknown method {name!r}; known methods: {known}") from None


# ----------------------------------------------------------------------------------------
# stage tables
# ----------------------------------------------------------------------------------------

_MERGEABLE = (_drv.STAGE_AXIS, _drv.STAGE_SPHERE, _drv.STAGE_KICK)

#: a stage: (kind, axis, coef, params, clock); params padded to N_PARAMS
Stage = tuple[int, int, float, tuple[float, ...], float]


def _stage(kind: int, axis: int, coef: float, params, clock: float = 0.0) -> Stage:
    p = tuple(float(v) for v in params)
    return (kind, axis, float(coef), p + (0.0,) * (_drv.N_PARAMS - len(p)), float(clock))


def _table(stages: list[Stage], merge: bool = True, info: dict | None = None) -> Plan:
    """Build a :class:`Plan`, merging adjacent flows of the same Hamiltonian."""
    merged: list[list] = []
    for kind, axis, coef, params, clock in stages:
        if coef == 0.0 or (kind in _MERGEABLE and kind != _drv.STAGE_KICK
                           and params[0] == 0.0):
            continue  # an identity flow (zero time or zero rate, e.g. SR2 on a symmetric body)
        if (merge and merged and kind in _MERGEABLE and merged[-1][0] == kind
                and merged[-1][1] == axis and merged[-1][3] == params):
            merged[-1][2] += coef
            merged[-1][4] += clock
            if merged[-1][2] == 0.0 and merged[-1][4] == 0.0:
                merged.pop()
            continue
        merged.append([kind, axis, coef, params, clock])
    if not merged:  # a flow that does nothing (e.g. every rate zero)
        merged = [list(_stage(_drv.STAGE_SPHERE, 0, 1.0, (0.0,), 1.0))]
    first, last = merged[0], merged[-1]
    merge_ends = (merge and len(merged) > 1 and first[0] in _MERGEABLE
                  and first[0] == last[0] and first[1] == last[1] and first[3] == last[3])
    return Plan(
        kinds=np.array([s[0] for s in merged], dtype=np.int64),
        axes=np.array([s[1] for s in merged], dtype=np.int64),
        coefs=np.array([s[2] for s in merged], dtype=np.float64),
        clock=np.array([s[4] for s in merged], dtype=np.float64),
        params=np.array([s[3] for s in merged], dtype=np.float64).reshape(-1, _drv.N_PARAMS),
        merge_ends=merge_ends,
        info=dict(info or {}),
    )


def compose(base: list[Stage], coefficients: tuple[float, ...]) -> list[Stage]:
    """Stages of the composition ``S(g_s h) ... S(g_1 h)`` of a base stage list."""
    out = []
    for g in coefficients:
        out.extend((k, a, c * g, p, ck * g) for k, a, c, p, ck in base)
    return out


def _recurs(moments, k: int) -> float:
    """1.0 when ``m_k`` is a constant of the free motion (the other two moments agree to
    within the exact-flow kernel's ``SYM_RTOL``): the axis-``k`` rotation then has the same
    angle every step and the kernel unit-corrects it (``axis_flow_recurring``)."""
    from liebody._kernels.exact import SYM_RTOL

    i, j = (k + 1) % 3, (k + 2) % 3
    return 1.0 if abs(moments[i] - moments[j]) <= SYM_RTOL * max(moments) else 0.0


def _axis(k: int, coef: float, rate: float, moments, clock: float = 0.0) -> Stage:
    return _stage(_drv.STAGE_AXIS, k, coef, (rate, _recurs(moments, k)), clock=clock)


def _axis_stages(moments, order3) -> list[Stage]:
    a, b, c = order3
    r = [1.0 / moments[i] for i in range(3)]
    return [_axis(a, 0.5, r[a], moments), _axis(b, 0.5, r[b], moments),
            _axis(c, 1.0, r[c], moments, clock=1.0),
            _axis(b, 0.5, r[b], moments), _axis(a, 0.5, r[a], moments)]


def _axis_pieces(moments, order3):
    pieces = []
    for i in order3:
        d = np.zeros(3)
        d[i] = 1.0 / moments[i]
        pieces.append(d)
    return pieces


def _sr2_parts(moments, variant):
    """SR2 variant ``(a, b, c)``: S = |m|^2/(2 I_a) + (1/I_c - 1/I_a) m_c^2/2 (exact),
    R = (1/I_b - 1/I_a) m_b^2 / 2, step R(h/2) S(h) R(h/2)."""
    a, b, c = variant
    rate_r = 1.0 / moments[b] - 1.0 / moments[a]
    rate_c = 1.0 / moments[c] - 1.0 / moments[a]
    return rate_r, rate_c


def _sr2_stages(moments, variant):
    a, b, c = variant
    rate_r, rate_c = _sr2_parts(moments, variant)
    S = _drv.STAGE_SPHERE
    return [_axis(b, 0.5, rate_r, moments), _stage(S, 0, 1.0, (1.0 / moments[a],), clock=1.0),
            _axis(c, 1.0, rate_c, moments), _axis(b, 0.5, rate_r, moments)]


def _sr2_pieces(moments, variant):
    a, b, c = variant
    rate_r, rate_c = _sr2_parts(moments, variant)
    R = np.zeros(3)
    R[b] = rate_r
    S = np.full(3, 1.0 / moments[a])
    S[c] += rate_c
    return [R, S]


_ORDERINGS = tuple(itertools.permutations(range(3)))


def _best(pieces_of, moments, m0) -> tuple[tuple[int, int, int], float]:
    """The variant (a permutation of the axes) with the smallest energy-error constant.

    Cached on (splitting family, moments, m0^2): the orbit, hence the choice, depends on
    nothing else, and repeated runs from one initial state skip the set-up.
    """
    return _best_cached(pieces_of, tuple(float(v) for v in moments),
                        tuple(float(v) ** 2 for v in m0))


@functools.lru_cache(maxsize=256)
def _best_cached(pieces_of, moments, u0) -> tuple[tuple[int, int, int], float]:
    m0 = np.sqrt(np.array(u0))
    per_variant = [pieces_of(moments, v) for v in _ORDERINGS]
    levels = [np.array([p[i] for p in per_variant]) for i in range(len(per_variant[0]))]
    scores = _modified.energy_error_constants(levels, moments, m0)
    k = int(np.argmin(scores))
    return _ORDERINGS[k], float(scores[k])


def best_axis_ordering(moments, m0) -> tuple[tuple[int, int, int], float]:
    """The axis ordering ``(a, b, c)`` of ``a-b-c-b-a`` with the smallest energy-error constant.

    Returns the ordering and its constant (range of ``H3`` over the orbit of ``m0``).
    """
    return _best(_axis_pieces, moments, m0)


def best_sr2_variant(moments, m0) -> tuple[tuple[int, int, int], float]:
    """The SR2 variant with the smallest energy-error constant (0 for a symmetric body)."""
    return _best(_sr2_pieces, moments, m0)


def best_base(moments, m0) -> tuple[str, list, dict]:
    """The better second-order splitting for this orbit: axis splitting or SR2."""
    order, s_axis = best_axis_ordering(moments, m0)
    variant, s_sr2 = best_sr2_variant(moments, m0)
    if s_sr2 <= s_axis:
        return "sr2", _sr2_stages(moments, variant), {
            "base": "sr2", "sr2_variant": variant, "energy_error_constant": s_sr2}
    return "splitting2", _axis_stages(moments, order), {
        "base": "splitting2", "axis_ordering": order, "energy_error_constant": s_axis}


def _dmv_modified_moments(moments, m0, h: float, order: int) -> tuple[float, float, float]:
    """Hairer–Vilmart modified moments ``1/I_i^mod = CSS / I_i + CDD`` (literature section 4).

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


_BASELINE_KIND = {"euler": _drv.STAGE_EULER, "rk4": _drv.STAGE_RK4,
                  "lie_euler": _drv.STAGE_LIE_EULER, "rkmk4": _drv.STAGE_RKMK4}


def free_flow_stages(body, m0, choice: str = "auto") -> tuple[list[Stage], str]:
    """The free flow used as the drift of the splittings of torqued scenes.

    * a spherical or symmetric body (moments equal to within the exact-flow kernel's
      ``SYM_RTOL``, a few ulps): its exact flow, a sphere rotation plus a rotation about
      the symmetry axis (trig functions only, about as cheap as one splitting step);
    * otherwise, with ``choice="auto"`` or ``"axes"``: the 5-rotation splitting with the
      axis ordering best for the orbit of ``m0`` (the cheapest drift that keeps the
      invariants); with ``choice="exact"``: the elliptic exact flow (about 4x dearer,
      no splitting error in the free part).
    """
    from liebody._kernels.exact import SYM_RTOL

    I = tuple(float(v) for v in body.moments)
    top = max(I)
    close = [abs(I[i] - I[j]) <= SYM_RTOL * top for i, j in ((1, 2), (2, 0), (0, 1))]
    if all(close):
        return [_stage(_drv.STAGE_SPHERE, 0, 1.0, (3.0 / sum(I),), clock=1.0)], "sphere"
    if any(close) and choice != "axes":
        c = close.index(True)  # the pair (c+1, c+2) is equal: c is the symmetry axis
        i_perp = 0.5 * (I[(c + 1) % 3] + I[(c + 2) % 3])
        return [_stage(_drv.STAGE_SPHERE, 0, 1.0, (1.0 / i_perp,), clock=1.0),
                _stage(_drv.STAGE_AXIS, c, 1.0, (1.0 / I[c] - 1.0 / i_perp, 1.0))], "symmetric"
    if choice == "exact":
        return [_stage(_drv.STAGE_EXACT, 0, 1.0, I, clock=1.0)], "elliptic"
    order, _ = best_axis_ordering(I, m0)
    return _axis_stages(I, order), f"axes {order}"


def plan(method: Method, scene, m0, h: float) -> Plan:
    """Turn ``method`` into a stage table for ``scene``, its initial ``m0`` and step ``h``."""
    body = scene.body
    moments = tuple(float(v) for v in body.moments)
    torque_kind, c = scene.torque_parameters()
    eps = scene.damping_parameter()
    name = method.name
    if name in _BASELINE_KIND:
        return _table([_stage(_BASELINE_KIND[name], 0, 1.0,
                              (*moments, float(torque_kind), *c, eps), clock=1.0)],
                      merge=False)
    if type(scene).__name__ == "FreeBody":
        return _plan_free(method, moments, m0, h)

    free, free_kind = free_flow_stages(body, m0, scene.free_flow)
    info = {"free_flow": free_kind}
    if eps != 0.0:  # dissipation: D(h/2) F(h) D(h/2)
        side = _stage(_drv.STAGE_DAMP, 0, 0.5, (*moments, eps))
    else:  # torque kicks: K(h/2) F(h) K(h/2)
        side = _stage(_drv.STAGE_KICK, 0, 0.5, (float(torque_kind), *c))
    closing = side
    if not scene.orientation_only_torque():
        # the explicit kick is not symmetric when the torque depends on L: close the step
        # with its adjoint (implicit) kick so the base method stays symmetric, order 2
        closing = _stage(_drv.STAGE_KICK_IMPLICIT, 0, 0.5, (float(torque_kind), *c))
        info["kicks"] = "explicit/implicit (L-dependent torque)"
    if name == "rattle":
        free = [_stage(_drv.STAGE_DMV, 0, 1.0, moments, clock=1.0)]
        info["free_flow"] = "dmv"
    base = [side, *free, closing]
    if method.family == "composition":
        return _table(compose(base, method.coefficients), info=info)
    if name in ("splitting2", "rattle"):
        return _table(base, info=info)
    raise ValueError(f"method {name!r} has no stage table for "  # pragma: no cover
                     f"{type(scene).__name__}")


def _plan_free(method: Method, moments, m0, h: float) -> Plan:
    name = method.name
    if name == "splitting2":
        order, score = best_axis_ordering(moments, m0)
        return _table(_axis_stages(moments, order),
                      info={"axis_ordering": order, "energy_error_constant": score})
    if name == "sr2":
        variant, score = best_sr2_variant(moments, m0)
        return _table(_sr2_stages(moments, variant),
                      info={"sr2_variant": variant, "energy_error_constant": score})
    if method.family == "composition":
        _, base, info = best_base(moments, m0)
        return _table(compose(base, method.coefficients), info=info)
    if name == "rattle":
        return _table([_stage(_drv.STAGE_DMV, 0, 1.0, moments, clock=1.0)], merge=False)
    if name in ("dmv4", "dmv6", "dmv8", "dmv10"):
        mod = _dmv_modified_moments(moments, m0, h, method.order)
        if not all(np.isfinite(v) and v > 0.0 for v in mod):
            raise ValueError(
                f"dt = {h:g} is too large for {name}: its modified moments "
                f"{tuple(round(v, 6) for v in mod)} are not all positive (the h^2 and h^4 "
                f"corrections of Hairer-Vilmart's series dominate); reduce dt")
        return _table([_stage(_drv.STAGE_DMV, 0, 1.0, mod, clock=1.0)], merge=False,
                      info={"modified_moments": mod})
    if name == "exact":
        return _table([_stage(_drv.STAGE_EXACT, 0, 1.0, moments, clock=1.0)], merge=False)
    raise ValueError(f"method {name!r} has no stage table")  # pragma: no cover
