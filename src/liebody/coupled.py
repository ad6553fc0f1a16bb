"""Interacting rigid bodies: ``N`` rotors coupled by a potential of all their orientations.

:class:`CoupledBodies` is the scene: ``N`` rigid bodies (their centres fixed) with the
Hamiltonian ``H = sum_i T_i(L_i) + V(t, q_1, ..., q_N)``. :func:`liebody.integrate` and
:class:`liebody.Stepper` run it with the splittings of liebody and their compositions:
a *kick* of every body by the collective torque with all orientations fixed (the exact
flow of ``V``: ``L_i += tau N_i``), then each body's own free flow (the exact axis or
sphere sub-flows of the method, on the SIMD kernels of the ensembles, or the exact
free flow), as in the splittings of one body (McLachlan 1993; Dullweber, Leimkuhler &
McLachlan, J. Chem. Phys. 107 (1997) 5840, the rigid-body splitting for molecular
dynamics). Every sub-flow is the exact flow of a Hamiltonian, so the methods are
symplectic and reversible and have the order of the method (2 for ``splitting2``,
4, 6 and 8 for the compositions). Each body's free flow is chosen at set-up from its
initial orbit, so to retrace a run reverse the momenta on its :class:`liebody.Stepper`
(a new run from ``(q, -L)`` may choose other free flows: ``docs/coupled.md``).

Angular momentum. A free flow keeps each body's spatial angular momentum
``R(q_i) L_i``; a kick changes the total by ``tau sum_i R(q_i) N_i``, the net torque in
space. If ``V`` is invariant under a common rotation of all bodies
(``V(R q_1, ..., R q_N) = V(q_1, ..., q_N)``), that net torque vanishes identically, so the
total spatial angular momentum is kept to round-off by every step, whatever the step
size. Point dipoles on fixed sites (:class:`DipoleLattice`) are not such a potential:
the sites pick directions in space, and the lattice takes up angular momentum.

Units: ``k_B = 1`` in the thermal helpers (:func:`thermal_momenta`,
:func:`kinetic_temperature`): a temperature is an energy.
"""

from __future__ import annotations

import math
import warnings
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from liebody._engine import failed_step_times, failed_step_words
from liebody._validate import (
    as_float_array,
    as_positive_float,
    as_unit_quaternion,
    clock_origin,
)
from liebody.errors import (
    ConvergenceError,
    IntegrationInterrupted,
    InvariantWarning,
    TorqueError,
)
from liebody.rigid_body import RigidBody
from liebody.trajectory import Trajectory

__all__ = ["CoupledBodies", "CoupledTrajectory", "DipoleLattice", "kinetic_temperature",
           "neighbours", "thermal_momenta", "uniform_orientations"]

#: the methods a coupled system runs: kicks and free flows (the others are refused)
_KINDS_OK = None


def _rigid_bodies(bodies) -> np.ndarray:
    """The principal moments ``(N, 3)`` of a batch :class:`RigidBody` or a sequence of
    single ones."""
    if isinstance(bodies, RigidBody):
        if not bodies.shape:
            raise ValueError("bodies must be N >= 1 rigid bodies: a RigidBody.batch or a "
                             "list of RigidBody (one body is a scene of liebody.integrate "
                             "itself)")
        return np.array(bodies.moments, dtype=float)
    try:
        items = list(bodies)
    except TypeError:
        raise TypeError(f"bodies must be a RigidBody.batch or a sequence of RigidBody, got "
                        f"{type(bodies).__name__}") from None
    if not items:
        raise ValueError("bodies must hold at least one body")
    for i, b in enumerate(items):
        if not isinstance(b, RigidBody) or b.shape:
            raise TypeError(f"bodies[{i}] must be a single RigidBody, got "
                            f"{type(b).__name__}")
    return np.array([b.moments for b in items], dtype=float)


def _is_compiled(fn) -> bool:
    """A numba dispatcher (any function when numba's JIT is off: ``NUMBA_DISABLE_JIT``)."""
    from numba import config

    return bool(config.DISABLE_JIT) or (hasattr(fn, "py_func") and hasattr(fn, "signatures"))


class CoupledBodies:
    """``N`` rigid bodies coupled by a potential ``V(t, q_1, ..., q_N)`` of their
    orientations (and time).

    Parameters
    ----------
    bodies
        The bodies: a :meth:`liebody.RigidBody.batch` of ``N`` or a sequence of ``N``
        :class:`liebody.RigidBody` (principal frames; the centres are fixed).
    torque
        A numba-compiled function ``torque(t, q, L, params, out)`` that writes every
        body's torque, in its own body frame, into ``out`` ``(N, 3)`` (zeros at every
        call: a loop over pairs may accumulate into it with ``+=``), from the
        orientations ``q`` ``(N, 4)`` (unit quaternions, scalar first, body to space: the
        state's ``q / |q|``), the body-frame angular momenta ``L`` ``(N, 3)`` (for the
        signature only: the torque of a potential does not depend on them; one that does
        is refused, checked at ``L = 2 L0 + 1`` at the start) and ``params``. For a
        potential ``V``, body ``i``'s torque is minus the derivative of ``V`` under a
        rotation of body ``i``: ``N_i = -dV/d(eps_i)`` with ``q_i -> q_i exp(eps_i / 2)``
        (body frame).
    potential
        Optional ``potential(t, q, params) -> float``, the ``V`` the torque derives
        from (compiled or plain Python): the energy of the trajectory and the energy
        check at the end of a run use it; :func:`liebody.integrate` calls it at the
        start and refuses a torque that does not derive from it (central differences
        along one rotation of all bodies). Without it the energy is the kinetic part.
    params
        Optional per-body parameters ``(N, k)`` (their first axis is the body; passed
        to the torque as a float64 C-contiguous array, ``(N, 0)`` when not given).

    Notes
    -----
    Integrate with :func:`liebody.integrate` (``q0`` ``(N, 4)`` or one for all, ``L0`` /
    ``omega0`` ``(N, 3)``; methods ``splitting2`` (default), ``no_squish``,
    ``splitting4/6/8``, ``exact`` (the exact free flow between kicks) and ``rattle`` (the
    discrete Moser–Veselov free step between kicks)), or step by
    step with :class:`liebody.Stepper`. The collective torque is called once per kick
    (once per step for ``splitting2``, whose end kicks merge), the free flows cost what
    they cost in an ensemble. See the module :mod:`liebody.coupled` for the angular
    momentum.
    """

    default_method = "splitting2"

    def __init__(self, bodies, torque, potential=None, params=None) -> None:
        self.moments = _rigid_bodies(bodies)
        n = self.moments.shape[0]
        if not callable(torque):
            raise TypeError(f"torque must be a compiled function torque(t, q, L, params, "
                            f"out), got {type(torque).__name__}")
        if not _is_compiled(torque):
            raise TypeError("torque must be compiled with numba (numba.njit): the kicks "
                            "call it from compiled code, torque(t, q, L, params, out)")
        if potential is not None and not callable(potential):
            raise TypeError(f"potential must be a function potential(t, q, params), got "
                            f"{type(potential).__name__}")
        if params is None:
            p = np.zeros((n, 0))
        else:
            p = as_float_array("params", params)
            if p.ndim == 1:
                p = p[:, None]
            if p.ndim != 2 or p.shape[0] != n:
                raise ValueError(f"params must have shape (N, k) with N = {n} bodies (one "
                                 f"row per body), got shape {p.shape}")
        self.params = np.ascontiguousarray(p, dtype=np.float64)
        self.params.flags.writeable = False
        self.torque = torque
        self.potential_function = potential
        self._address = None

    @property
    def n_bodies(self) -> int:
        return int(self.moments.shape[0])

    @property
    def batch_shape(self) -> tuple[int, ...]:
        return (self.n_bodies,)

    @property
    def address(self) -> int:
        """The address of the torque's C callback (made on first use, then kept)."""
        if self._address is None:
            from liebody._kernels.coupled import adapt_coupled_torque

            self._address = adapt_coupled_torque(self.torque)
        return self._address

    def _arguments(self, t, q, L=None):
        """``t``, ``q`` ``(N, 4)`` (and ``L`` ``(N, 3)``, or ``(3,)`` for every body) as
        the compiled functions take them: they index the bodies without bounds checks."""
        n = self.n_bodies
        t = float(as_float_array("t", t, shape=()))
        q = as_float_array("q", q)
        if q.shape != (n, 4):
            raise ValueError(f"q must have shape (N, 4) = ({n}, 4), one orientation per "
                             f"body, got {q.shape}")
        if L is None:
            return t, np.ascontiguousarray(q)
        L = as_float_array("L", L)
        if L.shape not in ((3,), (n, 3)):
            raise ValueError(f"L must have shape (3,) or (N, 3) = ({n}, 3), got {L.shape}")
        return t, np.ascontiguousarray(q), np.ascontiguousarray(np.broadcast_to(L, (n, 3)))

    def potential(self, q, t: float = 0.0) -> float:
        """``V(t, q)`` for the orientations ``q`` ``(N, 4)`` (NaN without a potential)."""
        if self.potential_function is None:
            return math.nan
        t, q = self._arguments(t, q)
        return float(self.potential_function(t, q, self.params))

    def evaluate_torque(self, q, L, t: float = 0.0) -> np.ndarray:
        """The collective torque ``(N, 3)`` at ``(t, q, L)``, called from Python (raises
        what the torque raises)."""
        t, q, L = self._arguments(t, q, L)
        out = np.zeros((self.n_bodies, 3))
        self.torque(t, q, L, self.params, out)
        return out

    def take(self, i):
        """Body ``i`` alone, free (for ``Trajectory.body(i)``: its samples, not its
        coupling)."""
        from liebody.scenes import FreeBody

        return FreeBody(RigidBody(self.moments[i], check_triangle=False))

    def __repr__(self) -> str:
        return (f"{type(self).__name__}({self.n_bodies} bodies, torque="
                f"{getattr(self.torque, '__name__', self.torque)!s})")


def neighbours(sites, cutoff: float) -> np.ndarray:
    """Each site's neighbours within ``cutoff``: ``(N, K)`` int64, padded with -1 (``K``
    the largest count), from a cell list (``O(N)`` for a bounded density).

    Parameters
    ----------
    sites : (N, 3) array
        Positions.
    cutoff : float
        Distance (> 0); a pair closer than it is a neighbour pair (listed on both sides).
    """
    s = as_float_array("sites", sites)
    if s.ndim != 2 or s.shape[1] != 3:
        raise ValueError(f"sites must have shape (N, 3), got {s.shape}")
    cutoff = as_positive_float("cutoff", cutoff)
    cells: dict = {}
    keys = np.floor(s / cutoff).astype(np.int64)
    for i, key in enumerate(map(tuple, keys)):
        cells.setdefault(key, []).append(i)
    lists = []
    c2 = cutoff * cutoff
    for i, (a, b, c) in enumerate(keys):
        near = [j for da in (-1, 0, 1) for db in (-1, 0, 1) for dc in (-1, 0, 1)
                for j in cells.get((a + da, b + db, c + dc), ())]
        near = np.array(sorted(j for j in near if j != i), dtype=np.int64)
        if near.size:
            d2 = np.sum((s[near] - s[i]) ** 2, axis=1)
            near = near[d2 < c2]
        lists.append(near)
    K = max((len(x) for x in lists), default=0)
    out = np.full((s.shape[0], K), -1, dtype=np.int64)
    for i, x in enumerate(lists):
        out[i, :len(x)] = x
    return out


class DipoleLattice(CoupledBodies):
    """Point dipoles on fixed sites, each carried by a rigid body (a lattice of polar
    rotors), through the :class:`CoupledBodies` interface.

    ``V = sum_{i<j} [mu_i . mu_j - 3 (mu_i . e_ij)(mu_j . e_ij)] / r_ij^3`` with
    ``mu_i = R(q_i) d_i`` and ``e_ij`` the unit vector between the sites (units in which
    the coupling constant ``mu_0 / 4 pi`` is 1; J. D. Jackson, *Classical
    Electrodynamics*, 3rd ed., 1999, eq. 5.72 for the field of a dipole).

    Parameters
    ----------
    bodies
        ``N`` bodies (a :meth:`liebody.RigidBody.batch` or a sequence).
    sites : (N, 3) array
        The fixed positions of the bodies' centres (no two closer than 1e-9 of their
        spread).
    dipoles : (N, 3) or (3,) array
        Each body's dipole moment in its body frame.
    cutoff : float, optional
        Pairs farther apart are left out (a neighbour list,
        :func:`liebody.coupled.neighbours`); ``None``: every pair (``O(N^2)`` per kick).

    Notes
    -----
    The sites fix directions in space, so ``V`` is not invariant under a common rotation
    of the dipoles: the total spatial angular momentum of the rotors is not conserved
    (the lattice takes it up); the energy is, within the bounded error of a symplectic
    method.
    """

    def __init__(self, bodies, sites, dipoles, cutoff=None) -> None:
        from liebody._models import dipoles as model

        moments = _rigid_bodies(bodies)
        n = moments.shape[0]
        s = as_float_array("sites", sites)
        if s.shape != (n, 3):
            raise ValueError(f"sites must have shape (N, 3) = ({n}, 3), one per body, got "
                             f"{s.shape}")
        d = as_float_array("dipoles", dipoles)
        if d.shape not in ((3,), (n, 3)):
            raise ValueError(f"dipoles must have shape (3,) or (N, 3) = ({n}, 3), got "
                             f"{d.shape}")
        d = np.broadcast_to(d, (n, 3))
        if n > 1:  # every pair within 1e-9 of the size (a k-d tree: N log N)
            from scipy.spatial import cKDTree

            spread = float(np.ptp(s, axis=0).max())
            pairs = cKDTree((s - s.min(axis=0)) / spread).query_pairs(
                1e-9, output_type="ndarray") if spread > 0 else np.array([[0, 1]])
            if len(pairs):
                i, j = min(map(tuple, np.sort(pairs, axis=1).tolist()))
                raise ValueError(f"sites must be distinct: sites {i} and {j} coincide "
                                 f"(closer than 1e-9 of the lattice's size)")
        if cutoff is None:
            nb = np.zeros((n, 0), dtype=np.int64)
            count = np.full(n, -1.0)
        else:
            nb = neighbours(s, cutoff)
            count = (nb >= 0).sum(axis=1).astype(float)
        p = np.concatenate([s, d, count[:, None], nb.astype(float)], axis=1)
        super().__init__(RigidBody.batch(moments, check_triangle=False), model.torque,
                         model.potential, p)
        self.sites = s
        self.dipoles = np.array(d)
        self.cutoff = cutoff

    @property
    def address(self) -> int:
        """The built-in model's C callback (compiled once, cached on disk)."""
        from liebody._models import dipoles

        return dipoles.callback_address()


# ------------------------------------------------------------------ thermal helpers
def uniform_orientations(n: int, rng=None) -> np.ndarray:
    """``n`` orientations drawn uniformly from SO(3) (Haar measure): unit quaternions
    ``(n, 4)`` with ``w >= 0``, normalised standard normal 4-vectors (uniform on ``S^3``;
    K. Shoemake, "Uniform random rotations", Graphics Gems III, 1992)."""
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 1:
        raise ValueError(f"n must be a positive integer, got {n!r}")
    g = np.random.default_rng(rng).normal(size=(int(n), 4))
    g /= np.linalg.norm(g, axis=1)[:, None]
    g[g[:, 0] < 0] *= -1.0
    return g


def thermal_momenta(moments, temperature: float, rng=None) -> np.ndarray:
    """Body-frame angular momenta drawn from the Maxwell–Boltzmann distribution at
    ``temperature`` (``k_B = 1``): ``L_k ~ N(0, I_k T)`` independently, the distribution
    ``exp(-sum L_k^2 / (2 I_k T))`` of a rigid rotor's momenta.

    Parameters
    ----------
    moments : (N, 3) or (3,) array
        Principal moments (one row per body).
    temperature : float
        ``k_B T`` (> 0).
    """
    I = as_float_array("moments", moments)
    if I.shape[-1:] != (3,) or I.ndim > 2 or np.any(I <= 0):
        raise ValueError(f"moments must be positive, shape (3,) or (N, 3), got {I.shape}")
    T = as_positive_float("temperature", temperature)
    return np.random.default_rng(rng).normal(size=I.shape) * np.sqrt(I * T)


def kinetic_temperature(traj) -> np.ndarray:
    """The kinetic temperature of a trajectory of ``N`` bodies at every sample:
    ``T_kin = 2 <K> / (3 N)`` (``k_B = 1``; three rotational degrees of freedom per body),
    ``K`` the total kinetic energy."""
    K = np.asarray(traj.kinetic_energy)
    if K.ndim != 2:
        raise ValueError("kinetic_temperature needs the trajectory of N bodies (q of shape "
                         "(N, n, 4))")
    return 2.0 * K.sum(axis=0) / (3.0 * K.shape[0])


# ------------------------------------------------------------------ the trajectory
@dataclass(frozen=True, eq=False, repr=False)
class CoupledTrajectory(Trajectory):
    """The trajectory of :class:`CoupledBodies`: per body ``q`` ``(N, n, 4)``, ``L``
    ``(N, n, 3)`` (every per-body quantity of :class:`~liebody.Trajectory`), and the
    system's :attr:`potential_energy`, :attr:`energy` ``(n,)``, :attr:`total_L_space`
    ``(n, 3)`` and :attr:`temperature` ``(n,)``."""

    #: one system, not independent bodies (``liebody.testing.energy_drift`` takes it)
    coupled = True

    @property
    def potential_energy(self) -> np.ndarray:
        """``V(t, q_1, ..., q_N)`` at every sample (NaN without a potential)."""
        q = self.orientation
        return np.array([self.scene.potential(q[:, k], t) for k, t in enumerate(self.t)])

    @property
    def energy(self) -> np.ndarray:
        """Total energy ``sum_i T_i + V`` at every sample."""
        T = self.kinetic_energy.sum(axis=0)
        return T if self.scene.potential_function is None else T + self.potential_energy

    @property
    def total_L_space(self) -> np.ndarray:
        """``sum_i R(q_i) L_i``, the total spatial angular momentum ``(n, 3)``."""
        return self.L_space.sum(axis=0)

    @property
    def temperature(self) -> np.ndarray:
        """:func:`kinetic_temperature` at every sample."""
        return kinetic_temperature(self)

    def __repr__(self) -> str:
        status = (f"failed at t={self.failed_at:g}" if self.failed_at is not None
                  else self.status)
        return (f"CoupledTrajectory(method={self.method.name!r}, dt={self.dt:g}, "
                f"bodies={self.n_bodies}, samples={len(self)}, t=[{self.t[0]:g}, "
                f"{self.t[-1]:g}], {status})")

    def body(self, i: int) -> Trajectory:
        """Body ``i``'s samples as a one-body trajectory
        (:meth:`liebody.Trajectory.body`), its scene the free body
        (:meth:`CoupledBodies.take`: the coupling is not part of it), ``failed_at`` and
        ``status`` the system's."""
        import dataclasses

        n = self.n_bodies
        whole = dataclasses.replace(
            self, failed_at=None if self.failed_at is None else np.full(n, self.failed_at),
            status=np.full(n, self.status))
        return Trajectory.body(whole, i)


# ------------------------------------------------------------------ the run
_SUPPORTED: tuple | None = None


def supported_methods() -> tuple[str, ...]:
    """The registered methods a coupled system runs (kicks between free flows)."""
    global _SUPPORTED
    if _SUPPORTED is None:
        from liebody import methods

        probe = CoupledBodies(RigidBody.batch([[1.0, 2.0, 3.0]]), _zero_torque())
        ok = []
        for m in methods():
            try:
                _tables(probe, m, np.array([[0.1, 0.2, 0.3]]), 0.1)
            except ValueError:
                continue
            ok.append(m.name)
        _SUPPORTED = tuple(ok)
    return _SUPPORTED


_ZERO = None


def _zero_torque():
    global _ZERO
    if _ZERO is None:
        from liebody._kernels._jit import jit

        @jit
        def zero(t, q, L):
            return 0.0, 0.0, 0.0

        _ZERO = zero
    return _ZERO


def _proxy(moments):
    """A one-body-per-row torqued scene with the bodies' moments: the plans of a method
    for kicks of an orientation-only torque between free flows."""
    from liebody.scenes import TorqueBody

    return TorqueBody(RigidBody.batch(moments, check_triangle=False), _zero_torque(),
                      orientation_only=True)


def _tables(scene, method, m0, h):
    """The driver's tables for ``scene`` under ``method`` (see ``_kernels.coupled.run``);
    ``ValueError`` for a method whose step does not begin and end with a kick, free flows
    between."""
    from liebody._kernels import stages as S
    from liebody._kernels.coupled import BLOCK, NOOP, ROWS  # noqa: F401

    allowed = {S.AXIS, S.AXIS_RECURRING, S.SPHERE, S.EXACT, S.DMV}
    try:
        groups = method.plans(_proxy(scene.moments), m0, h)
    except ValueError as exc:  # (the caller's words name the method: not again here)
        words = str(exc)
        prefix = f"{method.name}: "
        raise ValueError(words[len(prefix):] if words.startswith(prefix) else words) from None
    segs_all, kicks, times, merge = [], None, None, None
    for idx, plan in groups:
        kinds = plan.kinds.tolist()
        if any(k not in allowed and k != S.KICK for k in kinds):
            raise ValueError(f"{method.name}'s step holds stages other than kicks and free "
                             f"flows")
        if not kinds or kinds[0] != S.KICK or kinds[-1] != S.KICK:
            raise ValueError(f"{method.name}'s step begins or ends with a free flow, not a "
                             f"kick")
        kc, kt, segs, t, cur = [], [], [], 0.0, []
        for j, k in enumerate(kinds):
            if k == S.KICK:
                kc.append(float(plan.coefs[j]))
                kt.append(t)
                if j:
                    segs.append(cur)
                cur = []
            else:
                cur.append(j)
            t += float(plan.clock[j])
        if kicks is None:
            kicks, times, merge = kc, kt, bool(plan.merge_ends)
        elif kc != kicks or kt != times or bool(plan.merge_ends) != merge:
            raise ValueError(f"{method.name}: the bodies' steps put their kicks at different "
                             f"times (not a coupled step)")
        segs_all.append((idx, plan, segs))
    return groups, segs_all, np.array(kicks), np.array(times), merge


class _Coupled:
    """The prepared run of a coupled system: tables, blocks and work arrays."""

    def __init__(self, scene, method, q0, m0, dt):
        from liebody._kernels import stages as S
        from liebody._kernels.coupled import BLOCK, NOOP, ROWS

        self.scene, self.method, self.dt = scene, method, dt
        n = scene.n_bodies
        _, segs_all, kc, kt, merge = _tables(scene, method, m0, dt)
        self.kc, self.kt, self.merge = kc, kt, merge
        G, Sn = len(segs_all), len(kc) - 1
        R = max([len(seg) for _, _, segs in segs_all for seg in segs] + [1])
        rk = np.full((G, Sn, R), NOOP, dtype=np.int64)
        ra = np.zeros((G, Sn, R), dtype=np.int64)
        rc = np.zeros((G, Sn, R))
        blocks = []
        for g, (idx, plan, segs) in enumerate(segs_all):
            for s, seg in enumerate(segs):
                for r, j in enumerate(seg):
                    rk[g, s, r], ra[g, s, r], rc[g, s, r] = plan.kinds[j], plan.axes[j], \
                        plan.coefs[j]
            idx = np.asarray(idx)
            for a in range(0, len(idx), BLOCK):
                blocks.append((g, idx[a:a + BLOCK], plan, a))
        B = len(blocks)
        self.blk_group = np.array([b[0] for b in blocks], dtype=np.int64)
        self.blk_idx = np.zeros((B, BLOCK), dtype=np.int64)
        self.blk_n = np.zeros(B, dtype=np.int64)
        self.rates = np.zeros((B, Sn, R, 1, BLOCK))  # (a stage's rows: rates in row 0)
        for b, (g, idx, plan, a) in enumerate(blocks):
            self.blk_idx[b, :len(idx)] = idx
            self.blk_n[b] = len(idx)
            rows = plan.params if plan.params.shape[0] == 1 else plan.params[a:a + len(idx)]
            for s, seg in enumerate(segs_all[g][2]):
                for r, j in enumerate(seg):
                    self.rates[b, s, r, 0, :len(idx)] = rows[:, plan.slots[j], S.P_RATE]
        self.rk, self.ra, self.rc = rk, ra, rc
        self.rmax = np.abs(self.rates).max(axis=(-2, -1))
        self.lmax = np.zeros(B)
        self.bufs = np.zeros((B, ROWS * BLOCK))
        self.moments = np.ascontiguousarray(scene.moments)
        self.Q = np.empty((n, 4))
        self.Lm = np.empty((n, 3))
        self.out = np.empty((n, 3))
        self.ctl = np.array([1, 0, 0], dtype=np.int64)
        self.set_state(q0, m0)

    def set_state(self, q, m):
        from liebody._kernels.coupled import BLOCK

        for b in range(self.bufs.shape[0]):
            k = self.blk_n[b]
            idx = self.blk_idx[b, :k]
            rows = self.bufs[b].reshape(7, BLOCK)
            rows[:4, :k] = q[idx].T
            rows[4:, :k] = m[idx].T
            self.lmax[b] = np.sqrt((m[idx] ** 2).sum(axis=1).max())
        self.ctl[1] = 0

    def state(self):
        from liebody._kernels.coupled import BLOCK

        n = self.scene.n_bodies
        q, m = np.empty((n, 4)), np.empty((n, 3))
        for b in range(self.bufs.shape[0]):
            k = self.blk_n[b]
            rows = self.bufs[b].reshape(7, BLOCK)
            q[self.blk_idx[b, :k]] = rows[:4, :k].T
            m[self.blk_idx[b, :k]] = rows[4:, :k].T
        return q, m

    def run(self, t0, step0, n_steps, save_every, final, q_out, m_out, row0):
        from liebody._kernels.coupled import run

        return run(self.kc, self.kt, self.rk, self.ra, self.rc, self.blk_group, self.blk_idx,
                   self.blk_n, self.rates, self.rmax, self.moments, self.merge, self.dt, t0,
                   float(step0), n_steps, save_every, final, self.bufs, self.ctl, self.Q,
                   self.Lm, self.out, self.scene.params, self.scene.address, q_out, m_out,
                   row0, self.lmax)


def _prepare(scene, method, q, m, dt) -> _Coupled:
    """The prepared run, or a ``ValueError`` naming the methods that run coupled bodies."""
    try:
        return _Coupled(scene, method, q, m, dt)
    except ValueError as exc:
        raise ValueError(f"{method.name} does not run coupled bodies ({exc}): they run steps "
                         f"that begin and end with a kick of the collective torque, the "
                         f"bodies' free flows between, i.e. "
                         f"{', '.join(supported_methods())}") from None


def _initial(scene, q0, L0, omega0, name_q="q0"):
    n = scene.n_bodies
    q = as_unit_quaternion(name_q, q0)
    if q.shape not in ((4,), (n, 4)):
        raise ValueError(f"{name_q} must have shape (4,) or (N, 4) = ({n}, 4), got {q.shape}")
    if (L0 is None) == (omega0 is None):
        raise ValueError("give exactly one of L0 (body angular momenta) and omega0 (body "
                         "angular velocities)")
    name = "L0" if L0 is not None else "omega0"
    v = as_float_array(name, L0 if L0 is not None else omega0)
    if v.shape not in ((3,), (n, 3)):
        raise ValueError(f"{name} must have shape (3,) or (N, 3) = ({n}, 3), got {v.shape}")
    m = v if L0 is not None else scene.moments * v
    return (np.ascontiguousarray(np.broadcast_to(q, (n, 4))),
            np.ascontiguousarray(np.broadcast_to(m, (n, 3)), dtype=float))


def _check_potential(scene, q, t0) -> None:
    """The potential (called at the end of the run for the energy check and by
    ``Trajectory.energy``) called once at the initial state: one finite number, or a
    clear error before the run rather than at its end."""
    if scene.potential_function is None:
        return
    try:
        V = np.asarray(scene.potential_function(float(t0), q, scene.params))
    except Exception as exc:
        raise ValueError(f"the coupled potential raised {type(exc).__name__} at the initial "
                         f"state: {exc}. It must be potential(t, q, params) giving V, one "
                         f"number") from exc
    if V.shape != () or V.dtype.kind not in "biuf":
        raise ValueError(f"the coupled potential must give one real number V, got "
                         f"{type(V.tolist()).__name__} of shape {V.shape} at the initial state")
    if not np.isfinite(V):
        raise ValueError(f"the coupled potential is not finite at the initial state "
                         f"(V = {V.tolist()})")


def _check_derivation(scene, q, N, t0) -> None:
    """With a potential, the torque must be minus its derivative under rotations of the
    bodies (body frame). Checked along one random rotation of all bodies at once,
    ``q_i -> q_i exp(s e_i / 2)``: ``dV/ds = -sum_i e_i . N_i`` at ``s = 0``, against
    central differences at ``s = h`` and ``h / 2`` (judged only where the two agree: a
    smooth ``V``). ``N``: the torque at ``(t0, q)`` (:func:`_check_torque`'s). A sign
    error or a torque in the space frame is refused."""
    if scene.potential_function is None:
        return
    from liebody import quaternion as Q

    e = np.random.default_rng(20241126).normal(size=q.shape[:1] + (3,))
    want = -float(np.sum(e * N))
    h = 1e-4

    def V(s):
        return float(scene.potential(Q.multiply(q, Q.exp(s * e)), t0))

    try:
        V0 = abs(V(0.0))
        fd = [(V(a) - V(-a)) / (2.0 * a) for a in (h, 0.5 * h)]
    except Exception:  # (the potential's own check names its failures)
        return
    noise = 16.0 * np.finfo(float).eps * V0 / h  # (rounding of V in the differences)
    scale = abs(fd[1]) + abs(want)
    if abs(fd[0] - fd[1]) > 1e-4 * scale + noise:  # not smooth enough here to judge
        return
    if abs(fd[1] - want) > 1e-2 * scale + 8.0 * noise:
        raise ValueError(
            f"the coupled torque does not derive from the potential: along a rotation of "
            f"every body q_i -> q_i exp(s e_i / 2) at the initial state, dV/ds = "
            f"{fd[1]:.6g} by central differences, and -sum_i e_i . N_i = {want:.6g} from "
            f"the torque. It must be N_i = -dV/d(eps_i), in body i's own frame (a sign, or "
            f"a torque in the space frame?)")


def _check_torque(scene, q, m, t0) -> np.ndarray:
    """Call the torque from Python at the initial state: a wrong signature or a failing
    torque is named before the run; returns the torque there."""
    try:
        out = scene.evaluate_torque(q, m, t0)
    except Exception as exc:
        raise TorqueError(f"the coupled torque failed at the initial state: "
                          f"{type(exc).__name__}: {exc}. It must be torque(t, q, L, params, "
                          f"out) writing every body's torque into out (N, 3)") from exc
    bad = ~np.isfinite(out).all(axis=1)
    if bad.any():
        i = int(np.argmax(bad))
        raise TorqueError(f"the coupled torque wrote non-finite values for body {i} at the "
                          f"initial state: {out[i].tolist()}")
    why = ("The kicks are the exact flow of a potential V(t, q), L += tau N(t, q); a torque "
           "of the momenta (a drag, a gyroscopic term) has no such flow, and its kicks would "
           "be explicit, first order and irreversible")
    other_L = 2.0 * m + 1.0
    try:
        other = scene.evaluate_torque(q, other_L, t0)
    except Exception as exc:
        raise ValueError(f"the coupled torque depends on L: it raised {type(exc).__name__} "
                         f"({exc}) at L = 2 L0 + 1 (same t and q), not at L0. {why}") from exc
    if not np.array_equal(other, out) and np.array_equal(
            scene.evaluate_torque(q, m, t0), out):  # (not a torque that draws noise)
        i = int(np.argmax((other != out).any(axis=1)))
        raise ValueError(f"the coupled torque depends on L: at the initial t and q it gives "
                         f"{out[i].tolist()} for body {i} at L0 = {m[i].tolist()} and "
                         f"{other[i].tolist()} at L = 2 L0 + 1. {why}")
    return out


@contextmanager
def _numba_threads(n):
    """numba's thread count set to ``n`` (at most numba's, ``None``: as it is) for the
    block, the one before restored after."""
    if n is None:
        yield
        return
    import numba

    before = numba.get_num_threads()
    numba.set_num_threads(min(n, numba.config.NUMBA_NUM_THREADS))
    try:
        yield
    finally:
        numba.set_num_threads(before)


def integrate_coupled(scene, *, q0, L0, omega0, dt, n_steps, save_every, method, progress,
                      t0, t, threads=None, simd=None) -> CoupledTrajectory:
    """:func:`liebody.integrate` for :class:`CoupledBodies` (after the shared checks):
    ``threads`` sets numba's thread count for the run (the built-in model's torque and a
    user's ``prange`` run on them), ``simd=False`` is refused."""
    from liebody import _methods
    from liebody._engine import interrupt_after_call, resolve_threads, time_slices

    if simd is not None and not isinstance(simd, bool | np.bool_):
        raise TypeError(f"simd must be True, False or None, got {type(simd).__name__}")
    if simd is not None and not simd:
        raise ValueError("simd=False runs each body of an ensemble on the scalar drivers, "
                         "bit for bit its one-body run; the bodies of a coupled system have "
                         "no one-body run (the kicks couple them), and their free flows run "
                         "on the SIMD kernels: leave simd None")
    n_threads = None if threads is None else resolve_threads(threads)
    method = _methods.get(scene.default_method if method is None else method)
    q, m = _initial(scene, q0, L0, omega0)
    run = _prepare(scene, method, q, m, dt)
    N = _check_torque(scene, q, m, t0)
    _check_potential(scene, q, t0)
    _check_derivation(scene, q, N, t0)
    n = scene.n_bodies
    k = t.shape[0]
    q_out, m_out = np.empty((n, k, 4)), np.empty((n, k, 3))
    q_out[:, 0], m_out[:, 0] = q, m
    run.ctl[:2] = (save_every, 0)
    done = saved = 0
    status, body = 0, -1
    try:
        with _numba_threads(n_threads):
            for size in time_slices(n_steps, progress, "step", max(1, 4096 // n)):
                with interrupt_after_call():
                    d, s, status, body = run.run(t0, done, size, save_every,
                                                 done + size == n_steps, q_out, m_out,
                                                 1 + saved)
                    done += d
                    saved += s
                if status != 0:
                    break
    except KeyboardInterrupt:
        traj = _trajectory(scene, method, dt, t0, t[:1 + saved], q_out[:, :1 + saved].copy(),
                           m_out[:, :1 + saved].copy(), "interrupted")
        raise IntegrationInterrupted(
            f"{method.name}: interrupted after {done:,} of {n_steps:,} steps; the "
            f"{1 + saved:,} samples so far are on this exception's .trajectory", traj, done,
            t0 + done * dt) from None
    if status != 0:
        tf, t1 = failed_step_times(t0, done, dt)
        traj = _trajectory(scene, method, dt, t0, t[:1 + saved], q_out[:, :1 + saved].copy(),
                           m_out[:, :1 + saved].copy(), "failed", t1)
        raise _failure(run, status, body, t0, done, failed_step_words(done, tf, t1),
                       f"the {1 + saved:,} samples before it are on this exception's "
                       f".trajectory", traj, done)
    traj = _trajectory(scene, method, dt, t0, t, q_out, m_out, "complete",
                       info={"groups": len(set(run.blk_group.tolist()))})
    _check_energy(traj)
    return traj


def _failure(run, status, body, t0, done, where, then, traj, step):
    """The error of a run stopped in step ``done`` (counted from ``t0``) with ``status``,
    ``body`` the first failing body; ``where`` (the step) and ``then`` (what is kept) end
    the message. A torque that raised has its own exception as the cause: it is called
    again with the inputs of the failing kick (its time, and the ``q / |q|`` and ``L``
    the driver passed, left in the work arrays)."""
    from liebody._kernels import stages as S

    name, dt = run.method.name, run.dt
    tf = failed_step_times(t0, done, dt)[0]  # (the words' start of the step)
    if status == S.STATUS_NO_CONVERGENCE:
        return ConvergenceError(
            f"{name}: the implicit DMV (RATTLE) equation of body {body} has no solution "
            f"{where}; reduce dt (h |omega| must stay below about 1); {then}", traj, step, tf)
    tk = tf + float(run.kt[int(run.ctl[2])]) * dt  # (the driver's time of that kick)
    cause = None
    try:
        run.scene.torque(tk, run.Q.copy(), run.Lm.copy(), run.scene.params,
                         np.zeros_like(run.out))
    except Exception as exc:
        cause = exc
    if cause is not None:
        error = TorqueError(f"{name}: the coupled torque raised {type(cause).__name__}: "
                            f"{cause} {where}, at its kick at t = {tk:.6g}; {then}", traj,
                            step, tf)
    else:
        error = TorqueError(f"{name}: the coupled torque (or the momentum it kicked) was not "
                            f"finite for body {body} {where}, at its kick at t = {tk:.6g}; "
                            f"{then}", traj, step, tf)
    error.__cause__ = cause
    return error


def _trajectory(scene, method, dt, t0, t, q, m, status, failed_at=None, info=None):
    times = t if t0 == 0.0 else t0 + t
    return CoupledTrajectory(times, q, m, scene, method, dt, failed_at=failed_at,
                             info=info or {}, status=status)


def _check_energy(traj) -> None:
    """Warn when the total energy left 1 % of its scale (a symplectic method on a
    conservative system keeps it within a bounded error of the step's order); not for a
    potential that depends on the time (its value at the last orientations differs at
    the first and last times and at one in between, 0.382 of the way, which a period
    seldom divides), which does not keep the energy. A potential that
    raises here is warned about, the run kept. The warnings point at the caller of
    :func:`liebody.integrate`."""
    if traj.scene.potential_function is None or len(traj.t) < 2:
        return
    q = traj.orientation
    t0, t1 = traj.t[0], traj.t[-1]
    name = traj.method.name
    try:
        V0 = traj.scene.potential(q[:, 0], t0)
        V1 = traj.scene.potential(q[:, -1], t1)
        moving = [traj.scene.potential(q[:, -1], t) for t in (t0, t0 + 0.382 * (t1 - t0))]
    except Exception as exc:
        warnings.warn(f"{name}: the energy of the coupled system was not checked: the "
                      f"potential raised {type(exc).__name__}: {exc}", InvariantWarning,
                      stacklevel=5)
        return
    T = traj.kinetic_energy
    e0, e1 = T[:, 0].sum() + V0, T[:, -1].sum() + V1
    scale = T[:, 0].sum() + abs(V0)
    if not (math.isfinite(e0) and math.isfinite(e1)):
        warnings.warn(f"{name}: the energy of the coupled system is not finite at the ends "
                      f"(V = {V0:.6g}, {V1:.6g})", InvariantWarning, stacklevel=5)
    elif any(V != V1 for V in moving):  # V depends on the time: T + V is not kept
        return
    elif scale > 0 and not abs(e1 - e0) <= 1e-2 * scale:
        warnings.warn(f"{name}: the energy of the coupled system went from {e0:.6g} to "
                      f"{e1:.6g}, more than 1% of its scale {scale:.3g} (the step may be too "
                      f"large for this coupling)", InvariantWarning, stacklevel=5)


class CoupledStepper:
    """:class:`liebody.Stepper` for :class:`CoupledBodies`: the state of all bodies,
    advanced step by step (``Stepper(scene, q0=..., L0=..., dt=...)`` makes one).

    Attributes ``q`` ``(N, 4)``, ``L`` ``(N, 3)`` (read and set, copies), ``t`` (read and
    set); :meth:`step` advances ``n`` steps. A stepper's steps equal those of
    :func:`liebody.integrate` with ``save_every=1``, bit for bit.
    """

    def __init__(self, scene, *, q0=(1.0, 0.0, 0.0, 0.0), L0=None, omega0=None, dt,
                 method=None, t0: float = 0.0) -> None:
        from liebody import _methods
        self._scene = scene
        self._dt = as_positive_float("dt", dt)
        t0 = clock_origin("t0", t0, self._dt)
        self._method = _methods.get(scene.default_method if method is None else method)
        q, m = _initial(scene, q0, L0, omega0)
        self._run = _prepare(scene, self._method, q, m, self._dt)
        _check_torque(scene, q, m, t0)
        self._t0 = t0
        self._k = 0
        n = scene.n_bodies
        self._q1, self._m1 = np.empty((n, 1, 4)), np.empty((n, 1, 3))

    @property
    def scene(self):
        return self._scene

    @property
    def method(self):
        return self._method

    @property
    def dt(self) -> float:
        return self._dt

    @property
    def t(self) -> float:
        return self._t0 + self._k * self._dt

    @t.setter
    def t(self, value) -> None:
        self._t0 = clock_origin("t", value, self._dt)
        self._k = 0

    @property
    def q(self) -> np.ndarray:
        return self._run.state()[0]

    @q.setter
    def q(self, value) -> None:
        n = self._scene.n_bodies
        q = as_unit_quaternion("q", value)
        if q.shape not in ((4,), (n, 4)):
            raise ValueError(f"q must have shape (4,) or (N, 4) = ({n}, 4), got {q.shape}")
        self._run.set_state(np.broadcast_to(q, (n, 4)), self._run.state()[1])

    @property
    def L(self) -> np.ndarray:
        return self._run.state()[1]

    @L.setter
    def L(self, value) -> None:
        n = self._scene.n_bodies
        m = as_float_array("L", value)
        if m.shape not in ((3,), (n, 3)):
            raise ValueError(f"L must have shape (3,) or (N, 3) = ({n}, 3), got {m.shape}")
        self._run.set_state(self._run.state()[0], np.broadcast_to(m, (n, 3)))

    def step(self, n: int = 1) -> None:
        """Advance ``n`` steps (``n >= 1``). A torque that fails raises
        :class:`~liebody.errors.TorqueError` (the torque's own exception, if it raised,
        as the cause), an unsolved DMV equation :class:`~liebody.errors.ConvergenceError`;
        the stepper is then as it was before the call. Ctrl-C raises
        :class:`~liebody.errors.IntegrationInterrupted` with the steps done kept
        (``exc.step`` of them: the stepper is as ``step(exc.step)`` leaves it)."""
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 1:
            raise ValueError(f"n must be a positive integer, got {n!r}")
        run = self._run
        bufs, lmax, k0 = run.bufs.copy(), run.lmax.copy(), self._k
        k = k0
        run.ctl[0] = 2  # (a step that ran leaves 1, its save countdown: set before k)
        try:
            for i in range(int(n)):
                run.ctl[0] = 2
                k = self._k
                _, _, status, body = run.run(self._t0, k, 1, 1, True, self._q1, self._m1, 0)
                if status == 0:
                    self._k = k + 1
                    continue
                error = _failure(run, status, body, self._t0, k,
                                 failed_step_words(i, *failed_step_times(self._t0, k, self._dt),
                                                   " of this call"),
                                 "the stepper is left as it was before the call", None, i)
                run.bufs[:], run.lmax[:], self._k = bufs, lmax, k0
                run.ctl[1] = 0
                raise error
        except KeyboardInterrupt:  # (Python raises it between calls: none is cut short)
            if self._k == k and run.ctl[0] == 1:  # the step ran, the clock was not moved
                self._k = k + 1
            m = self._k - k0
            raise IntegrationInterrupted(
                f"Stepper.step({int(n):,}) interrupted after {m:,} of {int(n):,} steps; the "
                f"stepper is left after them, as step({m:,}) would have left it (t = "
                f"{self.t:.6g})", None, m, self.t) from None
