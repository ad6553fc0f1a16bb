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
from functools import cached_property

import numpy as np

from liebody import _ordering
from liebody._kernels import stages as S

__all__ = ["AxisSplitting", "Baseline", "BestSplitting", "Composition", "DMVFlow",
           "ExactFlow", "FlowSequence", "Plan", "Recipe", "SR2Splitting", "Stage",
           "compile_plan", "compose"]


# ----------------------------------------------------------------------------------------
# the bodies a plan is made for
# ----------------------------------------------------------------------------------------

#: symmetry classes of a body (exact equality: RigidBody has made equal moments equal)
ASYMMETRIC, SPHERICAL = -1, 3  # 0, 1, 2: symmetric about that axis


@dataclass(frozen=True)
class Bodies:
    """What the recipes read of a scene and its initial state, for ``N >= 1`` bodies.

    Every array has a leading body axis: one body is ``N = 1``, an ensemble any ``N``;
    the recipes are written once for both.
    """

    moments: np.ndarray  # (N, 3)
    momenta: np.ndarray  # (N, 3): the initial momenta, read through m0
    #: the torque model's parameter rows, ``(1, k)`` shared by every body or ``(N, k)``
    model_params: np.ndarray
    eps: np.ndarray  # (N,): dissipation strength
    rotor: np.ndarray  # (N, 3): a gyrostat's rotor momentum (body frame), zeros if rigid
    capabilities: object
    free_flow: str
    torque_code: int
    #: the rotor momentum changes in time (reaction wheels): the run code writes it into
    #: the stages' rotor slots (``l(t) = P_L + P_LD (t - P_LT)``), so every body gets the
    #: gyrostat's stages whatever its initial rotor momentum
    moving_rotor: bool = False
    #: what ``free_flow="auto"`` means for the scene's asymmetric rigid bodies (its
    #: ``auto_free_flow``): ``"axes"``, the axis splitting (or SR2 in the compositions),
    #: or ``"exact"``, the elliptic exact flow for fast rotators (:attr:`exact_drift`)
    auto_flow: str = "axes"
    #: the fastest angular rate of the scene's sources about the bodies (its
    #: ``orbit_rate``; 0 where unknown): the time scale :attr:`exact_drift` compares with
    orbit_rate: float = 0.0
    #: set once a recipe has read the initial momenta (shared with the bodies taken)
    orbit_read: list = field(default_factory=lambda: [False], repr=False, compare=False)
    #: the torque model's block shared by every body (1-d, stored once: a gravity
    #: gradient's sources)
    model_shared: np.ndarray = field(default_factory=lambda: _NO_SHARED)

    @property
    def m0(self) -> np.ndarray:
        """The initial momenta ``(N, 3)``. Reading them marks the plan as depending on
        the initial state (:attr:`orbit_read`): a plan that never reads them is the
        same for every initial state and is cached without it."""
        self.orbit_read[0] = True
        return self.momenta

    @classmethod
    def of(cls, scene, m0) -> Bodies:
        """The bodies of ``scene`` (its parameters may carry a leading body axis) and the
        initial momenta ``m0`` (``(3,)`` or ``(N, 3)``), broadcast together."""
        model = scene.torque_model()
        m0 = np.asarray(m0, dtype=float)
        moments = np.asarray(scene.moments, dtype=float)
        mp = model.params
        eps = np.asarray(scene.dissipation, dtype=float)
        rotor = getattr(scene, "rotor_momentum", None)
        rotor = _NO_ROTOR if rotor is None else np.asarray(rotor, dtype=float)
        if (m0.shape == (1, 3) and moments.shape == (3,) and eps.ndim == 0
                and rotor.shape == (3,) and mp.shape[0] == 1):  # one body: no broadcasting
            return cls(moments.reshape(1, 3), m0, mp, eps.reshape(1), rotor.reshape(1, 3),
                       scene.capabilities, scene.free_flow, model.code,
                       bool(getattr(scene, "moving_rotor", False)),
                       auto_flow=getattr(scene, "auto_free_flow", "axes"),
                       orbit_rate=float(getattr(scene, "orbit_rate", 0.0)),
                       model_shared=model.shared)
        n = np.broadcast_shapes(m0.shape[:-1], moments.shape[:-1], eps.shape,
                                rotor.shape[:-1], mp.shape[:1] if mp.shape[0] > 1 else ())
        size = int(np.prod(n)) if n else 1

        def rows(a, width):
            return np.ascontiguousarray(np.broadcast_to(a, n + (width,)).reshape(size, width))

        return cls(rows(moments, 3), rows(m0, 3), mp,
                   np.ascontiguousarray(np.broadcast_to(eps, n).reshape(size)), rows(rotor, 3),
                   scene.capabilities, scene.free_flow, model.code,
                   bool(getattr(scene, "moving_rotor", False)),
                   auto_flow=getattr(scene, "auto_free_flow", "axes"),
                   orbit_rate=float(getattr(scene, "orbit_rate", 0.0)),
                   model_shared=model.shared)

    def __len__(self) -> int:
        return self.moments.shape[0]

    def take(self, idx) -> Bodies:
        out = replace(self, moments=self.moments[idx], momenta=self.momenta[idx],
                      model_params=self._model_rows(idx), eps=self.eps[idx],
                      rotor=self.rotor[idx])
        memo = self.__dict__.get("_orderings")
        if memo:  # the orbits' ordering choices, for the bodies taken
            out.__dict__["_orderings"] = {k: (o[idx], sc[idx]) for k, (o, sc) in memo.items()}
        return out

    def _model_rows(self, idx) -> np.ndarray:
        mp = self.model_params
        return mp if mp.shape[0] == 1 else np.ascontiguousarray(mp[idx])

    @cached_property
    def has_rotor(self) -> bool:
        """Whether any body is a gyrostat (carries rotor momentum, or wheels whose
        momentum changes); computed once (the recipes ask for it at every stage)."""
        if self.rotor.shape == (1, 3):  # one body: three numbers
            return self.moving_rotor or any(v != 0.0 for v in self.rotor[0].tolist())
        return self.moving_rotor or bool(np.any(self.rotor != 0.0))

    @property
    def exact_drift(self) -> np.ndarray:
        """Per body, whether its drift between kicks is the elliptic exact flow: asked for
        (``free_flow="exact"``), or ``"auto"`` on a scene whose ``auto_free_flow`` is the
        exact flow, for a rigid *fast rotator*: ``|omega| >= FAST_ROTATOR`` times the
        scene's ``orbit_rate``, where the exact drift wins the work-precision chart (a
        spacecraft tumbling in its orbit). A body turning about as slowly as its sources
        (a satellite resting in its orbital frame) keeps the axis splitting, cheaper there
        per error and run on the SIMD kernels in an ensemble. Each body's choice is its
        own, so an ensemble's bodies get their one-body calls' plans."""
        n = len(self)
        if self.free_flow == "exact":
            return np.ones(n, dtype=bool)
        if self.free_flow != "auto" or self.auto_flow != "exact" or self.has_rotor:
            return np.zeros(n, dtype=bool)
        if not self.orbit_rate > 0.0:
            return np.ones(n, dtype=bool)
        spin = np.sqrt(np.sum((self.m0 / self.moments) ** 2, axis=1))
        return spin >= FAST_ROTATOR * self.orbit_rate

    def require_rigid(self, what: str) -> None:
        """Refuse a flow that is the rigid body's for a gyrostat, naming it and the way."""
        if self.has_rotor:
            raise ValueError(
                f"{what} is the rigid body's flow, not a gyrostat's (its rotor momentum "
                f"turns the body at (L - l) / I): integrate a gyrostat with the axis "
                f"splittings (splitting2, no_squish, splitting4/6/8 and user splittings of "
                f"T1, T2, T3) or a baseline")

    def orderings(self, pieces_of) -> tuple[np.ndarray, np.ndarray]:
        """:func:`liebody._ordering.best_orderings` of these bodies (index and score per
        body), computed once per splitting family and kept (also by
        :meth:`~liebody.Scene.take`): the recipes read it for the keys and again for
        ``info``. For a gyrostat the choice, made for the rigid body's splitting error,
        does not apply: the first ordering, ``(0, 1, 2)``, and a NaN score."""
        if self.has_rotor:
            return np.zeros(len(self), dtype=np.int64), np.full(len(self), np.nan)
        memo = self.__dict__.setdefault("_orderings", {})
        if pieces_of not in memo:
            memo[pieces_of] = _ordering.best_orderings(pieces_of, self.moments, self.m0)
        return memo[pieces_of]

    @property
    def symmetry(self) -> np.ndarray:
        """``(N,)``: the symmetry axis (0, 1, 2), :data:`SPHERICAL` or :data:`ASYMMETRIC`
        (a gyrostat counts as asymmetric: its rotor breaks the symmetric-body flows)."""
        if self.has_rotor:
            return np.full(len(self), ASYMMETRIC)
        if len(self) == 1:  # one body: the same rules on three numbers
            I0, I1, I2 = self.moments[0].tolist()
            sym = SPHERICAL if I0 == I1 == I2 else 2 if I0 == I1 else 1 if I0 == I2 else \
                0 if I1 == I2 else ASYMMETRIC
            return np.array([sym])
        I0, I1, I2 = self.moments.T
        out = np.full(len(self), ASYMMETRIC)
        out[I1 == I2] = 0
        out[I0 == I2] = 1
        out[I0 == I1] = 2
        out[(I0 == I1) & (I1 == I2)] = SPHERICAL
        return out


def combine(*codes) -> np.ndarray:
    """One integer key per body from small non-negative integer codes (each < 16)."""
    if all(c.__class__ is np.ndarray and c.shape == (1,) for c in codes):
        key = 0  # one body: the same sum in Python integers
        for c in codes:
            key = key * 16 + int(c[0])
        return np.array([key], dtype=np.int64)
    key = np.zeros(np.broadcast_shapes(*(np.shape(c) for c in codes)), dtype=np.int64)
    for c in codes:
        key = key * 16 + np.asarray(c, dtype=np.int64)
    return key


def split(key: int, n: int) -> tuple[int, ...]:
    """The ``n`` codes of a key made by :func:`combine`."""
    out = []
    for _ in range(n):
        key, c = divmod(int(key), 16)
        out.append(c)
    return tuple(reversed(out))


# ----------------------------------------------------------------------------------------
# stages
# ----------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Stage:
    """One stage of a step for a group of bodies: a map of ``kind`` run for ``coef * h``.

    The structure (``kind``, ``coef``, ``clock``, ``axis``) is common to the group; the
    parameters are arrays with a leading body axis (scalars broadcast).

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
    torque
        Torque model code (kicks, baselines); the model's parameters travel apart, in
        :attr:`Plan.model`.
    eps
        Dissipation strength (dissipation, baselines).
    """

    kind: int
    coef: float
    clock: float = 0.0
    axis: int = 0
    rate: object = 0.0
    moments: object = (0.0, 0.0, 0.0)
    torque: int = S.TORQUE_NONE
    eps: object = 0.0
    rotor: object = (0.0, 0.0, 0.0)
    #: the rotor momentum may change in time (``P_LD``): the stage reads it at the
    #: midpoint of its clock interval, so it merges with a neighbour only when their
    #: clocks are in proportion to their lengths (then the merged midpoint rule is the
    #: same integral)
    rotor_moves: bool = False

    def __post_init__(self) -> None:
        if self.kind not in S.KINDS:
            raise ValueError(f"unknown stage kind {self.kind!r}; known: {sorted(S.KINDS)}")
        if self.axis not in (0, 1, 2):
            raise ValueError(f"stage axis must be 0, 1 or 2, got {self.axis!r}")

    def rows(self, n: int) -> np.ndarray:
        """The parameter rows of ``n`` bodies (the named slots of ``stages``): ``(1,
        N_PARAMS)`` when every body has the same parameters (stored once, whatever ``n``),
        else ``(n, N_PARAMS)``; computed once per ``n`` (a stage is immutable), so do not
        write to them."""
        cache = self.__dict__.setdefault("_rows", {})
        p = cache.get(n)
        if p is None and n == 1:  # one body: its row as numbers (a plan's set-up cost)
            row = [0.0] * S.N_PARAMS
            row[S.P_I1:S.P_I3 + 1] = _first(self.moments, 2)
            row[S.P_RATE] = _first(self.rate, 1)
            row[S.P_EPS] = _first(self.eps, 1)
            row[S.P_L1:S.P_L3 + 1] = _first(self.rotor, 2)
            row[S.P_TORQUE] = float(self.torque)
            if len(row) == S.N_PARAMS:  # (else the general path says what is wrong)
                p = cache[n] = np.array([row])
        if p is None:
            fields = ((self.moments, 2), (self.rate, 1), (self.eps, 1), (self.rotor, 2))
            shared = all(_same_for_all(v, rank) for v, rank in fields)
            p = np.zeros((1 if shared else n, S.N_PARAMS))
            for (v, rank), cols in zip(fields, (slice(S.P_I1, S.P_I3 + 1), S.P_RATE, S.P_EPS,
                                                slice(S.P_L1, S.P_L3 + 1)), strict=True):
                v = np.asarray(v, dtype=float)
                p[:, cols] = v[:1] if shared and v.ndim == rank else v
            p[:, S.P_TORQUE] = float(self.torque)
            cache[n] = p
        return p

    def row_key(self) -> tuple:
        """One body's parameter row as a tuple of numbers (equal rows, equal keys)."""
        key = self.__dict__.get("_key")
        if key is None:
            key = self.__dict__["_key"] = tuple(self.rows(1)[0].tolist())
        return key

    def scaled(self, g: float) -> Stage:
        """The stage run for ``g`` times as long (its clock advance scaled alike)."""
        return replace(self, coef=self.coef * g, clock=self.clock * g)

    @property
    def identity(self) -> bool:
        """A stage that does nothing: zero time, or a rotation at zero rate for every body."""
        return self.coef == 0.0 or (S.KINDS[self.kind].rotation
                                    and bool((np.asarray(self.rate) == 0.0).all()))


def _first(value, rank: int):
    """The first body's value of a stage field of ``rank`` dimensions with the body axis
    (a number, or a list for a vector)."""
    a = np.asarray(value, dtype=float)
    return (a[0] if a.ndim == rank else a).tolist()


def _same_for_all(value, rank: int) -> bool:
    """Whether a stage field (a number or vector, or one per body: ``rank`` dimensions
    with the body axis) is the same for every body."""
    a = np.asarray(value)
    return a.ndim < rank or a.shape[0] <= 1 or bool(np.all(a == a[:1]))


def rotation(axis: int, coef: float, rate, recurring: bool = False,
             clock: float = 0.0) -> Stage:
    """Exact flow of ``rate * m_axis^2 / 2``; ``recurring`` when ``m_axis`` is constant."""
    return Stage(S.AXIS_RECURRING if recurring else S.AXIS, coef, clock, axis=axis, rate=rate)


def sphere(coef: float, rate, clock: float = 0.0) -> Stage:
    """Exact flow of ``rate * |m|^2 / 2``."""
    return Stage(S.SPHERE, coef, clock, rate=rate)


# ----------------------------------------------------------------------------------------
# plans
# ----------------------------------------------------------------------------------------


@dataclass
class Plan:
    """A method made concrete for a group of bodies, their initial state and step.

    ``params`` holds the distinct parameter rows of the stages, with a leading body axis:
    ``(N, r, N_PARAMS)``, or ``(1, r, N_PARAMS)`` when every body of the group has the same
    parameters (stored once); stage ``j`` reads row ``slots[j]`` (a composition repeats
    its base's few rows: ``splitting8``'s 52 stages read 2 or 3 rows on a free body, so
    per-body parameters cost ``r`` rows a body, not one per stage). ``model`` holds the torque
    model's parameter rows (``(1, k)`` shared, or ``(N, k)``) and ``model_shared`` its block
    that every body reads (1-d, stored once); the structure (``kinds``,
    ``axes``, ``coefs``, ``clock``, ``merge_ends``) is common. ``family`` is the driver
    family (``stages.F_*``) that runs it; ``info`` records the set-up choices (axis
    ordering, base of a composition, ...), shown as ``Trajectory.info``.
    """

    kinds: np.ndarray
    axes: np.ndarray
    coefs: np.ndarray
    clock: np.ndarray
    params: np.ndarray
    slots: np.ndarray
    merge_ends: bool
    family: int
    info: dict = field(default_factory=dict)
    model: np.ndarray = field(default_factory=lambda: _NO_MODEL)
    model_shared: np.ndarray = field(default_factory=lambda: _NO_SHARED)
    #: the drivers' model token (``dispatch.token``): the one torque model code of the
    #: stage rows, or "any" where they hold several
    token: tuple = (0,)
    #: driver -> its compiled entry point for this plan's argument types, resolved by the
    #: run code on the first call (``_engine.entry_point``; a fresh one for a copy)
    entries: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def model_rows(self, c) -> np.ndarray:
        """The model's parameter rows of the bodies ``c`` (a slice) of this plan."""
        return body_rows(self.model, c)

    @cached_property
    def first(self) -> tuple[np.ndarray, np.ndarray]:
        """The stage parameter rows and the model's parameter row of the first body (views,
        made once: the one-body runs read them on every call)."""
        return self.params[0], self.model[0]

    @property
    def n_stages(self) -> int:
        return int(self.kinds.shape[0])

    @cached_property
    def reach(self) -> tuple[float, float]:
        """The earliest and latest times its stages read, in steps from the step's start:
        ``(0, 1)`` unless a composition with negative weights reaches outside its step
        (Yoshida's triple jump: ``(-0.35, 1.35)``; the failure reports look there for a
        time outside a sampled orbit's span). Made once: every run of a long call, an
        ensemble or a Stepper reads it (a few microseconds to make)."""
        c = np.concatenate(([0.0], np.cumsum(self.clock)))
        return min(0.0, float(c.min())), max(1.0, float(c.max()))

    def with_info(self, info: dict) -> Plan:
        """This plan with another ``info`` (an initial state of the same key): the arrays
        and the resolved entry points are shared."""
        out = object.__new__(Plan)
        out.__dict__.update(self.__dict__)
        out.info = info
        return out


def body_rows(a: np.ndarray, c) -> np.ndarray:
    """The rows of the bodies ``c`` (a slice) of a per-body array, or its one shared row
    (an array of one row stands for every body)."""
    return a if a.shape[0] == 1 else a[c]


#: the rotor momentum of a rigid body
_NO_ROTOR = np.zeros(3)
_NO_ROTOR.flags.writeable = False
#: the parameter block of a scene without a torque model
_NO_MODEL = np.zeros((1, 1))
_NO_MODEL.flags.writeable = False
#: the shared block of a model without one
_NO_SHARED = np.zeros(1)
_NO_SHARED.flags.writeable = False


def compile_plan(stages: list[Stage], info: dict | None = None, n: int = 1,
                 model: np.ndarray | None = None, model_shared: np.ndarray | None = None
                 ) -> Plan:
    """Build a :class:`Plan` for ``n`` bodies: drop identity stages (an advance of the
    clock they carry goes to the stage before), merge adjacent flows of one Hamiltonian
    (for every body of the group); ``model``, ``model_shared``: the torque model's
    parameter rows and shared block."""
    merged: list[Stage] = []
    for st in stages:
        if st.identity:  # e.g. the R rotation of SR2 on a symmetric body
            if st.clock == 0.0:
                continue
            if merged and not merged[-1].rotor_moves:  # (that one reads l(t) mid-clock)
                merged[-1] = replace(merged[-1], clock=merged[-1].clock + st.clock)
                continue
        if merged and _mergeable(merged[-1], st, n):
            both = replace(merged[-1], coef=merged[-1].coef + st.coef,
                           clock=merged[-1].clock + st.clock)
            merged.pop()
            if both.coef != 0.0 or both.clock != 0.0:
                merged.append(both)
            continue
        merged.append(st)
    if not merged:  # a flow that does nothing (e.g. every rate zero)
        merged = [sphere(1.0, 0.0, clock=1.0)]
    kinds = np.array([s.kind for s in merged], dtype=np.int64)
    distinct: list[Stage] = []  # a stage of each distinct parameter row, in order
    slots = np.empty(len(merged), dtype=np.int64)
    for j, st in enumerate(merged):
        slots[j] = next((r for r, d in enumerate(distinct) if _same_params(d, st, n)),
                        len(distinct))
        if slots[j] == len(distinct):
            distinct.append(st)
    rows = [s.rows(n) for s in distinct]
    if all(r.shape[0] == 1 for r in rows):  # shared by every body: stored once
        params = np.stack(rows, axis=1)  # (1, r, P)
    else:
        params = np.stack([np.broadcast_to(r, (n, S.N_PARAMS)) for r in rows], axis=1)
    torques = params[:, :, S.P_TORQUE]
    codes = {int(c) for c in (torques.ravel().tolist() if torques.shape[0] == 1
                              else np.unique(torques))} - {S.TORQUE_NONE}
    code = codes.pop() if len(codes) == 1 else (S.TORQUE_NONE if not codes else -1)
    return Plan(
        kinds=kinds,
        axes=np.array([s.axis for s in merged], dtype=np.int64),
        coefs=np.array([s.coef for s in merged], dtype=np.float64),
        clock=np.array([s.clock for s in merged], dtype=np.float64),
        params=np.ascontiguousarray(params),
        slots=slots,
        merge_ends=len(merged) > 1 and _mergeable(merged[-1], merged[0], n),
        family=S.family_of(kinds),
        info=dict(info or {}),
        model=_NO_MODEL if model is None else model,
        model_shared=_NO_SHARED if model_shared is None else model_shared,
        token=(0,) * (code + 2),  # dispatch.token(code), without importing the kernels
    )


def _mergeable(a: Stage, b: Stage, n: int) -> bool:
    """Flows of the same Hamiltonian for every body: same mergeable kind, axis, parameters;
    ``a`` runs first. A kick reads the clock at its start, so two kicks merge only when
    the first leaves the clock where it was (else the merged one would read the second
    at the first's time)."""
    if not (S.KINDS[a.kind].mergeable and a.kind == b.kind and a.axis == b.axis):
        return False
    if a.kind == S.KICK and a.clock != 0.0:
        return False
    if (a.rotor_moves or b.rotor_moves) and a.coef * b.clock != b.coef * a.clock:
        return False  # l(t) read at different fractions of the two stages' clocks
    return _same_params(a, b, n)


#: a stage's parameter fields and their ranks with the body axis (:meth:`Stage.rows`)
_FIELDS = (("moments", 2), ("rate", 1), ("eps", 1), ("rotor", 2))


def _same_params(a: Stage, b: Stage, n: int) -> bool:
    """Whether two stages have the same parameter row for every one of ``n`` bodies
    (:meth:`Stage.rows`), without making the rows of many: fields held in the same memory
    are equal; others are compared on the first body, then on all."""
    if n == 1:  # one body: its rows as numbers (made once per stage)
        return a.row_key() == b.row_key()
    if a.torque != b.torque:
        return False
    for name, rank in _FIELDS:
        u, v = getattr(a, name), getattr(b, name)
        if u is v:
            continue
        u, v = np.asarray(u, dtype=float), np.asarray(v, dtype=float)
        if _same_memory(u, v):
            continue
        u1, v1 = (u[0] if u.ndim == rank else u), (v[0] if v.ndim == rank else v)
        if not np.array_equal(u1, v1):
            return False
        if (u.ndim == rank or v.ndim == rank) and not np.array_equal(*np.broadcast_arrays(u, v)):
            return False
    return True


def _same_memory(u: np.ndarray, v: np.ndarray) -> bool:
    """Whether two arrays are views of the same numbers (same data, shape and strides)."""
    return (u.shape == v.shape and u.strides == v.strides and u.size > 0
            and u.__array_interface__["data"][0] == v.__array_interface__["data"][0])


def compose(base: list[Stage], coefficients) -> list[Stage]:
    """Stages of the composition ``S(g_s h) ... S(g_1 h)`` of a base step (``g_1`` first)."""
    return [st.scaled(g) for g in coefficients for st in base]


# ----------------------------------------------------------------------------------------
# the free-body pieces (every function takes Bodies: arrays with a leading body axis)
# ----------------------------------------------------------------------------------------


def axis_stages(b: Bodies, ordering, sym: int) -> list[Stage]:
    """``a(h/2) b(h/2) c(h) b(h/2) a(h/2)``: the 5-rotation splitting in ``ordering``.

    ``sym`` is the group's symmetry class: rotations about a symmetry axis (or any axis
    of a sphere) recur every step with the same angle and are applied in increment form.
    """
    a, bb, c = ordering
    inv = 1.0 / b.moments

    def rot(k, coef, clock=0.0):
        if b.has_rotor:  # a gyrostat's axis term, (m_k - l_k)^2 / (2 I_k)
            return Stage(S.AXIS_SHIFTED, coef, clock, axis=k, rate=inv[:, k], rotor=b.rotor,
                         rotor_moves=b.moving_rotor)
        return rotation(k, coef, inv[:, k], sym in (k, SPHERICAL), clock)

    return [rot(a, 0.5), rot(bb, 0.5), rot(c, 1.0, clock=1.0), rot(bb, 0.5), rot(a, 0.5)]


def sr2_stages(b: Bodies, variant, sym: int) -> list[Stage]:
    """``R(h/2) S(h) R(h/2)`` with ``S`` the exact flow of a symmetric body (two stages)."""
    a, bb, c = variant
    inv = 1.0 / b.moments
    rate_r, rate_c = inv[:, bb] - inv[:, a], inv[:, c] - inv[:, a]
    return [rotation(bb, 0.5, rate_r, sym in (bb, SPHERICAL)),
            sphere(1.0, inv[:, a], clock=1.0),
            rotation(c, 1.0, rate_c, sym in (c, SPHERICAL)),
            rotation(bb, 0.5, rate_r, sym in (bb, SPHERICAL))]


def symmetric_flow_stages(b: Bodies, sym: int) -> tuple[list[Stage], str]:
    """The exact flow of spherical or symmetric bodies (trig only).

    A symmetric body (symmetry axis ``s``, transverse moment ``I_perp``) flows as a
    sphere rotation at rate ``1/I_perp`` and a rotation about ``e_s`` at rate
    ``1/I_s - 1/I_perp``; the two commute, so this is exact.
    """
    I = b.moments
    if sym == SPHERICAL:
        return [sphere(1.0, 3.0 / I.sum(axis=1), clock=1.0)], "sphere"
    i_perp = 0.5 * (I[:, (sym + 1) % 3] + I[:, (sym + 2) % 3])
    return [sphere(1.0, 1.0 / i_perp, clock=1.0),
            rotation(sym, 1.0, 1.0 / I[:, sym] - 1.0 / i_perp, recurring=True)], "symmetric"


def exact_stage(b: Bodies) -> Stage:
    b.require_rigid("the exact (elliptic) free flow")
    return Stage(S.EXACT, 1.0, 1.0, moments=b.moments)


#: a body spinning this many times faster than its scene's sources turn about it is a fast
#: rotator: ``free_flow="auto"`` gives it the exact drift where the scene asks for that
#: (:attr:`Bodies.exact_drift`); the work-precision chart of a satellite
#: (``bench/work_precision.py --satellite``) has the exact drift winning at a spin 440
#: times the orbit's rate and losing 2.5-5x at about the orbit's rate
FAST_ROTATOR = 10.0

# choices of the drift between kicks (scene_free_flow)
_DRIFT_SYMMETRIC, _DRIFT_EXACT, _DRIFT_AXES = 0, 1, 2


def drift_keys(b: Bodies, ordering=None) -> np.ndarray:
    """Per body, the drift a splitting uses between kicks: see :func:`drift_stages`."""
    if len(b) == 1:  # one body: the same choice in Python numbers
        sym1, exact = int(b.symmetry[0]), bool(b.exact_drift[0])
        if sym1 != ASYMMETRIC and (b.free_flow != "axes" or sym1 == SPHERICAL):
            choice = _DRIFT_SYMMETRIC
        else:
            choice = _DRIFT_EXACT if exact else _DRIFT_AXES
        order = 0
        if choice == _DRIFT_AXES:
            order = (int(b.orderings(_ordering.axis_pieces)[0][0]) if ordering is None
                     else _ordering.ORDERINGS.index(tuple(ordering)))
        return np.array([(choice * 16 + sym1 + 1) * 16 + order], dtype=np.int64)
    sym = b.symmetry
    flow = b.free_flow
    use_sym = (sym != ASYMMETRIC) & ((flow != "axes") | (sym == SPHERICAL))
    choice = np.where(use_sym, _DRIFT_SYMMETRIC,
                      np.where(b.exact_drift, _DRIFT_EXACT, _DRIFT_AXES))
    if not np.any(choice == _DRIFT_AXES):
        order = np.zeros(len(b), dtype=np.int64)  # no body's drift needs an ordering
    elif ordering is None:
        order, _ = b.orderings(_ordering.axis_pieces)
    else:
        order = np.full(len(b), _ordering.ORDERINGS.index(tuple(ordering)))
    order = np.where(choice == _DRIFT_AXES, order, 0)
    return combine(choice, sym + 1, order)


def drift_stages(b: Bodies, key: int) -> tuple[list[Stage], dict]:
    """The free flow a splitting uses as its drift between kicks.

    A spherical or symmetric body gets its exact flow (trig functions only), unless
    the scene asks for ``free_flow="axes"``; otherwise ``free_flow="exact"`` gives the
    elliptic exact flow and ``"auto"``/``"axes"`` the 5-rotation axis splitting (the
    ordering given, or the best for the orbit of ``m0``), except that ``"auto"`` is the
    exact flow for the fast rotators of scenes whose ``auto_free_flow`` says so
    (:attr:`Bodies.exact_drift`: :class:`~liebody.GravityGradient`).
    """
    choice, sym1, order = split(key, 3)
    sym = sym1 - 1
    if choice == _DRIFT_SYMMETRIC:
        stages, kind = symmetric_flow_stages(b, sym)
        return stages, {"free_flow": kind}
    if choice == _DRIFT_EXACT:
        return [exact_stage(b)], {"free_flow": "elliptic"}
    ordering = _ordering.ORDERINGS[order]
    return axis_stages(b, ordering, sym), {"free_flow": f"axes {ordering}"}


def scene_step(b: Bodies, drift: list[Stage], info: dict) -> tuple[list[Stage], dict]:
    """``side(h/2) drift(h) side(h/2)`` with the scene's torque kick and dissipation step.

    An orientation-only torque gets exact kicks on both sides (merged between steps);
    a torque that depends on the momentum closes the step with the adjoint (implicit)
    kick, so the step stays symmetric; dissipation gets its second-order step ``D``. A
    scene with both nests them, ``K(h/2) D(h/2) drift(h) D(h/2) K(h/2)``: symmetric, so
    second order.
    """
    caps = b.capabilities
    info = dict(info)
    opening, closing = [], []
    if caps.torque:
        kick = Stage(S.KICK, 0.5, torque=b.torque_code)
        opening.append(kick)
        if "momentum" in caps.torque:
            closing.append(replace(kick, kind=S.KICK_IMPLICIT))
            info["kicks"] = "explicit/implicit (L-dependent torque)"
        else:
            closing.append(kick)
    if caps.dissipative:
        damp = Stage(S.DAMP, 0.5, moments=b.moments, eps=b.eps)
        opening.append(damp)
        closing.insert(0, damp)
    return [*opening, *drift, *closing], info


# ----------------------------------------------------------------------------------------
# recipes
# ----------------------------------------------------------------------------------------


class Recipe:
    """How a method builds one step for a group of bodies.

    ``keys(b, h)`` gives each body an integer: bodies with equal keys share the step's
    structure (the stage kinds and axes, e.g. the same axis ordering), and
    ``stages(b, h, key)`` builds that structure for such a group, with per-body
    parameters; it returns the stages and the set-up choices (``info``).
    """

    #: composition coefficients applied to the base (``(1.0,)`` for a base method)
    coefficients: tuple[float, ...] = (1.0,)
    #: whether the stages' parameters depend on the step ``h`` (not only their lengths):
    #: a composition then builds each substep for its own length
    step_dependent: bool = False
    #: whether the stages depend on the initial state only through :meth:`keys` (the
    #: choices of an orbit, such as its axis ordering) and ``info`` only through
    #: :meth:`state_info`: a one-body plan is then shared by every initial state of one
    #: key, with its own ``info``. False (the plan is made per initial state) for a
    #: recipe whose stage parameters vary with the state (Hairer-Vilmart's modified
    #: moments) and for any recipe that does not say
    keyed_by_state: bool = False

    def keys(self, b: Bodies, h: float) -> np.ndarray:
        return np.zeros(len(b), dtype=np.int64)

    def stages(self, b: Bodies, h: float, key: int) -> tuple[list[Stage], dict]:  # pragma: no cover
        raise NotImplementedError

    def state_info(self, b: Bodies, h: float, key: int) -> dict:
        """The entries of ``stages(b, h, key)[1]`` that depend on the initial state beyond
        the key (an orbit's energy-error constant), for a recipe :attr:`keyed_by_state`."""
        return {}


class FreeFlowRecipe(Recipe):
    """A free-body flow; on a torqued or damped scene, the drift of ``side-drift-side``.

    Subclasses give :meth:`free_keys` / :meth:`free` (the method on a free body) and may
    override :meth:`drift_keys` / :meth:`drift` (the free flow between kicks; by default
    the same), and :meth:`free_info` / :meth:`drift_info` (their entries of ``info`` that
    depend on the initial state beyond the key).
    """

    keyed_by_state = True

    def free_keys(self, b: Bodies, h: float) -> np.ndarray:
        return np.zeros(len(b), dtype=np.int64)

    def free(self, b: Bodies, h: float, key: int):  # pragma: no cover
        raise NotImplementedError

    def drift_keys(self, b: Bodies, h: float) -> np.ndarray:
        return self.free_keys(b, h)

    def drift(self, b: Bodies, h: float, key: int):
        return self.free(b, h, key)

    def keys(self, b, h):
        return self.free_keys(b, h) if b.capabilities.free else self.drift_keys(b, h)

    def stages(self, b, h, key):
        if b.capabilities.free:
            return self.free(b, h, key)
        return scene_step(b, *self.drift(b, h, key))

    def free_info(self, b: Bodies, h: float, key: int) -> dict:
        return {}

    def drift_info(self, b: Bodies, h: float, key: int) -> dict:
        return self.free_info(b, h, key)

    def state_info(self, b, h, key):
        if b.capabilities.free:
            return self.free_info(b, h, key)
        return self.drift_info(b, h, key)


def _ordering_keys(b: Bodies, pieces_of, fixed=None):
    """Per body the symmetry class and the index of the ordering (best or ``fixed``)."""
    if fixed is None:
        order, score = b.orderings(pieces_of)
    else:
        order = np.full(len(b), _ordering.ORDERINGS.index(tuple(fixed)))
        score = None
    return combine(b.symmetry + 1, order), score


@dataclass(frozen=True)
class AxisSplitting(FreeFlowRecipe):
    """The 5-rotation splitting ``a(h/2) b(h/2) c(h) b(h/2) a(h/2)``, order 2.

    ``ordering=None`` chooses the ordering whose ``h^2`` energy-error term varies least
    over the orbit (Fassò 2003); a fixed ``(a, b, c)`` is used as given. On torqued
    scenes the drift is :func:`drift_stages`.
    """

    ordering: tuple[int, int, int] | None = None

    def __post_init__(self) -> None:
        if self.ordering is not None and sorted(self.ordering) != [0, 1, 2]:
            raise ValueError(f"ordering must be a permutation of (0, 1, 2), got {self.ordering}")

    def free_keys(self, b, h):
        return _ordering_keys(b, _ordering.axis_pieces, self.ordering)[0]

    def free(self, b, h, key):
        sym1, order = split(key, 2)
        ordering = _ordering.ORDERINGS[order]
        info = {"axis_ordering": ordering, **self.free_info(b, h, key)}
        return axis_stages(b, ordering, sym1 - 1), info

    def free_info(self, b, h, key):
        if self.ordering is not None:
            return {}
        _, score = b.orderings(_ordering.axis_pieces)
        return {"energy_error_constant": _one(score)}

    def drift_keys(self, b, h):
        return drift_keys(b, self.ordering)

    def drift(self, b, h, key):
        return drift_stages(b, key)

    def drift_info(self, b, h, key):
        return {}


def _one(values: np.ndarray):
    """A per-body value for ``info``: the number itself for one body, else the array."""
    return float(values[0]) if len(values) == 1 else values


@dataclass(frozen=True)
class SR2Splitting(FreeFlowRecipe):
    """``R(h/2) S(h) R(h/2)``: exact symmetric-body flow ``S`` plus one axis rotation ``R``.

    Order 2; exact for a symmetric body. The variant is chosen per orbit like the axis
    ordering. Free bodies only (its drift is not defined between kicks).
    """

    def free_keys(self, b, h):
        return _ordering_keys(b, _ordering.sr2_pieces)[0]

    def free(self, b, h, key):
        b.require_rigid("SR2's symmetric-body flow")
        sym1, order = split(key, 2)
        variant = _ordering.ORDERINGS[order]
        return sr2_stages(b, variant, sym1 - 1), {"sr2_variant": variant,
                                                  **self.free_info(b, h, key)}

    def free_info(self, b, h, key):
        _, score = b.orderings(_ordering.sr2_pieces)
        return {"energy_error_constant": _one(score)}

    def drift(self, b, h, key):
        raise ValueError("SR2 has no drift between kicks: it integrates free bodies only")


@dataclass(frozen=True)
class BestSplitting(FreeFlowRecipe):
    """The better second-order base for the orbit: :class:`AxisSplitting` or :class:`SR2Splitting`.

    On torqued (or damped) scenes the same choice is the drift between the kicks, so a
    composition keeps its base when a torque is added: for an asymmetric body with
    ``free_flow="auto"`` the better of SR2 and the axis splitting for the orbit of
    ``m0`` (a weak torque barely moves it off that orbit); ``free_flow="exact"`` or
    ``"axes"``, a symmetric body and a gyrostat as :func:`drift_stages`.
    """

    def free_keys(self, b, h):
        axis_order, s_axis = b.orderings(_ordering.axis_pieces)
        sr2_order, s_sr2 = b.orderings(_ordering.sr2_pieces)
        if len(b) == 1:  # one body: the same key in Python numbers
            use = bool(s_sr2[0] <= s_axis[0]) and not b.has_rotor
            order = int((sr2_order if use else axis_order)[0])
            return np.array([(int(use) * 16 + int(b.symmetry[0]) + 1) * 16 + order],
                            dtype=np.int64)
        use_sr2 = (s_sr2 <= s_axis) & (not b.has_rotor)  # (a gyrostat: the axis splitting)
        return combine(use_sr2, b.symmetry + 1, np.where(use_sr2, sr2_order, axis_order))

    def free(self, b, h, key):
        use_sr2, sym1, order = split(key, 3)
        ordering = _ordering.ORDERINGS[order]
        if use_sr2:
            return sr2_stages(b, ordering, sym1 - 1), {
                "base": "sr2", "sr2_variant": ordering, **self.free_info(b, h, key)}
        return axis_stages(b, ordering, sym1 - 1), {
            "base": "splitting2", "axis_ordering": ordering, **self.free_info(b, h, key)}

    def free_info(self, b, h, key):
        family = _ordering.sr2_pieces if split(key, 3)[0] else _ordering.axis_pieces
        _, score = b.orderings(family)
        return {"energy_error_constant": _one(score)}

    def drift_keys(self, b, h):
        keys = drift_keys(b)
        if len(b) == 1:  # one body: the same choice in Python numbers
            if (b.free_flow != "auto" or b.has_rotor or int(b.symmetry[0]) != ASYMMETRIC
                    or bool(b.exact_drift[0])):
                return keys
            free = int(self.free_keys(b, h)[0])
            return np.array([_DRIFT_SR2_KEYS + free]) if free >> 8 == 1 else keys
        asym = b.symmetry == ASYMMETRIC
        if b.free_flow != "auto" or b.has_rotor or not asym.any():
            return keys  # (a symmetric body's drift reads no orbit: its plan is shared)
        axes = asym & ~b.exact_drift  # (a fast rotator's drift is the exact flow)
        if not axes.any():
            return keys
        free = self.free_keys(b, h)  # combine(use_sr2, symmetry + 1, ordering)
        sr2 = axes & (free >> 8 == 1)
        return np.where(sr2, _DRIFT_SR2_KEYS + free, keys)

    def drift(self, b, h, key):
        if key >= _DRIFT_SR2_KEYS:  # SR2 between the kicks, as on the free body
            stages, info = self.free(b, h, key - _DRIFT_SR2_KEYS)
            return stages, {**info, "free_flow": f"sr2 {info['sr2_variant']}"}
        return drift_stages(b, key)

    def drift_info(self, b, h, key):
        if key >= _DRIFT_SR2_KEYS:
            return self.free_info(b, h, key - _DRIFT_SR2_KEYS)
        return {}


#: offset of BestSplitting's SR2 drift keys (above every key of ``drift_keys``)
_DRIFT_SR2_KEYS = 1 << 12


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

    @property
    def step_dependent(self) -> bool:
        """The preprocessed orders' modified moments depend on ``h``."""
        return self.order > 2

    @property
    def keyed_by_state(self) -> bool:
        """The preprocessed orders' modified moments vary with the initial state."""
        return self.order == 2

    def free(self, b, h, key):
        b.require_rigid("the discrete Moser-Veselov step (RATTLE)")
        if self.order == 2:
            return [Stage(S.DMV, 1.0, 1.0, moments=b.moments)], {}
        mod = dmv_modified_moments(b.moments, b.m0, h, self.order)
        bad = ~np.all(np.isfinite(mod) & (mod > 0.0), axis=1)
        if bad.any():
            i = int(np.argmax(bad))
            which = "" if len(b) == 1 else f" for {int(bad.sum())} of {len(b)} bodies (e.g. " \
                                           f"body {i})"
            raise ValueError(
                f"dt = {h:g} is too large for preprocessed DMV of order {self.order}{which}: "
                f"the modified moments {tuple(round(float(v), 6) for v in mod[i])} are not "
                f"all positive (the h^2 and h^4 corrections of Hairer-Vilmart's series "
                f"dominate); reduce dt")
        info = {"modified_moments": tuple(float(v) for v in mod[0]) if len(b) == 1 else mod}
        return [Stage(S.DMV, 1.0, 1.0, moments=mod)], info

    def drift(self, b, h, key):
        b.require_rigid("the discrete Moser-Veselov step (RATTLE)")
        if self.order != 2:
            raise ValueError("preprocessed DMV integrates free bodies only")
        return [Stage(S.DMV, 1.0, 1.0, moments=b.moments)], {"free_flow": "dmv"}


@dataclass(frozen=True)
class ExactFlow(FreeFlowRecipe):
    """The exact free-body flow as one stage (elliptic functions; trig when symmetric)."""

    def free(self, b, h, key):
        return [exact_stage(b)], {}


@dataclass(frozen=True)
class Composition(Recipe):
    """A symmetric composition ``S(g_s h) ... S(g_1 h)`` of a base recipe of order
    ``base_order`` (2 for the built-in compositions).

    ``coefficients`` are the full list of fractions ``g_i`` of the step given to the
    base, in order (palindromic; ``sum g = 1``).
    """

    base: Recipe
    coefficients: tuple[float, ...]
    base_order: int = 2

    def keys(self, b, h):
        return self.base.keys(b, h)

    def stages(self, b, h, key):
        if self.base.step_dependent:  # each substep built for its own length g h
            subs = [self.base.stages(b, g * h, key) for g in self.coefficients]
            return ([st.scaled(g) for g, (base, _) in zip(self.coefficients, subs, strict=True)
                     for st in base], subs[0][1])
        base, info = self.base.stages(b, h, key)
        return compose(base, self.coefficients), info

    @property
    def step_dependent(self) -> bool:
        return self.base.step_dependent

    @property
    def keyed_by_state(self) -> bool:
        return self.base.keyed_by_state

    def state_info(self, b, h, key):
        if self.base.step_dependent:  # the info of the first substep (see stages)
            return self.base.state_info(b, self.coefficients[0] * h, key)
        return self.base.state_info(b, h, key)


#: the sub-flows a :class:`FlowSequence` is made of
SUB_FLOWS = ("T1", "T2", "T3", "free", "kick", "damp")


@dataclass(frozen=True)
class FlowSequence(Recipe):
    """A splitting written as a sequence of exact sub-flows (a user-defined method).

    ``flows`` is a tuple of ``(flow, fraction, clock)`` (``clock`` may be left out: 0):
    run ``flow`` for ``fraction * h``, then advance the clock by ``clock * h``. The
    flows are the exact flows of

    * ``"T1"``, ``"T2"``, ``"T3"`` — ``T_k = L_k^2 / (2 I_k)`` (a rotation about body axis
      ``k``; on a symmetry axis it recurs every step and runs in increment form);
    * ``"free"`` — the whole free-body Hamiltonian ``T`` (the exact flow);
    * ``"kick"`` — the scene's torque alone (``q`` fixed, ``L += tau N(t, q)``: exact for a
      torque of the orientation and the time; identity on a free body);
    * ``"damp"`` — the double-bracket dissipation alone (:class:`~liebody.DampedBody`).

    :func:`liebody.register_splitting` checks the fractions (each part of the
    Hamiltonian gets a whole step) and the clock (one step in all). ``symmetric``: the
    method declares an order of 2 or more (a symmetric step), which on a rotor momentum
    that changes in time (reaction wheels) needs :attr:`rotor_reads_mirrored`.
    """

    flows: tuple
    symmetric: bool = False

    def __post_init__(self) -> None:
        rows = []
        for item in self.flows:
            if not isinstance(item, tuple | list) or len(item) not in (2, 3):
                raise ValueError(f"each flow must be (flow, fraction) or (flow, fraction, "
                                 f"clock), got {item!r}")
            name, frac = item[0], float(item[1])
            clock = float(item[2]) if len(item) == 3 else 0.0
            if name not in SUB_FLOWS:
                raise ValueError(f"unknown sub-flow {name!r}; known: {', '.join(SUB_FLOWS)}")
            if not (np.isfinite(frac) and np.isfinite(clock)):
                raise ValueError(f"fractions and clocks must be finite, got {item!r}")
            rows.append((name, frac, clock))
        if not rows:
            raise ValueError("a splitting needs at least one sub-flow")
        object.__setattr__(self, "flows", tuple(rows))

    def parts(self) -> dict[str, float]:
        """The total fraction of the step each sub-flow runs for."""
        out: dict[str, float] = {}
        for name, frac, _ in self.flows:
            out[name] = out.get(name, 0.0) + frac
        return out

    @property
    def exact_when_free(self) -> bool:
        """The exact free flow and kicks only: the exact flow on a body without torque."""
        return set(self.parts()) <= {"free", "kick"}

    @property
    def palindromic(self) -> bool:
        """The sequence reads the same backwards (a symmetric method, given symmetric
        sub-flows), kicks included: a kick reads the clock, so mirrored kicks must run at
        mirrored times (``c_i + c_j`` = the step's clock, ``c`` the clock before a
        stage)."""
        seq = [(n, f) for n, f, _ in self.flows]
        if not all(a[0] == b[0] and abs(a[1] - b[1]) <= 1e-15 * max(1.0, abs(a[1]))
                   for a, b in zip(seq, reversed(seq), strict=True)):
            return False
        before, clock = [], 0.0
        for _, _, c in self.flows:
            before.append(clock)
            clock += c
        last = len(self.flows) - 1
        return all(abs(before[i] + before[last - i] - clock) <= 1e-14
                   for i, (name, _, _) in enumerate(self.flows) if name == "kick")

    @property
    def rotor_reads_mirrored(self) -> bool:
        """The rotations read a rotor momentum that changes in time at mirrored times: a
        ``T_k`` piece reads it at the middle of its clock advance (``c + clock / 2``, ``c``
        the clock before it; exact for a momentum linear in time), and the pieces of
        nonzero fraction, read backwards, are the same rotations at ``1 - c`` (the step
        is symmetric about its middle). Without it such a step is first order there."""
        reads, before = [], 0.0
        for name, frac, clock in self.flows:
            if name in ("T1", "T2", "T3") and frac != 0.0:
                reads.append((name, frac, before + 0.5 * clock))
            before += clock
        return all(a[0] == b[0] and abs(a[1] - b[1]) <= 1e-15 * max(1.0, abs(a[1]))
                   and abs(a[2] + b[2] - 1.0) <= 1e-14
                   for a, b in zip(reads, reversed(reads), strict=True))

    keyed_by_state = True

    def keys(self, b, h):
        return b.symmetry + 1  # recurring rotations depend on the symmetry axis

    def stages(self, b, h, key):
        if b.moving_rotor and self.symmetric and not self.rotor_reads_mirrored:
            raise ValueError(
                "its rotations read the rotor (wheel) momentum, which the controls change "
                "in time here, "
                "at times that do not mirror about the middle of the step (a T_k piece "
                "reads it at the middle of its clock advance), so on this scene it is "
                "first order, not the order it declares; advance the clock symmetrically, "
                "as in [('T1', 0.5), ('T2', 0.5), ('T3', 1.0, 1.0), ('T2', 0.5), "
                "('T1', 0.5)], or declare order=1")
        sym = int(key) - 1
        inv = 1.0 / b.moments
        torque_free = not b.capabilities.torque
        out = []
        for name, frac, clock in self.flows:
            if name in ("T1", "T2", "T3"):
                k = int(name[1]) - 1
                if b.has_rotor:
                    out.append(Stage(S.AXIS_SHIFTED, frac, clock, axis=k, rate=inv[:, k],
                                     rotor=b.rotor, rotor_moves=b.moving_rotor))
                else:
                    out.append(rotation(k, frac, inv[:, k], sym in (k, SPHERICAL), clock))
            elif name == "free":
                b.require_rigid("the exact (elliptic) free flow")
                out.append(Stage(S.EXACT, frac, clock, moments=b.moments))
            elif name == "kick":
                if not torque_free:
                    out.append(Stage(S.KICK, frac, clock, torque=b.torque_code))
                elif clock != 0.0:  # nothing to kick; the clock still advances (the
                    out.append(sphere(0.0, 0.0, clock=clock))  # rotor's read times)
            else:
                out.append(Stage(S.DAMP, frac, clock, moments=b.moments, eps=b.eps))
        return out, {"flows": self.flows}


@dataclass(frozen=True)
class Baseline(Recipe):
    """A classical one-stage method on ``(q, L)``: torque and dissipation inside the stage."""

    kind: int
    keyed_by_state = True

    def __post_init__(self) -> None:
        if self.kind not in (S.EULER, S.RK4, S.LIE_EULER, S.RKMK4):
            raise ValueError(f"not a baseline stage kind: {self.kind!r}")

    def stages(self, b, h, key):
        return [Stage(self.kind, 1.0, 1.0, moments=b.moments, torque=b.torque_code,
                      eps=b.eps, rotor=b.rotor)], {}


def plan_groups(recipe: Recipe, b: Bodies, h: float) -> list[tuple[np.ndarray, Plan]]:
    """The recipe's plans for the bodies ``b``: one per group of bodies whose steps share
    a structure, with the indices of its bodies.

    Bodies that carry a rotor and bodies that do not (a gyrostat ensemble with a zero
    rotor momentum for some) are planned apart, each as its one-body call is: a rigid
    body gets its own axis ordering and flows, not the gyrostat's ``(0, 1, 2)``
    (:attr:`Bodies.has_rotor` speaks for the bodies it is asked about). The gyrostats
    first: a method that refuses them refuses the ensemble as a gyrostat, not with a
    refusal of the rigid bodies' step that numbers a body by its place among them."""
    if len(b) > 1 and not b.moving_rotor and b.rotor.shape[0] == len(b):
        rows = np.any(b.rotor != 0.0, axis=1)
        if rows.any() and not rows.all():
            out = []
            for sel in (np.flatnonzero(rows), np.flatnonzero(~rows)):
                out += [(sel[idx], plan) for idx, plan in plan_groups(recipe, b.take(sel), h)]
            return out
    keys = np.asarray(recipe.keys(b, h))
    out = []
    for key in (keys.tolist() if len(keys) == 1 else np.unique(keys)):
        idx = np.flatnonzero(keys == key)
        sub = b if len(idx) == len(b) else b.take(idx)
        out.append((idx, plan_of_key(recipe, sub, h, int(key))))
    return out


def plan_of_key(recipe: Recipe, b: Bodies, h: float, key: int) -> Plan:
    """The recipe's plan for the bodies ``b``, which share the key ``key``."""
    stages, info = recipe.stages(b, h, key)
    return compile_plan(stages, info, len(b), b.model_params, b.model_shared)


# ----------------------------------------------------------------------------------------
# Hairer-Vilmart modified moments
# ----------------------------------------------------------------------------------------


def dmv_modified_moments(moments, m0, h: float, order: int) -> np.ndarray:
    """Hairer–Vilmart modified moments ``1/I_i^mod = CSS / I_i + CDD``, for ``(N, 3)`` bodies.

    ``CSS = 1 + sum_k s_k(N, H)`` and ``CDD = sum_k d_k(N, H)``, with homogeneous
    polynomials of degree ``k = 1 .. order/2 - 1`` in ``N = h^2 |m|^2 / 2`` and
    ``H = h^2 sum m_i^2 / (2 I_i)`` whose coefficients are the rational functions of the
    moments of Hairer & Vilmart (J. Phys. A 39 (2006) 13225, Table 1, and their
    DMV10 routine for orders 8 and 10). They depend only on the invariants, so they
    are computed once per run. Returns ``(N, 3)``.
    """
    moments = np.atleast_2d(np.asarray(moments, dtype=float))
    m = np.atleast_2d(np.asarray(m0, dtype=float))
    # the map is homogeneous (I -> s I, m -> s m gives I_mod -> s I_mod): evaluate it in
    # units where the moments' geometric mean is 1, so that det^4 and I^-4 neither
    # overflow nor underflow for any moments RigidBody accepts (1e-100 .. 1e100)
    scale = np.exp(np.mean(np.log(moments), axis=1))[:, None]
    moments, m = moments / scale, m / scale
    I1, I2, I3 = moments[:, 0], moments[:, 1], moments[:, 2]
    N = 0.5 * h * h * np.sum(m * m, axis=1)
    H = 0.5 * h * h * np.sum(m * m / moments, axis=1)
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
    return np.stack([1.0 / (css / I + cdd) for I in (I1, I2, I3)], axis=1) * scale
