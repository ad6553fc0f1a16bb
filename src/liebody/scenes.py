"""Scenes: what is integrated — a rigid body and what acts on it.

A scene is modelled with no more than it needs: a :class:`FreeBody` has no torque
kicks and its default method is the exact flow; a symmetric body's splittings use the
symmetric-body flow. Methods are matched to scenes by what the scene *declares*
(its :class:`Capabilities`), never by its class name, so subclasses and new scenes
work with every method that can handle them.

The scene contract
------------------
Everything :func:`liebody.integrate` accepts is a :class:`Scene`. A scene provides

* ``body`` — the :class:`~liebody.RigidBody` (principal frame = body frame);
* ``capabilities`` — a :class:`Capabilities` record: what the torque depends on
  (nothing, the orientation, the momentum, the time), whether it derives from a
  potential (conservative), whether there is dissipation;
* ``potential(q)`` — the potential energy at orientations ``q`` ``(..., 4)`` (zeros
  when there is none), used by the energy diagnostics; for a scene whose parameters
  have a body axis (``batch_shape`` ``(N,)``) the body axis comes first, ``q``
  ``(N, ..., 4)``, and the result is ``(N, ...)``;
* ``torque_model()`` — how the kernels evaluate the torque: a :class:`TorqueModel`
  (none, uniform gravity, or a user's numba function through
  :meth:`TorqueModel.user`);
* ``dissipation`` — the strength ``eps`` of the double-bracket dissipation (0: none);
* ``controls`` — the number of control inputs ``u`` the torque takes (0: none;
  :class:`ControlledBody`);
* ``free_flow`` — the drift of the splittings for an asymmetric body (``"auto"``,
  ``"axes"`` or ``"exact"``) and ``default_method``.

A scene is immutable once made: liebody caches what it derives from a scene (the plans
of the methods, the torque model, the capabilities), keyed on the scene object, so a
parameter changed afterwards would not be seen. Make a new scene instead (the built-in
scenes are frozen dataclasses). The capabilities and the torque model must agree: a
declared torque needs a torque model, and a torque model a declared torque (checked on
every run).

The scenes below implement it. The easy way to a new scene is a subclass of
one of them (a gravity-gradient satellite is a :class:`TorqueBody` whose torque
function is built in ``__init__``; a top with a different mass distribution is a
:class:`HeavyTop`); a direct subclass of :class:`Scene` implements the members above.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from liebody._kernels.stages import (
    TORQUE_GRAVITY,
    TORQUE_GRAVITY_GRADIENT,
    TORQUE_NONE,
    TORQUE_USER,
)
from liebody._validate import as_float_array, as_positive_float
from liebody.rigid_body import RigidBody

__all__ = ["Capabilities", "ControlledBody", "DampedBody", "FreeBody", "GravityGradient",
           "HeavyTop", "Scene", "TorqueBody", "TorqueModel"]

#: what a torque may depend on
DEPENDENCIES = ("time", "orientation", "momentum")
#: drifts of the splittings for an asymmetric body
FREE_FLOWS = ("auto", "axes", "exact")


@dataclass(frozen=True)
class Capabilities:
    """What a scene needs from a method.

    Attributes
    ----------
    torque : frozenset of str
        What the torque depends on, a subset of ``{"time", "orientation",
        "momentum"}``; empty for a torque-free body.
    conservative : bool
        The torque derives from a potential of the orientation alone, so the total
        energy is conserved (true for a free body).
    dissipative : bool
        The scene dissipates energy internally (:class:`DampedBody`).
    """

    torque: frozenset = frozenset()
    conservative: bool = True
    dissipative: bool = False

    def __post_init__(self) -> None:
        torque = frozenset(self.torque)
        unknown = torque - set(DEPENDENCIES)
        if unknown:
            raise ValueError(f"torque dependencies must be among {DEPENDENCIES}, "
                             f"got {sorted(unknown)}")
        object.__setattr__(self, "torque", torque)
        if self.dissipative and self.conservative:
            raise ValueError("a dissipative scene is not conservative")

    @property
    def free(self) -> bool:
        """No torque and no dissipation: the free rigid body."""
        return not self.torque and not self.dissipative

    def describe(self) -> str:
        """Words for error messages and tables, e.g. ``"torque(t, q, L)"``."""
        if self.free:
            return "no torque"
        parts = []
        if self.torque:
            args = [a for a, d in (("t", "time"), ("q", "orientation"), ("L", "momentum"))
                    if d in self.torque]
            parts.append(f"torque({', '.join(args)})")
        if self.dissipative:
            parts.append("dissipation")
        return " and ".join(parts)


#: prefix of the instance attributes that memoise what a (frozen) scene derives from its
#: parameters; :meth:`Scene.take` drops them
_MEMO = "_memo_"


def _memo(scene, name: str, make, *args):
    """``make(*args)`` computed once per scene (scenes are frozen: their parameters never
    change) and kept on the instance."""
    d = vars(scene)
    key = _MEMO + name
    try:
        return d[key]
    except KeyError:
        d[key] = value = make(*args)
        return value


#: the capabilities of the built-in scenes, made once (read on every call)
_FREE = Capabilities()
_GRAVITY = Capabilities(torque=frozenset({"orientation"}), conservative=True)
_DAMPED = Capabilities(conservative=False, dissipative=True)
_GRAVITY_GRADIENT = Capabilities(torque=frozenset({"time", "orientation"}), conservative=False)


def _block(params) -> np.ndarray:
    """A model's parameter blocks as a read-only C-contiguous ``(rows, k)`` float64 array:
    ``(k,)`` becomes one shared row."""
    p = np.array(params, dtype=np.float64, ndmin=1)
    if p.ndim == 1:
        p = p[None, :]
    if p.shape[1] == 0:
        p = np.zeros((p.shape[0], 1))
    p = np.ascontiguousarray(p)
    p.flags.writeable = False  # a scene memoises its model: shared, never written
    return p


def _shared(values) -> np.ndarray:
    """A model's block shared by every body as a read-only 1-d float64 array (one zero
    for none)."""
    p = np.array(values, dtype=np.float64, ndmin=1).reshape(-1)
    if p.size == 0:
        p = np.zeros(1)
    p.flags.writeable = False
    return p


#: the shared block of a model without one
_NO_SHARED = _shared(0.0)


@dataclass(frozen=True)
class TorqueModel:
    """How the kernels evaluate a scene's torque (part of the scene contract).

    ``code`` names the physics model (a ``TORQUE_*`` code; the kernels of each model live
    in a module of its own under ``liebody._models``), ``params`` is the model's parameter
    block, ``(1, k)`` shared by every body or ``(N, k)`` one row per body, ``shared`` the
    numbers every body reads, stored once whatever ``params`` is (a gravity gradient's
    sources: ``(s,)``, one zero for a model without them), and for a user
    torque ``address`` is the address of its compiled C callback and ``function`` the
    user's own ``@njit`` function (which the Python side calls to check it and to report
    its errors), taking ``controls`` control inputs and, when ``takes_params``, the
    body's parameter row. Build one with :meth:`none`, :meth:`gravity`,
    :meth:`gravity_gradient` or :meth:`user`.
    """

    code: int = TORQUE_NONE
    params: np.ndarray = field(default_factory=lambda: _block(0.0))
    shared: np.ndarray = field(default_factory=lambda: _NO_SHARED)
    address: int = 0
    function: object = None
    controls: int = 0
    takes_params: bool = False
    #: the potential depends on the time: the energy is not conserved (a Hamiltonian of
    #: its own, the Jacobi integral, may be), and the energy diagnostics are NaN
    time_dependent: bool = False
    #: the times at which the model's data are known (sampled orbits), ``None`` for all
    span: tuple | None = None

    @classmethod
    def none(cls) -> TorqueModel:
        return cls()

    @classmethod
    def gravity(cls, weight_arm) -> TorqueModel:
        """Uniform gravity ``-g e_z`` on a body whose ``M g cm`` is ``weight_arm`` (``(3,)``,
        or ``(N, 3)`` for a batch)."""
        return cls(TORQUE_GRAVITY, _block(weight_arm))

    @classmethod
    def gravity_gradient(cls, moments, sources, span=None) -> TorqueModel:
        """Point masses on orbits (:class:`GravityGradient`): the principal ``moments``
        (``(3,)``, or ``(N, 3)`` per body) and the ``sources`` block shared by every body,
        as laid out by ``liebody._models.gravity_gradient``; ``span`` the times the sampled
        orbits cover."""
        return cls(TORQUE_GRAVITY_GRADIENT, _block(moments), _shared(sources),
                   time_dependent=True, span=span)

    @classmethod
    def user(cls, torque, controls: int = 0, params=None) -> TorqueModel:
        """A numba ``@njit`` function ``torque(t, q, L) -> (3,)``; with ``params`` (``(k,)``
        shared or ``(N, k)`` per body) ``torque(t, q, L, p)``; with ``controls = k``
        control inputs ``u`` last (compiled once per process)."""
        takes = params is not None
        return cls(TORQUE_USER, _block(0.0 if params is None else params),
                   address=_callback(torque, controls, takes), function=torque,
                   controls=controls, takes_params=takes)

    @property
    def block_address(self) -> int:
        """The address of the user torque's callback for many bodies at once (the SIMD
        drivers'; ``user_torque.adapt_user_block``), compiled on first use; 0 for the
        built-in models, which the SIMD kernels evaluate themselves."""
        if self.function is None:
            return 0
        return _callback(self.function, self.controls, self.takes_params, block=True)

    def driver_address(self, simd: bool) -> int:
        """The callback address a driver takes: the block callback for the SIMD drivers,
        the one-body callback otherwise."""
        return self.block_address if simd else self.address

    def row(self, i: int = 0) -> np.ndarray:
        """Body ``i``'s parameter row (the shared row when there is one)."""
        return self.params[0 if self.params.shape[0] == 1 else i]

    def __call__(self, t: float, q: np.ndarray, L: np.ndarray, u=None, i: int = 0
                 ) -> np.ndarray:
        """The user torque of body ``i`` at one state, called from Python (``u``: the
        controls, zero when not given); raises what the torque raises."""
        args = [t, q.copy(), L.copy()]
        if self.takes_params:
            args.append(self.row(i))  # (read-only, as the kernels pass it)
        if self.controls:
            args.append(np.zeros(self.controls) if u is None
                        else np.array(u[:self.controls], dtype=float))
        return self.function(*args)

    @property
    def signature(self) -> str:
        """How the torque is called, e.g. ``"spin(t, q, L, u)"``, for messages."""
        name = getattr(self.function, "__name__", "torque")
        extra = (", p" if self.takes_params else "") + (", u" if self.controls else "")
        return f"{name}(t, q, L{extra})"


#: the torque model of a scene without torque (immutable, shared)
_NO_TORQUE = TorqueModel()


class Scene:
    """Base class of the scenes; see the module docstring for the contract."""

    default_method: ClassVar[str] = "splitting2"
    body: RigidBody
    free_flow: str = "auto"
    #: parameters that may be given per body, with the rank of one body's value
    #: (0: a number, 1: a vector); ``take`` slices them
    per_body: ClassVar[dict[str, int]] = {}
    #: number of control inputs ``u`` the torque takes (:class:`ControlledBody`)
    controls: int = 0
    #: the rotor momentum changes in time (:class:`~liebody.ReactionWheels`)
    moving_rotor: ClassVar[bool] = False

    def __getstate__(self) -> dict:
        """The parameters, without what the scene memoised: a user torque's model holds
        the address of a callback compiled in this process, meaningless in another
        (a Dask worker unpickling the scene makes its own)."""
        return {k: v for k, v in vars(self).items() if not k.startswith(_MEMO)}

    def take(self, idx) -> Scene:
        """The scene of bodies ``idx`` (a slice or an index array) of a batched scene;
        unbatched parameters are shared, and so is a parameter of one row in a batch of
        more bodies (it broadcasts; an integer ``idx`` gets its row). Used to split an
        ensemble into chunks."""
        import copy

        batch = self.batch_shape
        many = bool(batch) and batch[0] > 1
        single = np.ndim(idx) == 0 and not isinstance(idx, slice)
        out = copy.copy(self)
        for key in [k for k in vars(out) if k.startswith(_MEMO)]:
            del vars(out)[key]  # derived from the parameters that change here
        if self.body.shape:
            one_row = many and self.body.shape[0] == 1
            if single or not one_row:
                object.__setattr__(out, "body", self.body[0 if one_row else idx])
        for name, rank in self.per_body.items():
            value = getattr(self, name)
            if np.ndim(value) > rank:
                value = np.asarray(value)
                one_row = many and value.shape[0] == 1
                if one_row and not single:
                    continue
                part = value[0 if one_row else idx]
                if np.ndim(part) == 0:  # one body by an integer index: a plain number
                    part = float(part)
                else:
                    part = part.copy()
                    part.flags.writeable = False
                object.__setattr__(out, name, part)
        return out

    @property
    def capabilities(self) -> Capabilities:  # pragma: no cover - abstract
        raise NotImplementedError(f"{type(self).__name__} must define capabilities")

    @property
    def moments(self) -> np.ndarray:
        return self.body.moments

    @property
    def batch_shape(self) -> tuple[int, ...]:
        """``()`` for one body; ``(N,)`` when the scene's parameters describe ``N`` bodies
        (a :meth:`liebody.RigidBody.batch`, or per-body parameters of a torqued scene)."""
        return self.body.shape

    @property
    def dissipation(self):
        """Strength ``eps`` of the internal dissipation (0 for none; ``(N,)`` per body)."""
        return 0.0

    def potential(self, q: np.ndarray) -> np.ndarray:
        """Potential energy at orientations ``q`` ``(..., 4)``; zero unless overridden."""
        return np.zeros(np.shape(q)[:-1])

    def torque_model(self) -> TorqueModel:
        """How the kernels evaluate the torque (none unless overridden)."""
        return _NO_TORQUE


def _init_body(scene: Scene, body, free_flow: str) -> None:
    """Shared constructor part: the body and the drift choice."""
    if not isinstance(body, RigidBody):
        raise TypeError(f"body must be a liebody.RigidBody, got {type(body).__name__}")
    if free_flow not in FREE_FLOWS:
        raise ValueError(f"free_flow must be one of {FREE_FLOWS}, got {free_flow!r}")
    object.__setattr__(scene, "body", body)
    object.__setattr__(scene, "free_flow", free_flow)


@dataclass(frozen=True, eq=False)
class FreeBody(Scene):
    """A torque-free rigid body: Euler's equations with ``N = 0`` (Hand & Finch,
    *Analytical Mechanics*, ch. 8: the force-free symmetric top, stability of rotation
    about the principal axes).

    Invariants: kinetic energy ``T = sum L_i^2 / (2 I_i)``, ``|L|`` and the spatial
    angular momentum ``L_space = R(q) L``.

    Default method: ``"exact"``. The free body is integrable, so the exact flow
    (trig functions for a symmetric body, Jacobi elliptic functions otherwise) is
    evaluated directly at the output times: no time stepping is spent and there is
    no discretisation error at all. Name a method to study integrators.
    """

    body: RigidBody

    default_method: ClassVar[str] = "exact"

    def __post_init__(self) -> None:
        _init_body(self, self.body, "auto")

    @property
    def capabilities(self) -> Capabilities:
        return _FREE


@dataclass(frozen=True, init=False, eq=False)
class HeavyTop(Scene):
    """A rigid body with one point fixed at the origin in uniform gravity ``-g e_z``.

    Hand & Finch, *Analytical Mechanics*, ch. 8 (the heavy symmetric top). The
    potential is ``V = mass * g * (R(q) cm) . e_z`` and the body-frame torque
    ``Gamma x (mass g cm)`` with ``Gamma = R(q)^T e_z``. A symmetric body with ``cm`` on
    its symmetry axis is the Lagrange top (see :mod:`liebody.lagrange_top`); an
    asymmetric body or an off-axis ``cm`` is a general heavy top and works as well.

    Parameters
    ----------
    body
        The body, its inertia taken **about the fixed point** (use
        :func:`liebody.inertia.parallel_axis` to move it from the centre of mass).
    mass
        Total mass (> 0).
    cm
        Centre of mass in the body (principal) frame, measured from the fixed point.
    g
        Gravitational acceleration (> 0).
    free_flow
        The drift of the splittings for an asymmetric body: ``"auto"``/``"axes"``, the
        5-rotation axis splitting (cheapest), or ``"exact"``, the elliptic exact flow
        (dearer per step, no splitting error in the free part). A symmetric body
        gets its exact flow unless ``"axes"`` is asked for.

    Default method: ``"splitting2"``, kick(h/2) – free flow(h) – kick(h/2): the gravity
    kick is exact (the torque depends on the orientation only) and the free flow is the
    exact symmetric-body flow for a Lagrange top (trig functions only), the cheapest
    (axis) splitting otherwise. Symplectic, time-reversible, energy error bounded,
    ``L_z`` (space) kept to round-off, and for a Lagrange top ``L_3`` (body) too. Known
    failure: step-size resonance when ``h`` times the nutation frequency nears ``2 pi``.
    """

    body: RigidBody
    mass: float | np.ndarray
    cm: np.ndarray
    g: float | np.ndarray
    free_flow: str

    per_body: ClassVar[dict[str, int]] = {"mass": 0, "cm": 1, "g": 0}

    def __init__(self, body: RigidBody, mass, cm, g=9.81, free_flow: str = "auto") -> None:
        _init_body(self, body, free_flow)
        cm_arr = as_float_array("cm", cm, last_dim=3).copy()
        mass_arr = _positive("mass", mass)
        g_arr = _positive("g", g)
        for name, a in (("cm", cm_arr[..., 0]), ("mass", mass_arr), ("g", g_arr)):
            if np.ndim(a) > 1:
                raise ValueError(f"{name} must be one value per body at most, got shape "
                                 f"{np.shape(a)}")
        try:
            np.broadcast_shapes(body.shape, cm_arr.shape[:-1], np.shape(mass_arr),
                                np.shape(g_arr))
        except ValueError:
            raise ValueError(
                f"the body ({body.shape[0] if body.shape else 1} bodies), mass "
                f"{np.shape(mass_arr)}, cm {cm_arr.shape} and g {np.shape(g_arr)} must "
                f"describe the same number of bodies") from None
        _check_weight(mass_arr, g_arr, cm_arr)
        cm_arr.flags.writeable = False
        object.__setattr__(self, "mass", mass_arr)
        object.__setattr__(self, "cm", cm_arr)
        object.__setattr__(self, "g", g_arr)

    @property
    def capabilities(self) -> Capabilities:
        return _GRAVITY

    @property
    def batch_shape(self) -> tuple[int, ...]:
        return _memo(self, "batch_shape", lambda: np.broadcast_shapes(
            self.body.shape, self.cm.shape[:-1], np.shape(self.mass), np.shape(self.g)))

    @property
    def weight_arm(self) -> np.ndarray:
        """The weight arm ``c = mass * g * cm`` in the body frame, ``(N, 3)`` per body: the
        potential is ``V = c·Gamma``."""
        return (np.asarray(self.mass) * np.asarray(self.g))[..., None] * self.cm

    def potential(self, q: np.ndarray) -> np.ndarray:
        """The potential ``V = mass g (R(q) cm)·e_z = c·Gamma`` at orientations ``q`` ``(..., 4)``.

        ``q`` is normalised first: the potential of the rotation it stands for (the
        baselines let ``|q|`` drift). For a batch of tops, ``q`` has the body axis first
        (``(N, ..., 4)``).
        """
        from liebody import quaternion

        gamma = quaternion.rotate_inverse(quaternion.normalize(q), [0.0, 0.0, 1.0])
        return np.sum(gamma * _per_body(self.weight_arm, gamma), axis=-1)

    def torque_model(self) -> TorqueModel:
        return _memo(self, "torque_model", lambda: TorqueModel.gravity(self.weight_arm))

    def __repr__(self) -> str:
        if self.batch_shape:
            return f"{type(self).__name__}(<batch of {self.batch_shape[0]} tops>)"
        return (f"{type(self).__name__}(body={self.body!r}, mass={self.mass:g}, "
                f"cm={self.cm.tolist()}, g={self.g:g})")


@dataclass(frozen=True, init=False, eq=False)
class TorqueBody(Scene):
    """A rigid body under a user torque ``torque(t, q, L)`` (body frame).

    Parameters
    ----------
    body
        The body.
    torque
        A numba ``@njit`` function ``torque(t, q, L)`` of the time, the orientation
        (scalar-first unit quaternion, ``(4,)`` array) and the body angular momentum
        (``(3,)`` array), returning the body-frame torque (3 numbers).
    potential
        Optional ``potential(q) -> float`` (``potential(t, q, p)`` with ``params``) for a
        conservative, orientation-only torque; energy diagnostics then include it, and
        the scene counts as conservative. A ``potential(t, q, p)`` that depends on ``t``
        (:attr:`time_dependent_potential`) makes the scene not conservative: the energy
        changes by the integral of ``dV/dt``, it is not checked at the end of a run and
        the energy diagnostics are NaN (``potential(q, t)`` evaluates it). With
        ``orientation_only`` (and no controls) the torque must be minus the derivative of
        the potential under a body-frame rotation, ``N = -dV/d(eps)`` for ``q -> q exp(eps
        / 2)``: checked by central differences at two orientations (body 0, the middle and
        the last body; ``ValueError`` otherwise) when the scene is first run.
    params
        Optional parameters of the torque: an array ``(k,)`` shared by every body, or
        ``(N, k)`` one row per body (the inertia of each Monte Carlo case, say). With
        ``params`` the torque is ``torque(t, q, L, p)`` (and ``torque(t, q, L, p, u)`` for
        a :class:`ControlledBody`), ``p`` the body's row, read-only (the run's own
        numbers: a torque that writes to ``p`` is refused with ``TypeError``; copy it to
        change numbers), and a batch of rows makes the scene an ensemble of ``N`` bodies.
    orientation_only
        Promise that the torque does not depend on ``L`` (it may depend on ``t`` and
        ``q``). Then each kick (``q`` fixed, ``L += dt * torque``) is the exact flow of the
        torque, and consecutive kicks are merged. Otherwise (the default) a step closes
        with the adjoint, implicit kick ``L' = L + dt * torque(t, q, L')`` (solved by
        fixed-point iteration), which keeps the splittings symmetric.
        :func:`liebody.integrate` checks the promise at the start of each run (the torque
        at ``L0`` and at ``2 L0 + 1``, same ``t`` and ``q``, must agree; else
        ``ValueError``), and the scene checks it for every row of ``params`` at a probe
        state when it is first run.
    free_flow
        As for :class:`HeavyTop`.

    Guarantees. The splittings (and their compositions) have their declared order
    for any smooth torque. Only for a conservative torque that depends on the
    orientation alone are the splittings and ``rattle`` symplectic with a bounded
    energy error; for a torque that depends on ``L`` (or dissipates) they are
    consistent, symmetric methods with no further geometric guarantee.
    """

    body: RigidBody
    torque: object
    potential_fn: object
    params: np.ndarray | None
    orientation_only: bool
    free_flow: str

    per_body: ClassVar[dict[str, int]] = {"params": 1}

    def __init__(self, body: RigidBody, torque, potential=None, params=None,
                 orientation_only: bool = False, free_flow: str = "auto") -> None:
        _init_body(self, body, free_flow)
        if params is not None:
            params = _user_params(params, body)
        _check_user_torque(torque, self.controls, params)
        if potential is not None and not callable(potential):
            sig = "potential(t, q, p)" if params is not None else "potential(q)"
            raise TypeError(f"potential must be a callable {sig} -> float or None")
        if not isinstance(orientation_only, bool):
            raise TypeError("orientation_only must be True or False")
        object.__setattr__(self, "torque", torque)
        object.__setattr__(self, "potential_fn", potential)
        object.__setattr__(self, "params", params)
        object.__setattr__(self, "orientation_only", orientation_only)

    def take(self, idx) -> TorqueBody:
        """As :meth:`Scene.take`; bodies of a scene whose torque passed its checks pass
        them (their rows are among the scene's: not checked again, at every run of an
        ensemble that plans its body 0 apart), and the bodies' potential is time-dependent
        as the scene's is (the same conservative flag for every part)."""
        out = super().take(idx)
        for name in ("checked", "time_dependent_potential"):
            if _MEMO + name in vars(self):
                vars(out)[_MEMO + name] = vars(self)[_MEMO + name]
        return out

    @property
    def batch_shape(self) -> tuple[int, ...]:
        rows = () if self.params is None or self.params.ndim == 1 else self.params.shape[:1]
        return np.broadcast_shapes(self.body.shape, rows)

    @property
    def capabilities(self) -> Capabilities:
        return _memo(self, "capabilities", self._capabilities)

    def _capabilities(self) -> Capabilities:
        deps = {"time", "orientation"} | (set() if self.orientation_only else {"momentum"})
        conservative = (self.potential_fn is not None and self.orientation_only
                        and not self.time_dependent_potential)
        return Capabilities(torque=frozenset(deps), conservative=conservative)

    #: the times and orientations at which :attr:`time_dependent_potential` compares a
    #: potential ``(t, q, p)`` (generic numbers: no common potential is periodic in them)
    _PROBE_TIMES: ClassVar[tuple] = (0.0, 0.3183098861837907, 2.718281828459045, 31.3)
    _PROBE_Q: ClassVar[tuple] = ((0.8792968436751748, 0.2398082300932295,
                                  -0.35971234513984424, 0.1998401917443579),
                                 (0.5, -0.5, 0.5, 0.5))

    @property
    def time_dependent_potential(self) -> bool:
        """Whether the potential ``potential(t, q, p)`` depends on ``t``: its finite values
        differ between the probe times (``_PROBE_TIMES``) at a probe orientation, for
        body 0, the middle body or the last. Such a scene is not conservative (its energy
        changes by the integral of ``dV/dt``): the end-of-run energy check is not made and
        the energy diagnostics are NaN, as for a :class:`GravityGradient`. False without
        ``params`` (``potential(q)`` has no time) or without a potential."""
        return _memo(self, "time_dependent_potential", self._probe_time_dependence)

    def _probe_time_dependence(self) -> bool:
        if self.potential_fn is None or self.params is None:
            return False
        rows = self.params.reshape(-1, self.params.shape[-1])
        for i in sorted({0, len(rows) // 2, len(rows) - 1}):
            p = rows[i]
            for q in self._PROBE_Q:
                q = np.array(q)
                try:
                    values = [float(self.potential_fn(t, q, p)) for t in self._PROBE_TIMES]
                except Exception:  # (the run's check of the potential reports it)
                    continue
                if all(map(math.isfinite, values)) and len(set(values)) > 1:
                    return True
        return False

    def potential(self, q: np.ndarray, t=0.0) -> np.ndarray:
        """The user's potential at orientations ``q`` ``(..., 4)`` and times ``t`` (a number,
        or an array broadcast against ``q``'s leading axes, as for
        :class:`GravityGradient`: ``potential(traj.q, traj.t)`` is the potential along a
        run; zeros without a potential). With per-body ``params`` ``(N, k)``, ``q`` has the
        body axis first (``(N, ..., 4)``) and body ``i``'s row is passed."""
        q = np.asarray(q, dtype=float)
        if self.potential_fn is None:
            return np.zeros(q.shape[:-1])
        if self.params is None:
            flat = q.reshape(-1, 4)
            vals = np.fromiter((float(self.potential_fn(row)) for row in flat), float,
                               len(flat))
            return vals.reshape(q.shape[:-1])
        try:
            t = np.broadcast_to(np.asarray(t, dtype=float), q.shape[:-1])
        except ValueError:
            raise ValueError(f"t of shape {np.shape(t)} does not broadcast against the "
                             f"orientations q {q.shape[:-1]} (one time per orientation, or "
                             f"one for all)") from None
        rows = self.params.reshape(-1, self.params.shape[-1])
        if rows.shape[0] > 1 and (q.ndim < 2 or q.shape[0] != rows.shape[0]):
            raise ValueError(f"q must have the body axis first, (N, ..., 4) with N = "
                             f"{rows.shape[0]} (one per row of params), got shape {q.shape}")
        out = None if rows.shape[0] == 1 else np.empty(q.shape[:-1])
        for i in range(rows.shape[0]):  # (one row for every body, or body i's)
            qi, ti = (q, t) if rows.shape[0] == 1 else (q[i], t[i])
            p = rows[i]
            vals = np.fromiter((float(self.potential_fn(tk, row, p)) for row, tk in
                                zip(qi.reshape(-1, 4), ti.reshape(-1).tolist(), strict=True)),
                               float, ti.size)
            if rows.shape[0] == 1:
                out = vals.reshape(q.shape[:-1])
            else:
                out[i] = vals.reshape(ti.shape)
        return out

    def torque_model(self) -> TorqueModel:
        key = _MEMO + "torque_model"
        model = vars(self).get(key)
        if model is None:  # (made outside _memo's KeyError handler: a refusal reads alone)
            model = vars(self)[key] = self._torque_model()
        return model

    def _torque_model(self) -> TorqueModel:
        import dataclasses

        model = TorqueModel.user(self.torque, self.controls, self.params)
        if self.orientation_only and not vars(self).get(_MEMO + "checked"):
            self._check_promise(model)
            if self.potential_fn is not None and not self.controls:
                self._check_gradient(model)
            vars(self)[_MEMO + "checked"] = True
        if self.time_dependent_potential or (self.controls and self.potential_fn is not None):
            # the energy diagnostics NaN: the kernels cannot call a Python potential, and
            # without it the running 'energy' would be the kinetic energy alone
            model = dataclasses.replace(model, time_dependent=True)
        return model

    #: the state and controls at which :meth:`_check_promise` compares the torque of every
    #: row of ``params`` at ``L`` and ``2 L + 1`` (generic numbers)
    _PROBE_L: ClassVar[tuple] = (0.37, -1.1, 0.83)
    _PROBE_U: ClassVar[tuple] = (0.7, -0.4, 0.25, 0.6, -0.9, 0.15)

    def _check_gradient(self, model: TorqueModel) -> None:
        """The torque must be minus the derivative of the potential under a body-frame
        rotation, ``N = -dV/d(eps)`` with ``q -> q exp(eps / 2)``: checked at ``t = 0`` at
        the probe orientations for body 0, the middle and the last body, by central
        differences (step 1e-5 rad; relative tolerance 1e-3, far above their error, far
        below a sign, a factor or a torque in the space frame). A potential that raises or
        is not finite there is not judged (the run's check reports it). Else
        ``ValueError``: the energy diagnostics would follow another system's energy, and
        the end-of-run check blame the step."""
        from liebody import quaternion

        h = 1e-5
        c, s = math.cos(h / 2.0), math.sin(h / 2.0)
        # q exp(+-h e_k / 2) = q (c, +-s e_k), k = 0, 1, 2, for each probe orientation
        steps = np.array([[c, *(sk * e)] for e in np.eye(3) for sk in (s, -s)])
        turned = [quaternion.multiply(q, steps) for q in self._PROBE_Q]
        rows = model.params.reshape(-1, model.params.shape[-1])
        for i in sorted({0, len(rows) // 2, len(rows) - 1}):
            p = rows[i]

            def V(r, p=p):
                r = np.array(r)
                return float(self.potential_fn(r) if self.params is None
                             else self.potential_fn(0.0, r, p))

            for (w, x, y, z), turns in zip(self._PROBE_Q, turned, strict=True):
                try:
                    grad = np.array([(V(a) - V(b)) / (2.0 * h)
                                     for a, b in zip(turns[0::2], turns[1::2], strict=True)])
                    size = abs(V((w, x, y, z)))
                    torque = np.asarray(model(0.0, np.array([w, x, y, z]),
                                              np.array(self._PROBE_L), None, i), dtype=float)
                except Exception:  # (the run's checks report it)
                    continue
                if not (np.isfinite(grad).all() and math.isfinite(size)
                        and torque.shape == (3,) and np.isfinite(torque).all()):
                    continue
                off = np.linalg.norm(torque + grad)
                if off <= 1e-3 * (np.linalg.norm(torque) + np.linalg.norm(grad)) + 1e-8 * size:
                    continue
                who = f" (body {i}, row {i} of params)" if len(rows) > 1 else ""
                raise ValueError(
                    f"the torque {model.signature} is not minus the derivative of the "
                    f"potential{who}: at t = 0, q = {[w, x, y, z]} it gives "
                    f"{torque.tolist()}, and -dV/d(eps) is {(-grad).tolist()} (q -> q exp(eps "
                    f"/ 2), a rotation in the body frame; central differences). The potential "
                    f"of a conservative torque N gives N = -dV/d(eps): check its signs and "
                    f"factors, and that the torque is in the body frame; or give no potential")

    def _check_promise(self, model: TorqueModel) -> None:
        """``orientation_only=True`` for every body: the torque of each row of ``params``
        at a probe state must not change from ``L`` to ``2 L + 1`` (``integrate()`` checks
        body 0 at its initial state; a torque whose ``L`` term is scaled by a row, zero in
        body 0's, ran the other bodies' implicit-kick torque with explicit kicks, at order
        1, without a word). One compiled call over the rows; else ``ValueError``."""
        from liebody._models.user_torque import broken_promise

        q, m = np.array(self._PROBE_Q[0]), np.array(self._PROBE_L)
        u = np.array(self._PROBE_U)
        i = int(broken_promise(model.address, 0.0, q, m, u, model.params))
        if i < 0:
            return
        a = np.asarray(model(0.0, q, m, u, i), dtype=float).tolist()
        b = np.asarray(model(0.0, q, 2.0 * m + 1.0, u, i), dtype=float).tolist()
        who = f" for body {i} (row {i} of params)" if model.params.shape[0] > 1 else ""
        at = f", u = {u[:self.controls].tolist()}" if self.controls else ""
        raise ValueError(
            f"orientation_only=True, but the torque {model.signature} depends on L{who}: "
            f"at t = 0, q = {q.tolist()}{at} it gives {a} at L = {m.tolist()} and {b} at "
            f"L = 2 L + 1. orientation_only=True promises a torque of t, q (and u) alone, "
            f"whose kicks are then explicit and exact; for a torque that depends on L, pass "
            f"orientation_only=False (the default: implicit kicks, the method's order kept)")


@dataclass(frozen=True, init=False, eq=False)
class ControlledBody(TorqueBody):
    """A rigid body under a torque ``torque(t, q, L, u)`` of the state and control inputs.

    The control inputs ``u`` (``controls`` float64 numbers) are what a digital controller
    sets: :class:`liebody.Stepper` takes them between steps (``stepper.u = ...``) and
    :func:`liebody.integrate` for a whole run (``controls=``). They are held constant
    over each step (a zero-order hold): within a step the torque may still depend on
    ``t``, ``q`` and ``L`` (a magnetorquer's ``m x B(t, q)``, say), but ``u`` is the
    value set before the step.

    Parameters
    ----------
    body
        The body.
    torque
        A numba ``@njit`` function ``torque(t, q, L, u)`` of the time, the orientation
        (scalar-first unit quaternion, ``(4,)``), the body angular momentum ``(3,)``
        and the control inputs ``(controls,)``, returning the body-frame torque (3
        numbers). A reaction-wheel or thruster torque commanded directly is
        ``return u.copy()`` (with ``controls=3``).
    controls
        Number of control inputs, 1 to 6. ``u`` holds exactly that many: numba does not
        check bounds, so a torque that reads beyond ``u[controls - 1]`` reads memory
        that is not ``u`` (compile the torque with ``@njit(boundscheck=True)`` while
        developing it to catch that). The constructor calls the torque's Python code once
        on ``u = 0`` and refuses one that raises ``IndexError`` there (``ValueError``
        saying how many entries ``u`` has).
    potential, params, orientation_only, free_flow
        As for :class:`TorqueBody` (with ``params``, ``torque(t, q, L, p, u)``).
        ``orientation_only=True`` promises that the torque does not depend on ``L`` (``u``
        and ``t`` are allowed): kicks are then explicit and exact. The controls do work,
        so a controlled body is not conservative, with a potential or without:
        ``Trajectory.energy`` includes the potential, no energy is checked at the end of a
        run, and with a potential the energy diagnostics are NaN.

    Examples
    --------
    A spacecraft commanded by three body-axis torques:

    >>> import numpy as np
    >>> from numba import njit
    >>> import liebody as lb
    >>> @njit
    ... def commanded(t, q, L, u):
    ...     return u.copy()
    >>> craft = lb.ControlledBody(lb.RigidBody([1200.0, 1100.0, 800.0]), commanded,
    ...                           controls=3, orientation_only=True)
    """

    controls: int

    def __init__(self, body: RigidBody, torque, controls: int, potential=None, params=None,
                 orientation_only: bool = False, free_flow: str = "auto") -> None:
        from liebody._kernels.stages import N_CONTROLS

        if isinstance(controls, bool) or not isinstance(controls, int | np.integer):
            raise TypeError(f"controls must be an integer (the number of control inputs), "
                            f"got {type(controls).__name__}")
        if not 1 <= controls <= N_CONTROLS:
            raise ValueError(f"controls must be 1 to {N_CONTROLS}, got {controls}")
        object.__setattr__(self, "controls", int(controls))
        super().__init__(body, torque, potential=potential, params=params,
                         orientation_only=orientation_only, free_flow=free_flow)

    def _capabilities(self) -> Capabilities:
        # the controls do work: no potential makes the energy a constant of the run
        return Capabilities(torque=super()._capabilities().torque, conservative=False)


@dataclass(frozen=True, init=False, eq=False)
class GravityGradient(Scene):
    """A rigid body in the gravity field of point masses on orbits: the gravity-gradient
    torque.

    Each source ``k`` is a pair ``(GM_k, orbit_k)``: its gravitational parameter and a
    :mod:`liebody.orbits` orbit giving its position ``r_k(t)`` seen from the body's centre
    of mass (inertial frame). With ``r_k`` in the body frame (``R(q)^T r_k``) the torque
    is ``tau = sum_k 3 GM_k / r_k^5 (r_k x I r_k)`` and the potential
    ``V = sum_k 3 GM_k / (2 r_k^5) r_k^T I r_k`` (MacCullagh's formula; the terms free of
    the orientation are left out). The Earth below a satellite, the Sun and the Moon on
    the Earth: any number of sources.

    Parameters
    ----------
    body
        The body (its inertia about the centre of mass); a :meth:`liebody.RigidBody.batch` makes an
        ensemble with per-body inertia (the sources are held once for all its bodies, each
        body its three moments).
    sources
        A sequence of ``(GM, orbit)`` pairs (``GM > 0``), the orbits
        :class:`~liebody.orbits.Circular`, :class:`~liebody.orbits.Kepler` or sampled
        :class:`~liebody.orbits.Table` ones in any mix. A table covers a span of times
        only (:attr:`time_span`): a run that leaves it stops with a torque failure.
    free_flow
        The drift of the splittings between the kicks: ``"exact"``, the exact free flow
        (elliptic functions for an asymmetric body, trig functions only for a symmetric
        one); ``"axes"``, the 5-rotation axis splitting (cheaper per step, with a
        splitting error in the free motion); ``"auto"`` (the default), the exact flow for
        a fast rotator, a body spinning at least ten times faster than the sources turn
        about it (:attr:`orbit_rate`), and the axis splitting for the others, each body by
        its own initial state.

    Default method: ``"splitting2"`` as kick(h/2) – exact free flow(h) – kick(h/2) for a
    fast rotator, and ``splitting4/6/8`` compose the same step (``auto_free_flow =
    "exact"``). A
    satellite or a planet turns fast under a weak torque: the free motion is most of
    the motion, and its exact flow leaves only the small error of splitting off the
    torque. On the spacecraft of the method guide (``I = (100, 120, 80)``, tumbling
    near its intermediate axis at 0.5 rad/s in low Earth orbit, one day) this is the
    cheapest method at 1e-2 rad (17 times cheaper than ``rk4``), while the axis
    splitting between the kicks is still 0.027 rad off after 6.9 million steps (the
    chart: ``python -m bench.work_precision --satellite``, in the method guide). For
    tighter accuracy take ``saba2``, ``saba3`` or ``saba4`` (Laskar & Robutel's SABA_n:
    the exact free flow between kicks at the Gauss-Legendre nodes, error
    ``O(eps h^(2n) + eps^2 h^2)`` for a torque of relative strength ``eps``), the
    cheapest at 1e-4 and 1e-6 rad there. A satellite librating slowly about its orbital
    frame gains nothing from the exact drift, so a body turning about as slowly as its
    orbit keeps the axis splitting, which an ensemble runs on the SIMD kernels. A
    gyrostat keeps the axis splitting (the exact flow is the rigid body's).

    The torque depends on the orientation and the time only, so a kick with ``q`` fixed
    is its exact flow: the splittings and their compositions are symplectic (for the
    time-dependent Hamiltonian) and of their declared order, ``rattle`` likewise. The
    energy is not conserved (the sources move); for one source on a circular orbit the
    Jacobi integral, the energy in the frame turning with the orbit, is
    (:meth:`jacobi_integral`). ``Trajectory.diagnostics``' energy error is NaN.
    """

    body: RigidBody
    sources: tuple
    free_flow: str
    #: what ``free_flow="auto"`` means here: the exact free flow between the kicks, for a
    #: fast rotator (``liebody._plan.FAST_ROTATOR``: a spin ten times the sources' rate)
    auto_free_flow: ClassVar[str] = "exact"

    def __init__(self, body: RigidBody, sources, free_flow: str = "auto") -> None:
        from liebody.orbits import Orbit

        _init_body(self, body, free_flow)
        if isinstance(sources, tuple) and len(sources) == 2 and isinstance(sources[1], Orbit):
            sources = [sources]  # one (GM, orbit) pair
        try:
            pairs = list(sources)
        except TypeError:
            raise TypeError("sources must be a sequence of (GM, orbit) pairs") from None
        if not pairs:
            raise ValueError("sources must hold at least one (GM, orbit) pair")
        out = []
        for k, pair in enumerate(pairs):
            if not (isinstance(pair, tuple | list) and len(pair) == 2):
                raise TypeError(f"sources[{k}] must be a (GM, orbit) pair, got {pair!r}")
            GM, orbit = pair
            GM = as_positive_float(f"sources[{k}] GM", GM)
            if not isinstance(orbit, Orbit):
                raise TypeError(f"sources[{k}]: the orbit must be a liebody.orbits orbit "
                                f"(Circular, Kepler, Table), got {type(orbit).__name__}")
            out.append((GM, orbit))
        object.__setattr__(self, "sources", tuple(out))

    @property
    def capabilities(self) -> Capabilities:
        return _GRAVITY_GRADIENT

    def _sources_block(self) -> np.ndarray:
        """The model's block shared by every body: the number of sources, then each
        source's ``GM`` and orbit row (``liebody._models.gravity_gradient``)."""
        return np.concatenate([[float(len(self.sources))]]
                              + [np.concatenate([[GM], orbit.row]) for GM, orbit in self.sources])

    def torque_model(self) -> TorqueModel:
        return _memo(self, "torque_model", lambda: TorqueModel.gravity_gradient(
            self.body.moments, self._sources_block(),
            None if self.time_span == (-math.inf, math.inf) else self.time_span))

    @property
    def orbit_rate(self) -> float:
        """The fastest angular rate of the sources about the body: a conic's mean motion, a
        table's largest ``|r x dr/dt| / |r|^2`` between its samples. A body spinning ten
        times faster or more is a fast rotator, whose default drift is the exact flow."""
        def rate(orbit) -> float:
            t = getattr(orbit, "t", None)
            if t is None:
                return float(orbit.mean_motion)
            r = orbit.r
            v = np.diff(r, axis=0) / np.diff(t)[:, None]
            mid = 0.5 * (r[1:] + r[:-1])
            return float(np.max(np.linalg.norm(np.cross(mid, v), axis=1)
                                / np.sum(mid * mid, axis=1)))

        return _memo(self, "orbit_rate", lambda: max(rate(o) for _, o in self.sources))

    @property
    def time_span(self) -> tuple[float, float]:
        """The times at which every source's position is known: the intersection of the
        :class:`~liebody.orbits.Table` orbits' spans (``(-inf, inf)`` without tables). A
        run that leaves it stops there with a torque failure (the torque is NaN)."""
        lo, hi = -math.inf, math.inf
        for _, orbit in self.sources:
            span = getattr(orbit, "span", None)
            if span is not None:
                lo, hi = max(lo, span[0]), min(hi, span[1])
        return lo, hi

    def potential(self, q: np.ndarray, t=0.0) -> np.ndarray:
        """The potential at orientations ``q`` ``(..., 4)`` and times ``t`` (broadcast
        against ``q``'s leading axes); a batch of bodies takes the body axis first."""
        from liebody._models.dispatch import potentials

        q = as_float_array("q", q, last_dim=4)
        t = np.broadcast_to(as_float_array("t", t), q.shape[:-1])
        model = self.torque_model()
        rows = model.params
        flat_q = np.ascontiguousarray(q.reshape(-1, 4))
        mp = rows if rows.shape[0] == 1 else np.ascontiguousarray(np.broadcast_to(
            _per_body(rows, q), q.shape[:-1] + rows.shape[-1:]).reshape(-1, rows.shape[-1]))
        out = np.empty(flat_q.shape[0])
        potentials(model.code, mp, model.shared, np.ascontiguousarray(t.reshape(-1)), flat_q,
                   out)
        return out.reshape(q.shape[:-1])

    def jacobi_integral(self, traj) -> np.ndarray:
        """The Jacobi integral ``J = T + V(t, q) - n k . L_space`` at every sample of
        ``traj`` (one source on a :class:`~liebody.orbits.Circular` orbit of mean motion
        ``n`` and plane normal ``k``): the energy in the frame that turns with the orbit,
        conserved by the exact flow (``(..., n_samples)``)."""
        from liebody import quaternion
        from liebody.orbits import Circular

        if len(self.sources) != 1 or not isinstance(self.sources[0][1], Circular):
            raise ValueError("the Jacobi integral exists for one source on a Circular orbit; "
                             f"this scene has {len(self.sources)} source(s): "
                             f"{[type(o).__name__ for _, o in self.sources]}")
        orbit = self.sources[0][1]
        q, L, t = traj.q, traj.L, traj.t
        moments = _per_body(np.asarray(self.body.moments, dtype=float), L)
        T = 0.5 * np.sum(L * L / moments, axis=-1)
        V = self.potential(q, np.broadcast_to(t, q.shape[:-1]))
        Ls = quaternion.rotate(quaternion.normalize(q), L)
        return T + V - orbit.n * (Ls @ orbit.normal)

    def __repr__(self) -> str:
        src = ", ".join(f"({GM:g}, {o!r})" for GM, o in self.sources)
        return f"{type(self).__name__}(body={self.body!r}, sources=[{src}])"


@dataclass(frozen=True, init=False, eq=False)
class DampedBody(Scene):
    """A free body with internal dissipation that keeps ``|L|`` and lowers the energy.

    Double-bracket form (body frame): ``dL/dt = L x omega + eps L x (L x omega)``, i.e.
    the body turns with ``omega + eps L x omega`` while the spatial ``L`` stays fixed.
    ``|L|`` is kept, ``dT/dt = -eps |L x omega|^2 <= 0``, and the body ends up spinning
    about its axis of largest moment, where ``T = |L|^2 / (2 I_max)`` is least: the
    spin-stabilised spacecraft of Hand & Finch, ch. 8 (stability of rotation about the
    principal axes; Explorer 1 started about its long axis and tumbled).

    This is the double-bracket dissipation of A. Bloch, P. S. Krishnaprasad, J. E.
    Marsden & T. S. Ratiu, "The Euler–Poincaré equations and double bracket
    dissipation", Commun. Math. Phys. 175 (1996) 1–42.

    Default method: ``"splitting2"``, D(h/2) – free flow(h) – D(h/2), second order.
    The dissipative part alone, ``L_i' = eps (2T - |L|^2 / I_i) L_i``, is a replicator
    equation for ``p_i = L_i^2 / |L|^2`` and has the exponential solution
    ``L_i(t) ∝ L_i(0) exp(-eps |L|^2 t / I_i)`` (normalised to ``|L|``); the step D
    uses it, so ``L`` is exact in D, and turns ``q`` by the shortest arc that keeps the
    spatial ``L`` (``O(h^3)`` from the exact orientation, about ``L`` only). D is
    stable for any ``eps h``: ``|L|`` and the spatial ``L`` are kept to round-off, the
    energy never rises within D, and a stiff dissipation (``eps |L|^2 h`` large) puts
    the body on its largest-moment axis at once instead of overshooting. The free flow
    keeps the energy exactly with ``free_flow="exact"`` and to ``O(h^2)`` with the axis
    splitting. ``free_flow`` as for :class:`HeavyTop`.
    """

    body: RigidBody
    eps: float | np.ndarray
    free_flow: str

    per_body: ClassVar[dict[str, int]] = {"eps": 0}

    def __init__(self, body: RigidBody, eps, free_flow: str = "auto") -> None:
        _init_body(self, body, free_flow)
        eps = _positive("eps", eps)
        try:
            if np.ndim(eps) > 1:
                raise ValueError
            np.broadcast_shapes(body.shape, np.shape(eps))
        except ValueError:
            raise ValueError(f"eps must be one value, or one per body, got shape "
                             f"{np.shape(eps)} for {body.shape[0] if body.shape else 1} "
                             f"bodies") from None
        object.__setattr__(self, "eps", eps)

    @property
    def batch_shape(self) -> tuple[int, ...]:
        return np.broadcast_shapes(self.body.shape, np.shape(self.eps))

    @property
    def capabilities(self) -> Capabilities:
        return _DAMPED

    @property
    def dissipation(self) -> float:
        return self.eps


def _check_weight(mass, g, cm: np.ndarray) -> None:
    """A heavy top's weight arm ``mass * g * cm`` and its length must be finite (the
    kernels' torque and potential, and the energy, are built from them)."""
    with np.errstate(over="ignore", invalid="ignore"):
        mg = np.asarray(mass, dtype=float) * np.asarray(g, dtype=float)
        arm = mg[..., None] * cm
        size = np.asarray(mg) * np.linalg.norm(cm, axis=-1)
        bad = ~(np.isfinite(arm).all(axis=-1) & np.isfinite(size))
    if not bad.any():
        return
    if bad.ndim == 0:
        who, m, gg, c = "", float(mass), float(g), cm
    else:
        i = int(np.argmax(bad))
        who = f"body {i}: "
        m = float(np.broadcast_to(mass, bad.shape)[i])
        gg = float(np.broadcast_to(g, bad.shape)[i])
        c = np.broadcast_to(cm, (*bad.shape, 3))[i]
    raise ValueError(
        f"{who}mass * g * |cm| must be finite (the weight arm of the torque and the "
        f"potential), but mass = {m:.6g}, g = {gg:.6g}, cm = {c.tolist()} overflow float64; "
        f"rescale the units of mass, length or time")


def _user_params(params, body: RigidBody) -> np.ndarray:
    """A user torque's parameters: ``(k,)`` shared by every body or ``(N, k)`` one row per
    body, finite float64 (read-only copy)."""
    p = np.array(as_float_array("params", params), dtype=np.float64)
    if p.ndim not in (1, 2) or p.shape[-1] == 0:
        raise ValueError(f"params must be an array (k,) shared by every body or (N, k) one "
                         f"row per body, k >= 1, got shape {p.shape}")
    if p.ndim == 2:
        n = body.shape[0] if body.shape else None
        if p.shape[0] == 0:
            raise ValueError(f"params of shape {p.shape} have no rows: give one row per body "
                             f"(N, k), one row for all (1, k) or a (k,) array")
        if n is not None and p.shape[0] not in (n, 1):
            raise ValueError(f"params of shape {p.shape} give {p.shape[0]} rows, but the body "
                             f"describes {n} bodies: give one row per body or a (k,) array")
    p.flags.writeable = False
    return p


def _check_user_torque(torque, controls: int, params=None) -> None:
    """A user torque is an ``@njit`` function giving 3 real numbers on a test call.

    Refused: not a numba function (``TypeError``); compiled in object mode, or returning
    complex, boolean, string or object values (``TypeError``: the kernels' callback cannot call
    it); a test call that raises or gives another shape (``ValueError``); and, with
    controls or parameters, Python code that raises ``IndexError`` on the test inputs
    (``ValueError`` saying how many entries ``u`` and ``p`` have: compiled, numba does not
    check bounds and would read other memory); with parameters, a torque that writes to
    ``p`` (``TypeError``: ``p`` is passed read-only, the run's own row).
    """
    args = "t, q, L" + (", p" if params is not None else "") + (", u" if controls else "")
    from numba.core.config import DISABLE_JIT  # @njit gives plain functions then

    if not (hasattr(torque, "py_func") or (DISABLE_JIT and callable(torque))):
        raise TypeError(f"torque must be a numba @njit function torque({args}) returning "
                        f"the body-frame torque, got {type(torque).__name__}")
    test = (0.0, np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3))
    if params is not None:  # read-only, as the kernels pass it (the run's own row)
        row = np.ascontiguousarray(params.reshape(-1, params.shape[-1])[0])
        row.flags.writeable = False
        test += (row,)
    if controls:
        test += (np.zeros(controls),)
    try:
        tau = np.asarray(torque(*test))
    except Exception as exc:
        if params is not None and _writes_read_only(exc):
            raise TypeError(
                f"torque({args}) writes to p, the body's row of params: p is read-only (the "
                f"run's parameters, kept by the scene: a write would change them for the "
                f"steps, bodies and runs after it); copy it first (p.copy()) to change "
                f"numbers") from exc
        if isinstance(exc, IndexError):
            raise ValueError(f"torque({args}) failed on a test call: IndexError: {exc} "
                             f"({_input_sizes(controls, params)})") from exc
        raise ValueError(f"torque({args}) failed on a test call: {exc}") from exc
    overloads = getattr(torque, "overloads", {})
    if (getattr(torque, "targetoptions", {}).get("forceobj")
            or any(getattr(c, "objectmode", False) for c in overloads.values())):
        raise TypeError(f"torque({args}) is compiled in numba's object mode: the torque must "
                        f"return real float64 numbers from nopython code (use @njit, not "
                        f"@jit(forceobj=True)), which the kernels can call")
    if tau.dtype.kind not in "iuf":
        raise TypeError(f"torque({args}) must return real float64 numbers (3 of them), got "
                        f"dtype {tau.dtype} on a test call (complex, boolean, string and "
                        f"object values cannot be a torque)")
    if tau.shape != (3,):
        raise ValueError(f"torque({args}) must return 3 numbers, got shape {tau.shape}")
    py_func = getattr(torque, "py_func", None)
    if py_func is not None and (controls or params is not None):
        # numba does not check bounds: the Python function, called on the same NumPy
        # arrays, raises IndexError where the compiled one reads memory beyond u or p
        try:
            py_func(*test)
        except IndexError as exc:
            raise ValueError(
                f"torque({args}) reads beyond its inputs: its Python code raises IndexError "
                f"({exc}) on a test call, where the compiled torque would read memory that "
                f"is not its input ({_input_sizes(controls, params)}; compile it with "
                f"@njit(boundscheck=True) to find the line)") from exc
        except Exception:  # code that only runs compiled: the compiled test call passed
            pass


def _writes_read_only(exc: BaseException) -> bool:
    """Whether ``exc`` says that the code wrote to a read-only array: numba's typing error
    (``setitem`` of a readonly array), or NumPy's (the torque as plain Python)."""
    text = str(exc)
    return ("readonly array" in text and "setitem" in text) or (
        isinstance(exc, ValueError) and "read-only" in text)


def _input_sizes(controls: int, params) -> str:
    """How many entries ``u`` and ``p`` hold, for messages."""
    words = []
    if controls:
        words.append(f"u has {controls} entries (controls={controls})")
    if params is not None:
        words.append(f"p has {params.shape[-1]} entries (a row of params)")
    return "; ".join(words) or "q has 4 entries and L 3"


def _positive(name: str, value):
    """A positive finite number, or an array of them (one per body)."""
    if np.ndim(value) == 0:
        return as_positive_float(name, value)
    arr = as_float_array(name, value)
    if np.any(arr <= 0):
        raise ValueError(f"{name} must be > 0 for every body, got {arr.min():g} at index "
                         f"{int(np.argmin(arr))}")
    arr = arr.copy()
    arr.flags.writeable = False
    return arr


def _per_body(param: np.ndarray, values: np.ndarray) -> np.ndarray:
    """A per-body parameter ``(N, k)`` shaped to broadcast against ``values`` ``(N, ..., k)``
    (unchanged when it is one body's ``(k,)``)."""
    param = np.asarray(param)
    if param.ndim < 2:
        return param
    return param.reshape(param.shape[:1] + (1,) * (values.ndim - 2) + param.shape[1:])


_CALLBACKS: dict = {}


def _callback(torque, controls: int = 0, params: bool = False, block: bool = False) -> int:
    """The address of the C callback of a user torque (one body, or ``block``: many at
    once), compiled once per process."""
    key = (id(torque), controls, params, block)
    entry = _CALLBACKS.get(key)
    if entry is None or entry[0] is not torque:
        from liebody._models.user_torque import adapt_user_block, adapt_user_torque

        adapt = adapt_user_block if block else adapt_user_torque
        entry = (torque, adapt(torque, controls, params))
        _CALLBACKS[key] = entry
    return entry[1]
