"""The stage contract: every stage kind, its parameters and the driver families, in one place.

A method's step is a sequence of *stages*. Each stage is one map applied for
``coef * h`` while the clock advances by ``clock * h``; the driver
(:mod:`liebody._kernels.driver`) runs the sequence. A stage is one row of five
arrays (``kinds``, ``axes``, ``coefs``, ``clock``, ``params``); the Python side builds
rows from :class:`liebody._plan.Stage` records, never by hand.

Parameter slots. ``params`` has :data:`N_PARAMS` columns, and every column has one
meaning for every kind (a kind reads the columns it needs and ignores the others):

=========================  =================================================
``P_I1, P_I2, P_I3``        principal moments (the DMV, exact and baseline
                            stages; modified moments for preprocessed DMV)
``P_RATE``                  rate of a rotation: the flow of
                            ``rate * m_k^2 / 2`` (axis) or ``rate * |m|^2 / 2``
                            (sphere)
``P_TORQUE``                torque model code (``TORQUE_*`` below); the model's
                            parameters are its parameter block, passed to the
                            drivers apart from the stages (``liebody._models``)
``P_EPS``                   dissipation strength ``eps``
``P_L1, P_L2, P_L3``        rotor momentum ``l`` of a gyrostat (body frame): the
                            kinetic energy is ``(m - l)^T I^-1 (m - l) / 2``
``P_U0 .. P_U0 + 5``        control inputs ``u`` passed to a user torque, held
                            constant over each step (zero-order hold); a
                            :class:`liebody.Stepper` sets them between steps
``P_LD1, P_LD2, P_LD3``     rate of change ``dl/dt`` of the rotor momentum (body
                            frame; reaction wheels driven by their motors)
``P_LT``                    the time at which the rotor momentum is ``P_L``: at
                            time ``t`` it is ``l(t) = P_L + P_LD (t - P_LT)``
=========================  =================================================

A rotor whose momentum changes linearly in time (:class:`liebody.ReactionWheels`) is
exact in the axis flows: a stage that runs ``(m_k - l_k(t))^2 / (2 I_k)`` for
``coef * h`` while the clock runs from ``t`` to ``t + clock * h`` turns the body by
``coef * h * (m_k - l_k(t + clock * h / 2)) / I_k`` (the integral of a linear function is
its midpoint value times the interval; the stage is the exact flow of
``H_k(m, t) + (clock / coef) p_t`` on the phase space extended by the time ``t`` and its
conjugate ``p_t``).

Adding a stage kind: give it a code and a :class:`Kind` entry in :data:`KINDS`, add
it to the families that should run it, and implement it in the driver's
``_apply_*`` functions. Nothing else reads kind codes.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

# ---------------------------------------------------------------------------- stage kinds
AXIS = 0  # exact flow of rate * m_k^2 / 2 about body axis k (k = the stage's axis)
AXIS_RECURRING = 1  # the same flow when m_k is constant: applied in increment form
SPHERE = 2  # exact flow of rate * |m|^2 / 2 (m fixed, q turns about m)
KICK = 3  # exact flow of an orientation-dependent torque: q fixed, m += tau torque
KICK_IMPLICIT = 4  # adjoint kick m' = m + tau torque(t, q, m') for momentum-dependent torques
DAMP = 5  # second-order step of the double-bracket dissipation (keeps |m|, lowers T)
DMV = 6  # discrete Moser-Veselov step = RATTLE on SO(3)
EXACT = 7  # exact free-body flow (Jacobi elliptic functions)
EULER = 8  # explicit Euler on (q, m) in R^7 (baseline)
RK4 = 9  # classical Runge-Kutta 4 on (q, m) in R^7 (baseline)
LIE_EULER = 10  # Lie-Euler, coadjoint form (baseline)
RKMK4 = 11  # Runge-Kutta-Munthe-Kaas 4 (baseline)
AXIS_SHIFTED = 12  # exact flow of rate * (m_k - l_k(t))^2 / 2: a gyrostat's axis term

# ------------------------------------------------------------------------ parameter slots
P_I1, P_I2, P_I3 = 0, 1, 2
P_RATE = 3
P_TORQUE = 4
P_EPS = 5
P_L1, P_L2, P_L3 = 6, 7, 8  # rotor momentum (gyrostat), body frame
P_U0 = 9
#: columns of the running diagnostics' reference values (``driver._diagnose``)
DREF_WIDTH = 13
#: the most control inputs a user torque takes
N_CONTROLS = 6
P_LD1, P_LD2, P_LD3 = 15, 16, 17  # rate of change of the rotor momentum, body frame
P_LT = 18  # the time at which the rotor momentum is P_L1..P_L3
#: width of a parameter row
N_PARAMS = P_LT + 1
assert P_LD1 == P_U0 + N_CONTROLS  # the control slots come just before

# --------------------------------------------------------------------------- torque codes
TORQUE_NONE = 0
TORQUE_GRAVITY = 1  # uniform gravity (liebody._models.uniform_gravity)
TORQUE_USER = 2  # the user's callback (liebody._models.user_torque)
TORQUE_GRAVITY_GRADIENT = 3  # point masses on orbits (liebody._models.gravity_gradient)
#: the largest model code (every code from 1 to it names a model)
MAX_MODEL_CODE = TORQUE_GRAVITY_GRADIENT

# ------------------------------------------------------------------------- driver status
STATUS_OK = 0
STATUS_NONFINITE = 1  # the state became non-finite
STATUS_NO_CONVERGENCE = 2  # DMV's implicit equation was not solved
STATUS_KICK_NO_CONVERGENCE = 3  # the implicit (adjoint) kick's equation was not solved
STATUS_BAD_STAGE = 4  # a stage kind the family does not run (a bug in a plan)
STATUS_TORQUE = 5  # the torque was not a finite 3-vector (a user torque raised or gave NaN)


class Kind(NamedTuple):
    """What the Python side needs to know about a stage kind."""

    name: str
    params: tuple[str, ...]  # the parameter slots it reads
    mergeable: bool  # consecutive stages of this kind with equal parameters are one flow
    rotation: bool  # an exact rotation of (q, m): the identity when its rate is zero


_MOMENTS = ("I1", "I2", "I3")
_TORQUE = ("torque",)
_CONTROLS = tuple(f"u{i}" for i in range(N_CONTROLS))
_ROTOR = ("l1", "l2", "l3", "ld1", "ld2", "ld3", "lt")

#: every stage kind, by code
KINDS: dict[int, Kind] = {
    AXIS: Kind("axis", ("rate",), True, True),
    AXIS_RECURRING: Kind("axis (recurring)", ("rate",), True, True),
    SPHERE: Kind("sphere", ("rate",), True, True),
    KICK: Kind("kick", _TORQUE + _CONTROLS, True, False),
    KICK_IMPLICIT: Kind("implicit kick", _TORQUE + _CONTROLS, False, False),
    DAMP: Kind("damping", (*_MOMENTS, "eps"), False, False),
    DMV: Kind("dmv", _MOMENTS, False, False),
    EXACT: Kind("exact", _MOMENTS, True, False),
    EULER: Kind("euler", (*_MOMENTS, *_TORQUE, "eps", *_ROTOR, *_CONTROLS), False, False),
    RK4: Kind("rk4", (*_MOMENTS, *_TORQUE, "eps", *_ROTOR, *_CONTROLS), False, False),
    LIE_EULER: Kind("lie_euler", (*_MOMENTS, *_TORQUE, "eps", *_ROTOR, *_CONTROLS), False,
                    False),
    RKMK4: Kind("rkmk4", (*_MOMENTS, *_TORQUE, "eps", *_ROTOR, *_CONTROLS), False, False),
    AXIS_SHIFTED: Kind("axis (gyrostat)", ("rate", *_ROTOR), True, True),
}

#: parameter name -> slot
SLOTS: dict[str, int] = {"I1": P_I1, "I2": P_I2, "I3": P_I3, "rate": P_RATE,
                         "torque": P_TORQUE, "eps": P_EPS, "l1": P_L1, "l2": P_L2, "l3": P_L3,
                         "ld1": P_LD1, "ld2": P_LD2, "ld3": P_LD3, "lt": P_LT,
                         **{f"u{i}": P_U0 + i for i in range(N_CONTROLS)}}

# ------------------------------------------------------------------------------ families
# The driver is compiled once per family, for the stage kinds of that family only, so a
# method compiles no more than it runs (a free-body splitting never compiles the
# elliptic exact flow). A plan runs in the first family, in this order, that holds all
# its kinds; GENERAL holds every kind.
F_AXES = 0  # axis rotations (free-body splitting2 and its compositions)
F_ROTATIONS = 1  # every rotation (sr2, free symmetric bodies)
F_KICKED = 2  # rotations and explicit kicks (splittings of orientation-only torques)
F_SPLITTING = 3  # rotations, kicks and dissipation (splittings of torqued scenes)
F_DMV_FREE = 4  # DMV alone (rattle, preprocessed DMV on a free body)
F_DMV = 5  # DMV and kicks (rattle on torqued scenes)
F_EXACT = 6  # the exact flow, kicks and dissipation
F_EULER = 7
F_RK4 = 8
F_LIE_EULER = 9
F_RKMK4 = 10
F_GENERAL = 11  # every kind (plans that mix kinds of several families)
F_ROTOR = 12  # rotations and a rotor's axis term (free gyrostats, reaction wheels)
F_ROTOR_TORQUED = 13  # the same with kicks and dissipation (a rotor under a torque)



def family_tag(family: int, diag: bool = False) -> str:
    """The name a family's driver kernels carry (every kernel its own name: ``_jit``)."""
    return f"family{family}_diag" if diag else f"family{family}"


_KICKS = frozenset({KICK, KICK_IMPLICIT})
_ROTATIONS = frozenset({AXIS, AXIS_RECURRING, SPHERE})

#: family code -> the stage kinds its driver runs (in the order tried)
FAMILIES: dict[int, frozenset[int]] = {
    F_AXES: frozenset({AXIS}),
    F_ROTATIONS: _ROTATIONS,
    F_KICKED: _ROTATIONS | {KICK},
    F_SPLITTING: _ROTATIONS | _KICKS | {DAMP},
    # (a rotor's turn carries double-length parts through a step: the rigid families
    # above do not compile it)
    F_ROTOR: _ROTATIONS | {AXIS_SHIFTED},
    F_ROTOR_TORQUED: _ROTATIONS | _KICKS | {DAMP, AXIS_SHIFTED},
    F_DMV_FREE: frozenset({DMV}),
    F_DMV: _KICKS | {DMV},
    F_EXACT: _KICKS | {EXACT, DAMP},
    F_EULER: frozenset({EULER}),
    F_RK4: frozenset({RK4}),
    F_LIE_EULER: frozenset({LIE_EULER}),
    F_RKMK4: frozenset({RKMK4}),
    F_GENERAL: frozenset(KINDS),
}


def _members() -> np.ndarray:
    table = np.zeros((len(FAMILIES), max(KINDS) + 1), dtype=np.bool_)
    for code, members in FAMILIES.items():
        table[code, sorted(members)] = True
    table.flags.writeable = False
    return table


#: ``MEMBERS[family, kind]``: whether the family's driver runs the kind (the driver checks
#: every stage of a table against it once, before stepping)
MEMBERS = _members()


def family_of(kinds) -> int:
    """The smallest driver family that runs every kind in ``kinds``."""
    need = {int(k) for k in kinds}
    unknown = need - set(KINDS)
    if unknown:
        raise ValueError(f"unknown stage kind(s) {sorted(unknown)}; known: {sorted(KINDS)}")
    for code, members in FAMILIES.items():
        if need <= members:
            return code
    raise AssertionError("F_GENERAL holds every kind")  # pragma: no cover
