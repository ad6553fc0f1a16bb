"""The method catalogue: every integrator is a :class:`Method` record, registered once.

A method is data: a name, its order and properties, what scenes it can handle, and
a *recipe* (``liebody._plan``) that builds its stage table for a scene, initial
state and step. Compositions are a coefficient table applied to a second-order base
recipe. :func:`methods` renders the catalogue as a table, so the documentation and
the tests read one truth; adding a method is one :func:`register` call.

Example: a fixed-ordering Strang splitting, integrable at once by
:func:`liebody.integrate` and picked up by the generic tests::

    from liebody import Method, register
    from liebody._plan import AxisSplitting
    register(Method("strang123", AxisSplitting(ordering=(0, 1, 2)), order=2,
                    family="splitting", symplectic=True, reversible=True,
                    keeps_casimir=True, keeps_energy=False, handles=Handles.ALL,
                    cost="4 axis rotations"))
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections import OrderedDict
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from liebody import _plan as P
from liebody._kernels import stages as S
from liebody._validate import F64
from liebody.scenes import DEPENDENCIES, Capabilities
from liebody.scenes import _memo as memo

#: one-body plans kept (least recently used dropped first)
PLAN_CACHE_SIZE = 128
#: (method name, id(scene), h[, m0 bytes]) -> (method, scene, plan), and (method name,
#: id(scene), h, None, key) -> the plan shared by the states of one key
_PLANS: OrderedDict = OrderedDict()
#: method name -> its last plan, ``(method, scene, h, m0 bytes or None, plan)``
_LAST: dict = {}


def _touch(key) -> None:
    """Mark a plan of the cache as just used."""
    try:  # noqa: SIM105 - (contextlib.suppress costs 0.3 us a call)
        _PLANS.move_to_end(key)
    except KeyError:  # evicted meanwhile by another thread
        pass


def _keep(key, entry) -> None:
    """Cache a plan, dropping the least recently used beyond :data:`PLAN_CACHE_SIZE`."""
    _PLANS[key] = entry
    while len(_PLANS) > PLAN_CACHE_SIZE:
        try:
            _PLANS.popitem(last=False)
        except KeyError:  # emptied meanwhile by another thread
            break

__all__ = ["COMPOSITIONS", "CoefficientReport", "Handles", "Method", "MethodTable",
           "composition_report", "get", "methods", "register", "register_composition",
           "register_splitting"]


# ----------------------------------------------------------------------------------------
# what a method can integrate
# ----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Handles:
    """What a method can integrate, matched against a scene's :class:`~liebody.scenes.Capabilities`.

    Attributes
    ----------
    torque : frozenset of str
        The torque dependencies it handles (``"time"``, ``"orientation"``,
        ``"momentum"``); empty: free bodies only.
    dissipation : bool
        Whether it handles internal dissipation.
    """

    torque: frozenset = frozenset()
    dissipation: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "torque", frozenset(self.torque))

    def accepts(self, caps: Capabilities) -> bool:
        return caps.torque <= self.torque and (self.dissipation or not caps.dissipative)

    def describe(self) -> str:
        if not self.torque and not self.dissipation:
            return "free body"
        parts = ["any torque" if self.torque == frozenset(DEPENDENCIES)
                 else "torque(" + ", ".join(sorted(self.torque)) + ")"] if self.torque else []
        if self.dissipation:
            parts.append("dissipation")
        return ", ".join(parts)


# the three usual cases, as class attributes: Handles.FREE, Handles.TORQUES, Handles.ALL
Handles.FREE = Handles()
Handles.TORQUES = Handles(frozenset(DEPENDENCIES))
Handles.ALL = Handles(frozenset(DEPENDENCIES), dissipation=True)


# ----------------------------------------------------------------------------------------
# the record
# ----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Method:
    """A registered integrator and its declared properties.

    Attributes
    ----------
    name
        Public name passed as ``integrate(..., method=name)``.
    recipe
        Builds the method's stage table for a scene, initial state and step
        (``liebody._plan``).
    order
        Classical order (``math.inf`` for the exact flow).
    family
        A descriptive word for tables and charts: ``"splitting"``, ``"composition"``,
        ``"rattle"``, ``"exact"`` or ``"baseline"`` (nothing dispatches on it).
    symplectic, reversible
        Symplectic (Lie–Poisson in ``L``) and time-reversible (symmetric). On torqued
        scenes these hold for conservative, orientation-only torques.
    keeps_casimir
        On a free body: keeps ``|L|`` (and, for every method that acts by rotations,
        spatial ``L``) to round-off.
    keeps_energy
        On a free body: keeps the energy to round-off.
    handles
        What scenes it can integrate (:class:`Handles`).
    cost
        Cost of one step in words (measured figures: ``bench/README.md``).
    description
        One or two sentences for the documentation.
    sampled
        ``integrate()`` evaluates the method at the output times directly instead of
        stepping (the exact flow): no time is spent between samples.
    weak_order
        For a weak torque of relative strength ``eps`` against the free motion, the
        order in ``h`` of the error's terms linear in ``eps``: the global error is
        ``O(eps h^weak_order + eps^2 h^order)`` (Laskar & Robutel's SABA_n: ``2 n``).
        ``None``: no more than ``order``.
    """

    name: str
    recipe: P.Recipe
    order: float
    family: str
    symplectic: bool
    reversible: bool
    keeps_casimir: bool
    keeps_energy: bool
    handles: Handles
    cost: str
    description: str = ""
    sampled: bool = False
    weak_order: float | None = None

    @property
    def exact_when_free(self) -> bool:
        """Whether the method is the exact free flow on a body without torque (``exact``;
        the splittings of the exact free flow and kicks only, such as SABA_n, whose
        kicks vanish there): on a free body it has no error of its own to measure."""
        return self.sampled or bool(getattr(self.recipe, "exact_when_free", False))

    @property
    def coefficients(self) -> tuple[float, ...]:
        """Composition coefficients applied to the base (``(1.0,)`` for a base method)."""
        return self.recipe.coefficients

    def supports(self, scene) -> bool:
        """Whether the method can integrate ``scene`` (by its capabilities)."""
        return self.handles.accepts(scene.capabilities)

    def plan(self, scene, m0, h: float) -> P.Plan:
        """The method's stage table for one body: ``scene``, initial momentum ``m0`` ``(3,)``
        and step ``h`` (``params`` has a body axis of length 1).

        Plans are cached per (method, scene object, ``h``), and also per ``m0`` when the
        recipe read the initial state to build it (an axis ordering chosen for the
        orbit, Hairer-Vilmart's modified moments): repeated calls with one scene skip
        the set-up, and so do calls from new initial states for methods whose plan does
        not depend on them. A recipe whose ``keyed_by_state`` is true (``liebody._plan``;
        the splittings: its plan depends on the state only through the orbit's choices,
        its key) shares one plan among the states of one key, each with its own ``info``:
        a new initial state then costs its choices only. A cached plan is shared: never
        write to its arrays (copy ``params`` first, as the drivers' callers do for the
        controls).
        """
        if m0.__class__ is not np.ndarray or m0.shape != (3,) or m0.dtype is not F64:
            m0 = np.asarray(m0, dtype=float).reshape(3)
        h = h if h.__class__ is float else float(h)
        last = _LAST.get(self.name)  # (the repeated calls of a loop, at once)
        if last is not None and last[0] is self and last[1] is scene and last[2] == h and (
                last[3] is None or last[3] == m0.tobytes()):
            return last[4]
        any_state = (self.name, id(scene), h)
        key = any_state
        entry = _PLANS.get(key)
        if entry is None:
            key = (*any_state, m0.tobytes())
            entry = _PLANS.get(key)
        if entry is not None and entry[0] is self and entry[1] is scene:
            _touch(key)
            plan = entry[2]
        else:
            bodies = P.Bodies.of(scene, m0.reshape(1, 3))
            plan = self._keyed_plan(scene, bodies, h, any_state)
            if plan is None:
                (_, plan), = self._plans_of(bodies, h)
            key = (*any_state, m0.tobytes()) if bodies.orbit_read[0] else any_state
            _keep(key, (self, scene, plan))  # the scene is kept: its id stays unique
        _LAST[self.name] = (self, scene, h, key[3] if len(key) > 3 else None, plan)
        return plan

    def _keyed_plan(self, scene, bodies: P.Bodies, h: float, any_state: tuple) -> P.Plan | None:
        """The plan of one body from a recipe keyed by state, shared by the states of its
        key (cached per key, beside the plans per state), or ``None`` for a recipe that
        is not keyed by state or a plan that reads no state."""
        recipe = self.recipe
        if not recipe.keyed_by_state:
            return None
        try:
            key = int(recipe.keys(bodies, h)[0])
            if not bodies.orbit_read[0]:
                return None  # the same plan for every state (cached without it)
            by_key = (*any_state, None, key)
            entry = _PLANS.get(by_key)
            if entry is not None and entry[0] is self and entry[1] is scene:
                _touch(by_key)
                shared = entry[2]
                return shared.with_info({**shared.info, **recipe.state_info(bodies, h, key)})
            plan = P.plan_of_key(recipe, bodies, h, key)
        except ValueError as exc:  # a recipe's refusal: say which method refused
            raise ValueError(f"{self.name}: {exc}") from None
        _keep(by_key, (self, scene, plan))
        return plan

    def plans(self, scene, m0, h: float) -> list[tuple[np.ndarray, P.Plan]]:
        """The stage tables for a batch of bodies (``m0`` ``(N, 3)``, and the scene's
        parameters broadcast against it): one per group of bodies that share the step's
        structure, with the indices of its bodies."""
        return self._plans_of(P.Bodies.of(scene, m0), h)

    def _plans_of(self, bodies: P.Bodies, h: float) -> list[tuple[np.ndarray, P.Plan]]:
        try:
            return P.plan_groups(self.recipe, bodies, float(h))
        except ValueError as exc:  # a recipe's refusal: say which method refused
            raise ValueError(f"{self.name}: {exc}") from None


# ----------------------------------------------------------------------------------------
# composition coefficients (palindromic, the full list in order)
# ----------------------------------------------------------------------------------------


def _palindrome(half: tuple[float, ...], centre: float) -> tuple[float, ...]:
    return (*half, centre, *reversed(half))


_SUZUKI_G = 1.0 / (4.0 - 4.0 ** (1.0 / 3.0))

#: name -> palindromic coefficients ``g_i`` of ``S(g_s h) ... S(g_1 h)``
COMPOSITIONS: dict[str, tuple[float, ...]] = {
    "strang": (1.0,),
    # Suzuki, Phys. Lett. A 146 (1990) 319: 5 stages, order 4
    "suzuki4": _palindrome((_SUZUKI_G, _SUZUKI_G), 1.0 - 4.0 * _SUZUKI_G),
    # Kahan & Li, Math. Comp. 66 (1997) 1089, s9odr6: order 6
    "kahanli6": _palindrome(
        (0.39216144400731413928, 0.33259913678935943860, -0.70624617255763935981,
         0.08221359629355080023),
        0.79854399093482996340),
    # Kahan & Li (1997), s17odr8: order 8
    "kahanli8": _palindrome(
        (0.13020248308889008088, 0.56116298177510838456, -0.38947496264484728641,
         0.15884190655515560090, -0.39590389413323757734, 0.18453964097831570709,
         0.25837438768632204729, 0.29501172360931029887),
        -0.60550853383003451170),
}


def gauss_legendre(n: int) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The ``n``-point Gauss–Legendre rule on ``[0, 1]`` (``n`` = 1 to 4), nodes
    increasing and weights, from the closed forms of the roots of the Legendre
    polynomials (Abramowitz & Stegun 1964, table 25.4): exact for polynomials of degree
    ``2 n - 1``."""
    if n == 1:
        x, w = (0.0,), (2.0,)
    elif n == 2:
        x, w = (-1.0 / math.sqrt(3.0), 1.0 / math.sqrt(3.0)), (1.0, 1.0)
    elif n == 3:
        a = math.sqrt(0.6)
        x, w = (-a, 0.0, a), (5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0)
    elif n == 4:
        r = 2.0 / 7.0 * math.sqrt(1.2)
        a, b = math.sqrt(3.0 / 7.0 - r), math.sqrt(3.0 / 7.0 + r)
        wa, wb = (18.0 + math.sqrt(30.0)) / 36.0, (18.0 - math.sqrt(30.0)) / 36.0
        x, w = (-b, -a, a, b), (wb, wa, wa, wb)
    else:
        raise ValueError(f"n must be 1 to 4, got {n!r}")
    return tuple(0.5 * (1.0 + v) for v in x), tuple(0.5 * v for v in w)


def saba_flows(n: int) -> tuple[tuple[str, float, float], ...]:
    """The sub-flows of Laskar & Robutel's SABA_n (Celest. Mech. Dyn. Astron. 80 (2001)
    39, sect. 3): the free flow between ``n`` kicks at the Gauss–Legendre nodes
    ``c_i`` of the step, each kick weighted by its Gauss weight, the clock advancing
    with the free flow (so a time-dependent torque is read at the nodes):
    ``free(c_1) kick(w_1) free(c_2 - c_1) ... kick(w_n) free(1 - c_n)``."""
    nodes, weights = gauss_legendre(n)
    drifts = [b - a for a, b in zip((0.0, *nodes), (*nodes, 1.0), strict=True)]
    for i in range((n + 1) // 2):
        drifts[n - i] = drifts[i]  # mirrored exactly (palindromic)
    out = []
    for d, w in zip(drifts, weights, strict=False):
        out += [("free", d, d), ("kick", w)]
    out.append(("free", drifts[-1], drifts[-1]))
    return tuple(out)


def check_composition(coefficients, order: float, base_order: int = 2) -> tuple[float, ...]:
    """Validate composition coefficients for a symmetric base of order ``base_order``.

    They must be finite, palindromic, sum to 1, and for a declared order ``p`` above the
    base's satisfy the necessary power conditions ``sum g^j = 0`` for the odd ``j`` from
    ``base_order + 1`` to ``p - 1`` (Yoshida 1990; Hairer, Lubich & Wanner 2006, sect.
    V.3.2): enough for ``p = base_order + 2``; higher orders need further conditions on
    nested sums, which the observed-order tests check.
    """
    g = np.asarray(coefficients, dtype=float)
    if g.ndim != 1 or g.size == 0 or not np.all(np.isfinite(g)):
        raise ValueError(f"coefficients must be a non-empty list of finite numbers, got {g}")
    if not np.allclose(g, g[::-1], rtol=0, atol=1e-15):
        raise ValueError("coefficients must be palindromic (a symmetric composition)")
    if abs(g.sum() - 1.0) > 1e-14:
        raise ValueError(f"coefficients must sum to 1 (consistency), got {g.sum()!r}")
    for p in range(int(base_order) + 1, int(order), 2):
        if abs(float(np.sum(g**p))) > 1e-13 * float(np.sum(np.abs(g) ** p)):
            raise ValueError(f"coefficients do not give order {order} from a base of order "
                             f"{base_order}: sum g^{p} = {float(np.sum(g**p)):.3e} must "
                             f"vanish")
    return tuple(float(v) for v in g)


#: size of the random matrices that stand for the sub-flows' vector fields in
#: ``check_splitting`` (a matrix identity of degree below ``2 n`` does not hold for
#: ``n x n`` matrices, Amitsur-Levitzki: 6 x 6 ones tell the conditions up to order 11)
_ORDER_MATRIX = 6


def check_splitting(flows, order: int) -> None:
    """Check the declared order of a splitting of exact sub-flows (``FlowSequence``).

    A splitting ``exp(a_s h X_s) ... exp(a_1 h X_1)`` has order ``p`` when the logarithm
    of the product is ``h (X_1 + ... + X_m) + O(h^(p+1))``: its terms of degree 2 to
    ``p`` in ``h`` (commutators of the ``X``; Baker-Campbell-Hausdorff) vanish (Hairer,
    Lubich & Wanner 2006, sect. III.5). The ``X`` stand for the sub-flows: ``T1``,
    ``T2``, ``T3``, ``kick``, ``damp``, a clock (``kick`` reads the time; the other
    flows commute with it), ``free = T1 + T2 + T3``. The terms are computed as exact
    power series in ``h`` with fixed random matrices in place of the ``X``: conditions
    for a generic scene, so an order reached only through the structure of a special
    body is refused (measure it with :func:`liebody.testing.observed_order` and
    register a :class:`Method` yourself). Raises ``ValueError`` naming the first degree
    whose terms do not vanish.
    """
    recipe = flows if isinstance(flows, P.FlowSequence) else P.FlowSequence(tuple(flows))
    p = int(order)
    if p < 2:
        return
    n = _ORDER_MATRIX
    rng = np.random.default_rng(20)  # fixed: the check is deterministic
    eye_b = np.eye(2)

    def generic(size):
        a = rng.normal(size=(size, size))
        return a / np.linalg.norm(a, 2)

    rot = [np.kron(generic(n), eye_b) for _ in range(3)]
    gens = {"T1": rot[0], "T2": rot[1], "T3": rot[2], "free": rot[0] + rot[1] + rot[2],
            "damp": np.kron(generic(n), eye_b), "kick": generic(2 * n)}
    clock = np.kron(np.eye(n), generic(2))  # commutes with every flow but the kick
    dim = 2 * n
    # the product as a power series in h: coefficient matrices of h^0 .. h^p
    series = [np.eye(dim)] + [np.zeros((dim, dim)) for _ in range(p)]
    total = np.zeros((dim, dim))

    def times_exp(series, X):
        powers = [np.eye(dim)]
        for j in range(1, p + 1):
            powers.append(powers[-1] @ X / j)
        return [sum(powers[j] @ series[d - j] for j in range(d + 1)) for d in range(p + 1)]

    for name, frac, tick in recipe.flows:
        series = times_exp(series, frac * gens[name])
        total = total + frac * gens[name]
        if tick:
            series = times_exp(series, tick * clock)
            total = total + tick * clock
    # log(I + Y), Y = series - I (no h^0 term), up to h^p
    Y = [np.zeros((dim, dim))] + series[1:]
    log = [np.zeros((dim, dim)) for _ in range(p + 1)]
    power = Y
    for k in range(1, p + 1):
        for d in range(p + 1):
            log[d] = log[d] + ((-1) ** (k + 1) / k) * power[d]
        power = [sum(power[j] @ Y[d - j] for j in range(1, d)) if d >= 2 else
                 np.zeros((dim, dim)) for d in range(p + 1)]
    scale = sum(abs(f) + abs(c) for _, f, c in recipe.flows)
    for d in range(2, p + 1):
        size = float(np.abs(log[d]).max())
        if size > 1e-11 * scale**d:
            raise ValueError(
                f"flows: the declared order {p} is false: the terms of degree {d} in h "
                f"of the splitting's logarithm (Baker-Campbell-Hausdorff) do not vanish "
                f"(largest {size:.3e}); order {p} needs every term of degree 2 to {p} to "
                f"vanish, so this sequence has order {d - 1}")


# ----------------------------------------------------------------------------------------
# the registry
# ----------------------------------------------------------------------------------------

_REGISTRY: dict[str, Method] = {}
#: the names liebody registers itself (replacing one warns); filled once they are
_BUILTIN: frozenset = frozenset()


def register(method: Method, *, replace: bool = False) -> Method:
    """Add ``method`` to the catalogue (``replace=True`` to redefine a name).

    A registered method is integrable by :func:`liebody.integrate`, listed by
    :func:`methods` and picked up by the generic tests at once. Its declared order is
    checked where the recipe allows: the power conditions of a symmetric composition
    (``check_composition``), the order conditions of a splitting of exact sub-flows
    (``check_splitting``). Replacing one of liebody's built-in methods (some are
    the scenes' default methods) warns (``UserWarning``): every run that names it, or
    that relies on a scene's default, then runs the replacement.
    """
    return _register(method, replace, stacklevel=3)


def _register(method: Method, replace: bool, stacklevel: int) -> Method:
    """:func:`register`, warning ``stacklevel`` frames up (the user's call)."""
    if not isinstance(method, Method):
        raise TypeError(f"method must be a liebody.Method, got {type(method).__name__}")
    if not isinstance(method.name, str) or not method.name.isidentifier():
        raise ValueError(f"a method name must be an identifier, got {method.name!r}")
    if method.name in _REGISTRY and not replace:
        raise ValueError(f"a method named {method.name!r} is registered already "
                         f"(pass replace=True to redefine it)")
    if not isinstance(method.recipe, P.Recipe):
        raise TypeError(f"recipe must be a liebody._plan.Recipe, got "
                        f"{type(method.recipe).__name__}")
    if isinstance(method.recipe, P.Composition) and method.reversible:
        check_composition(method.recipe.coefficients, method.order, method.recipe.base_order)
    if isinstance(method.recipe, P.FlowSequence) and math.isfinite(method.order):
        check_splitting(method.recipe, int(method.order))
    if method.name in _BUILTIN and _REGISTRY.get(method.name) is not method:
        warnings.warn(f"register: {method.name!r} replaces liebody's built-in method of that "
                      f"name{_default_of(method.name)}: every run that names it now runs the "
                      f"replacement", UserWarning, stacklevel=stacklevel)
    _REGISTRY[method.name] = method
    return method


def _default_of(name: str) -> str:
    """`` (the default method of FreeBody, ...)`` when ``name`` is a scene's default."""
    from liebody import scenes

    owners = sorted(c.__name__ for c in vars(scenes).values()
                    if isinstance(c, type) and getattr(c, "default_method", None) == name
                    and c.__module__ == scenes.__name__)
    return f" (the default method of {', '.join(owners)})" if owners else ""


def _composition(name: str, table: str, order: int) -> Method:
    return Method(
        name, P.Composition(P.BestSplitting(), COMPOSITIONS[table]), order, "composition",
        True, True, True, False, Handles.TORQUES,
        f"{len(COMPOSITIONS[table])} base steps ({table})",
        description=f"{table} composition of the best second-order splitting for the orbit.")


def _dmv(order: int) -> Method:
    return Method(
        f"dmv{order}", P.DMVFlow(order), order, "rattle", False, True, True, True,
        Handles.FREE, "1 DMV step with modified moments (same cost as rattle)",
        description=f"Hairer–Vilmart preprocessed DMV of order {order} (modified moments "
                    "from the invariants); Poisson in L but not symplectic for (q, L).")


def _saba(n: int) -> Method:
    return Method(
        f"saba{n}", P.FlowSequence(saba_flows(n)), 2, "splitting", True, True, True, True,
        Handles(frozenset({"time", "orientation"})),
        f"{n} exact free flows and {n} kicks (the end flows merged between unsaved steps)",
        description=f"Laskar & Robutel's SABA_{n} (2001): the exact free flow between "
                    f"{n} kicks at the Gauss-Legendre nodes of the step; error "
                    f"O(eps h^{2 * n} + eps^2 h^2) for a torque of relative strength eps, "
                    f"exact on a free body (the drift is the exact flow whatever the "
                    f"scene's free_flow). For fast rotators under weak torques.",
        weak_order=2 * n)


def _baseline(name: str, kind: int, order: int, keeps_casimir: bool, cost: str,
              description: str) -> Method:
    return Method(name, P.Baseline(kind), order, "baseline", False, False, keeps_casimir,
                  False, Handles.ALL, cost, description=description)


for _m in (
    Method("exact", P.ExactFlow(), math.inf, "exact", True, True, True, True, Handles.FREE,
           "one elliptic-function evaluation per output sample (no time stepping)",
           description="Exact free-body flow (Jacobi elliptic functions, Carlson R_F/R_J; "
                       "trig functions only for symmetric bodies), evaluated at the output "
                       "times.",
           sampled=True),
    Method("splitting2", P.AxisSplitting(), 2, "splitting", True, True, True, False,
           Handles.ALL, "4 axis rotations (4 sin/cos pairs), end rotations merged",
           description="Symmetric 5-rotation splitting of T into exact axis sub-flows; the "
                       "axis ordering is chosen per orbit from the leading "
                       "modified-Hamiltonian term."),
    Method("no_squish", P.AxisSplitting(ordering=(2, 1, 0)), 2, "splitting", True, True, True,
           False, Handles.ALL, "4 axis rotations (4 sin/cos pairs), end rotations merged",
           description="The 5-rotation splitting in the fixed ordering z-y-x-y-z of NO_SQUISH "
                       "(Miller et al., J. Chem. Phys. 116 (2002) 8649), as molecular-dynamics "
                       "codes run it: the same map, written in (q, L); often a worse "
                       "ordering than splitting2's."),
    Method("sr2", P.SR2Splitting(), 2, "splitting", True, True, True, False, Handles.FREE,
           "1 quaternion exponential + 2 axis rotations",
           description="Symmetric-body + one-rotation splitting (Touma–Wisdom, "
                       "Hairer–Vilmart SR2): exact for symmetric bodies, far more accurate "
                       "for nearly symmetric ones."),
    Method("rattle", P.DMVFlow(2), 2, "rattle", True, True, True, True, Handles.TORQUES,
           "1 implicit 3x3 solve (about 5-8 fixed-point iterations, no trig)",
           description="RATTLE on SO(3) in its discrete Moser–Veselov quaternion form; the "
                       "implicit equation is solved to round-off (fixed point, Newton "
                       "fallback)."),
    _composition("splitting4", "suzuki4", 4),
    _composition("splitting6", "kahanli6", 6),
    _composition("splitting8", "kahanli8", 8),
    _saba(2), _saba(3), _saba(4),
    _dmv(4), _dmv(6), _dmv(8), _dmv(10),
    _baseline("euler", S.EULER, 1, False, "1 right-hand side",
              "Explicit Euler on (q, L) in R^7, no renormalisation: energy, |L| and |q| grow "
              "every step. Kept to show failure."),
    _baseline("rk4", S.RK4, 4, False, "4 right-hand sides",
              "Classical RK4 on (q, L) in R^7, no renormalisation: energy, |L| and |q| "
              "drift. Kept to show failure."),
    _baseline("lie_euler", S.LIE_EULER, 1, True, "1 quaternion exponential",
              "Lie–Euler (coadjoint form): stays on SO(3), keeps |L|, drives L to the "
              "maximum-energy axis."),
    _baseline("rkmk4", S.RKMK4, 4, True, "4 quaternion exponentials",
              "Runge–Kutta–Munthe-Kaas with the RK4 tableau: on SO(3), keeps |L|, energy "
              "drifts linearly."),
):
    register(_m)
#: the names liebody registers itself (replacing one warns)
_BUILTIN = frozenset(_REGISTRY)


# ----------------------------------------------------------------------------------------
# user-defined methods
# ----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CoefficientReport:
    """What the registry found in a list of composition coefficients ``g_1, ..., g_s``.

    Attributes
    ----------
    total
        ``sum g`` (consistency: 1).
    palindromic
        ``g_i = g_{s+1-i}`` (a symmetric composition of a symmetric base is symmetric,
        and then has even order).
    power_sums
        ``{3: sum g^3, 5: sum g^5, ...}``: a symmetric composition of a symmetric
        second-order base has order 4 if and only if ``sum g^3 = 0``; order ``2k + 2``
        needs ``sum g^(2j+1) = 0`` for ``j = 1 .. k`` and further conditions on nested
        sums (Hairer, Lubich & Wanner, *Geometric Numerical Integration*, 2006, sect.
        V.3; Yoshida, Phys. Lett. A 150 (1990) 262).
    order_bound
        The highest order the power sums allow (4 or more is proven only up to 4;
        :func:`liebody.testing.observed_order` measures it).
    """

    coefficients: tuple[float, ...]
    total: float
    palindromic: bool
    power_sums: dict
    order_bound: int

    def __str__(self) -> str:
        sums = ", ".join(f"sum g^{p} = {v:.3e}" for p, v in self.power_sums.items())
        return (f"{len(self.coefficients)} stages, sum g = {self.total!r}, "
                f"{'palindromic' if self.palindromic else 'not palindromic'}; {sums}; "
                f"order at most {self.order_bound}")


def composition_report(coefficients) -> CoefficientReport:
    """Check composition coefficients: finite, consistent (``sum g = 1``); report their
    symmetry and power sums (:class:`~liebody.CoefficientReport`). Raises ``ValueError`` when they
    are not finite numbers or do not sum to 1."""
    g = np.asarray(coefficients, dtype=float)
    if g.ndim != 1 or g.size == 0 or not np.all(np.isfinite(g)):
        raise ValueError(f"coefficients must be a non-empty list of finite numbers, got "
                         f"{coefficients!r}")
    total = float(math.fsum(g))
    if abs(total - 1.0) > 1e-14:
        raise ValueError(f"coefficients must sum to 1 (consistency: the base runs for one "
                         f"step in all), got sum = {total!r}")
    pal = bool(np.allclose(g, g[::-1], rtol=0, atol=1e-15))
    sums, bound = {}, 2
    scale = 1e-13
    for k in range(1, 5):
        p = 2 * k + 1
        v = float(math.fsum(g**p))
        sums[p] = v
        if pal and bound == 2 * k and abs(v) <= scale * float(np.sum(np.abs(g) ** p)):
            bound = 2 * k + 2
    return CoefficientReport(tuple(float(v) for v in g), total, pal, sums,
                             bound if pal else 2)


def register_composition(name: str, coefficients, base: str = "splitting2", *,
                         order: int | None = None, description: str = "",
                         replace: bool = False) -> Method:
    """Register a composition of a registered base method, from its coefficients.

    The step is ``S(g_s h) ... S(g_1 h)``: the base method ``S`` run for the fractions
    ``g_1, ..., g_s`` of the step in turn.

    Parameters
    ----------
    name
        The new method's name (an identifier).
    coefficients
        The full list of fractions ``g_1 .. g_s`` of the step given to the base method,
        in the order they run (as ``liebody._methods.COMPOSITIONS`` stores them), summing to 1.
    base
        A registered time-stepping method to compose (a symmetric second-order one for
        the classical order theory: ``"splitting2"``, ``"sr2"``, ``"rattle"``, ...).
    order
        The order to declare. Default: the order the coefficients prove for a symmetric
        base of order ``p`` (``p``, or ``p + 2`` when they are palindromic and
        ``sum g^(p+1) = 0``). A higher order must be declared, and is checked against
        the necessary power conditions ``sum g^j = 0`` (odd ``j`` from ``p + 1``); a
        composition that is not symmetric cannot declare more than ``p``.
    description, replace
        As for :func:`register`.

    Returns
    -------
    Method
        The registered method; it integrates, benchmarks and checks like any other
        (:func:`liebody.testing.observed_order` measures its order). The registry's
        findings on the coefficients are in its ``description``
        (:func:`composition_report`).

    Examples
    --------
    Yoshida's triple jump (Phys. Lett. A 150 (1990) 262), order 4:

    >>> import liebody
    >>> g1 = 1 / (2 - 2 ** (1 / 3))
    >>> m = liebody.register_composition("triple_jump", [g1, 1 - 2 * g1, g1])
    >>> m.order
    4
    """
    base_m = get(base)
    if base_m.sampled or isinstance(base_m.recipe, P.Baseline):
        raise ValueError(f"base {base_m.name!r} cannot be composed: compose a splitting or "
                         f"RATTLE (a method that steps by stages)")
    report = composition_report(coefficients)
    p = int(base_m.order)
    symmetric = report.palindromic and base_m.reversible
    if order is None:  # what the coefficients prove: p, or p + 2 when sum g^(p+1) = 0
        g = np.asarray(report.coefficients)
        gains = symmetric and p % 2 == 0 and abs(float(math.fsum(g ** (p + 1)))) <= \
            1e-13 * float(np.sum(np.abs(g) ** (p + 1)))
        order = p + 2 if gains else p
    if not isinstance(order, int | np.integer) or isinstance(order, bool) or order < 1:
        raise ValueError(f"order must be a positive integer, got {order!r}")
    if symmetric:
        check_composition(report.coefficients, order, p)
    elif order > p:
        raise ValueError(
            f"order {order} cannot be checked: only a symmetric composition (palindromic "
            f"coefficients) of a symmetric base gains order by the power conditions; "
            f"declare at most the base's order {p}, or measure it with "
            f"liebody.testing.observed_order and register a Method yourself")
    method = Method(
        name, P.Composition(base_m.recipe, report.coefficients, p), int(order), "composition",
        base_m.symplectic, base_m.reversible and report.palindromic, base_m.keeps_casimir,
        False, base_m.handles, f"{len(report.coefficients)} {base_m.name} steps",
        description=(description or f"User composition of {base_m.name}.") + f" [{report}]")
    return _register(method, replace, stacklevel=3)


#: the torques a user splitting's kicks handle (``Handles`` of :func:`register_splitting`)
_KICK_TORQUE = frozenset({"time", "orientation"})


def _judged_bodies(torque: bool, wheels: bool) -> P.Bodies:
    """A generic body to judge a user splitting's symmetry on (:func:`_symmetric_as_run`):
    asymmetric and rigid, or carrying driven wheels (a rotor momentum that changes in
    time); with a torque of the time and the orientation or none."""
    return P.Bodies(
        moments=np.array([[1.0, 2.0, 3.0]]), momenta=np.array([[1.0, 0.5, -0.7]]),
        model_params=np.zeros((1, 1)), eps=np.zeros(1),
        rotor=np.array([[0.3, -0.2, 0.1]]) if wheels else np.zeros((1, 3)),
        capabilities=Capabilities(_KICK_TORQUE, conservative=False) if torque
        else Capabilities(),
        free_flow="auto", torque_code=S.TORQUE_USER if torque else S.TORQUE_NONE,
        moving_rotor=wheels)


def _symmetric_as_run(recipe: P.FlowSequence) -> bool:
    """Whether a user splitting is symmetric as it runs: its plan, compiled as for a
    run (pieces of one flow merged, pieces that do nothing dropped), reads the same
    backwards on every kind of scene where the compiler merges differently. Those are a
    torque or none (a kick is the identity without one) and a rigid body or driven
    wheels (there a ``T_k`` piece reads the wheels' momentum mid-clock, so pieces of one
    axis merge only with their clocks in proportion); a symmetric body and a gyrostat of
    constant rotor momentum merge as the asymmetric rigid body does. Only the kinds the
    method runs on count: a torque only with kicks, wheels only without ``free``. The
    rotations' reads of moving wheels are not judged here: a symmetric method is refused
    on such a scene where they do not mirror (``FlowSequence.rotor_reads_mirrored``)."""
    recipe = dataclasses.replace(recipe, symmetric=False)  # (judged, not refused)
    names = {name for name, _, _ in recipe.flows}
    for torque in (False, True) if "kick" in names else (False,):
        for wheels in (False,) if "free" in names else (False, True):
            bodies = _judged_bodies(torque, wheels)
            key = int(recipe.keys(bodies, 1.0)[0])
            if not _palindromic_plan(P.plan_of_key(recipe, bodies, 1.0, key)):
                return False
    return True


def _palindromic_plan(plan: P.Plan) -> bool:
    """Whether a plan's stages that act (stages of zero length only advance the clock)
    read the same backwards: kinds, axes and lengths, and the kicks, which read the
    clock at their start, at mirrored times (``c_i + c_j`` = the step's clock, ``c`` the
    clock before a stage)."""
    kinds, axes, coefs = plan.kinds.tolist(), plan.axes.tolist(), plan.coefs.tolist()
    acting, before, clock = [], [], 0.0
    for j, c in enumerate(plan.clock.tolist()):
        if coefs[j] != 0.0:
            acting.append(j)
            before.append(clock)
        clock += c
    last = len(acting) - 1
    for i, j in enumerate(acting):
        m = acting[last - i]
        if kinds[j] != kinds[m] or axes[j] != axes[m] or \
                abs(coefs[j] - coefs[m]) > 1e-15 * max(1.0, abs(coefs[j])):
            return False
        if kinds[j] in (S.KICK, S.KICK_IMPLICIT) and \
                abs(before[i] + before[last - i] - clock) > 1e-14:
            return False
    return True


def register_splitting(name: str, flows, *, order: int | None = None,
                       description: str = "", replace: bool = False) -> Method:
    """Register a splitting made of exact sub-flows (``FlowSequence``).

    Parameters
    ----------
    name
        The new method's name (an identifier).
    flows
        A sequence of ``(flow, fraction)`` or ``(flow, fraction, clock)``: run the exact
        flow ``flow`` for ``fraction * h``, then advance the clock by ``clock * h``.
        ``flow`` is ``"T1"``, ``"T2"``, ``"T3"`` (``T_k = L_k^2 / (2 I_k)``: a rotation
        about body axis ``k``), ``"free"`` (the exact free-body flow), ``"kick"`` (the
        scene's torque alone) or ``"damp"`` (its dissipation alone). Consistency:
        ``T1``, ``T2`` and ``T3`` (or ``free``) each run for one step in all, and so do
        ``kick`` and ``damp`` where present; the clocks add up to one step.
    order
        The order to declare; default 2 for a palindromic sequence (a symmetric
        method), else 1. Symmetry is judged on the sequence as it runs: the plan
        compiled for a generic body of each kind of scene the method runs on (a rigid
        body and driven reaction wheels, with a torque and without), where pieces that
        do nothing are dropped and adjacent pieces of one flow merged (so ``("free",
        0.3), ("free", 0.2)`` counts as ``("free", 0.5)``; a kick that advances the
        clock does not merge with the next kick, which reads the later time; ``damp``
        pieces never merge; on the wheels, ``T_k`` pieces merge only with their clocks
        in proportion to their fractions), must read the same backwards on each: the
        flows, fractions and the times the kicks read. A higher order is checked as for a
        composition: the order conditions (the terms of degree 2 to ``order`` of the
        splitting's Baker-Campbell-Hausdorff logarithm vanish, ``check_splitting``),
        and a false one is refused; a sequence that is not palindromic cannot declare
        more than 1. :func:`liebody.testing.observed_order` measures it. On a rotor
        momentum that changes in time (:class:`~liebody.ReactionWheels`) the rotations
        read it at the middle of their clock advance: a method of order 2 or more whose
        ``T_k`` pieces do not read it at times mirrored about the middle of the step
        (``FlowSequence.rotor_reads_mirrored``) is refused there.
    description, replace
        As for :func:`register`.

    Returns
    -------
    Method
        The registered method. It integrates free bodies, and torqued (or damped)
        scenes when it has kicks (or a dissipation step): its kicks are the exact flow
        of a torque of the orientation and time, so it handles those torques only.

    Examples
    --------
    The Lie–Trotter splitting ``T1(h) T2(h) T3(h)``, first order:

    >>> import liebody
    >>> m = liebody.register_splitting("lie_trotter", [("T1", 1.0), ("T2", 1.0),
    ...                                                ("T3", 1.0, 1.0)])
    >>> m.order, m.reversible
    (1, False)
    """
    recipe = P.FlowSequence(tuple(flows))
    parts = recipe.parts()
    free = parts.get("free", 0.0)
    for k in ("T1", "T2", "T3"):
        total = parts.get(k, 0.0) + free
        if abs(total - 1.0) > 1e-14:
            raise ValueError(f"flows: {k} runs for {total!r} of a step in all (with 'free'); "
                             f"each part of T must run for exactly one step (consistency)")
    for k in ("kick", "damp"):
        if k in parts and abs(parts[k] - 1.0) > 1e-14:
            raise ValueError(f"flows: {k!r} runs for {parts[k]!r} of a step in all; it must "
                             f"run for exactly one step (consistency)")
    clock = math.fsum(c for _, _, c in recipe.flows)
    if "kick" in parts and abs(clock - 1.0) > 1e-14:
        raise ValueError(f"flows: the clocks add up to {clock!r} steps; a step must advance "
                         f"the clock by exactly one step (the kicks of a time-dependent "
                         f"torque read it)")
    sym = _symmetric_as_run(recipe)  # symmetry is a property of what runs
    if order is None:
        order = 2 if sym else 1
    if not isinstance(order, int | np.integer) or isinstance(order, bool) or order < 1:
        raise ValueError(f"order must be a positive integer, got {order!r}")
    if not sym and order > 1:
        raise ValueError(
            f"order {order} cannot be checked for a sequence that is not palindromic (a "
            f"non-symmetric splitting of these flows is first order unless its fractions "
            f"satisfy further conditions); declare order=1, or measure the order with "
            f"liebody.testing.observed_order and register a Method yourself")
    if int(order) >= 2:  # (checked on a rotor momentum that changes in time)
        recipe = dataclasses.replace(recipe, symmetric=True)
    torque = _KICK_TORQUE if "kick" in parts else frozenset()
    handles = Handles(torque, dissipation="damp" in parts)
    rotations = sum(1 for n, _, _ in recipe.flows if n in ("T1", "T2", "T3"))
    method = Method(
        name, recipe, int(order), "splitting", "damp" not in parts, sym,
        True, "free" in parts and rotations == 0 and "kick" not in parts, handles,
        f"{len(recipe.flows)} sub-flows", description=description or "User splitting.")
    return _register(method, replace, stacklevel=3)


# ----------------------------------------------------------------------------------------
# the table
# ----------------------------------------------------------------------------------------


class MethodTable(tuple):
    """The catalogue as an immutable sequence of :class:`Method`, printed as a table."""

    _cols = ("name", "family", "order", "symplectic", "reversible", "keeps_casimir",
             "keeps_energy", "handles", "cost")

    def names(self) -> list[str]:
        return [m.name for m in self]

    def __contains__(self, key) -> bool:
        if isinstance(key, str):
            return any(m.name == key for m in self)
        return super().__contains__(key)

    def __getitem__(self, key):
        if isinstance(key, str):
            for m in self:
                if m.name == key:
                    return m
            raise KeyError(f"unknown method {key!r}; known methods: "
                           f"{', '.join(sorted(self.names()))}")
        return super().__getitem__(key)

    def rows(self) -> Iterator[tuple[str, ...]]:
        for m in self:
            vals = []
            for c in self._cols:
                v = getattr(m, c)
                if c == "order":
                    v = "exact" if math.isinf(v) else str(int(v))
                    if m.weak_order is not None:
                        v += f" (eps h^{int(m.weak_order)})"
                elif c == "handles":
                    v = v.describe()
                elif isinstance(v, bool):
                    v = "yes" if v else "no"
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
    if name.__class__ is str:  # (the common case, at once)
        method = _REGISTRY.get(name)
        if method is not None:
            return method
    if isinstance(name, Method):
        return name
    if not isinstance(name, str):
        raise TypeError(f"method must be a method name (str), got {type(name).__name__}")
    try:
        return _REGISTRY[name]
    except KeyError:
        known = ", ".join(sorted(_REGISTRY))
        raise ValueError(f"unknown method {name!r}; known methods: {known}") from None


def supported(name, scene) -> Method:
    """:func:`get` and :func:`check_supports` in one call: the method ``name`` (a name or
    a :class:`Method`), checked against ``scene``; a name checked before for this scene
    is looked up at once (while the registry still holds that method)."""
    done = _accepted(scene)
    if name.__class__ is str:
        method = done.get(name)
        if method is not None and _REGISTRY.get(name) is method:
            return method
    method = get(name)
    check_supports(method, scene)
    if name.__class__ is str:
        done[name] = method
    return method


def _accepted(scene) -> dict:
    """The scene's memo of the methods :func:`check_supports` accepted for it:
    ``{id(method): method}``, and ``{name: method}`` for those :func:`supported` looked
    up by name (a scene is immutable: the scene contract)."""
    return memo(scene, "supported", dict)


def check_supports(method: Method, scene) -> None:
    """Raise a ``ValueError`` naming the rule when ``method`` cannot integrate ``scene``
    (or when the scene's capabilities and torque model disagree: the scene contract)."""
    done = _accepted(scene)
    if done.get(id(method)) is method:
        return  # checked before
    caps = scene.capabilities
    torqued = scene.torque_model().code != S.TORQUE_NONE
    if bool(caps.torque) != torqued:
        said = f"declares torque {sorted(caps.torque)}" if caps.torque else "declares no torque"
        gives = "a torque model" if torqued else "no torque model (TorqueModel.none())"
        raise ValueError(
            f"the scene {type(scene).__name__} {said} in its capabilities but its "
            f"torque_model() gives {gives}: the methods would disagree on whether it has a "
            f"torque. Make the two agree (the Scene contract in liebody.scenes)")
    rotor = getattr(scene, "rotor_momentum", None)
    if method.sampled and rotor is not None and np.any(np.asarray(rotor) != 0.0):
        raise ValueError(
            f"method {method.name!r} evaluates the rigid body's exact flow at the output "
            f"times; a gyrostat (rotor momentum l, body angular velocity (L - l) / I) is "
            f"stepped: use splitting2 (its default), splitting4/6/8 or a baseline")
    if method.supports(scene):
        done[id(method)] = method
        return
    able = [m.name for m in _REGISTRY.values() if m.supports(scene)]
    hint = ""
    if "momentum" in caps.torque and caps.torque - {"momentum"} <= method.handles.torque:
        hint = (" (a torque that does not read L is declared with orientation_only=True, "
                "which these methods take)")
    raise ValueError(
        f"method {method.name!r} cannot integrate this {type(scene).__name__}: the scene has "
        f"{caps.describe()}, and {method.name} handles {method.handles.describe()} only"
        f"{hint}; methods that can: {', '.join(able)}")
