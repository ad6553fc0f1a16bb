"""No bias in |q| on the torqued path: a planet under the Sun's torque at a step of half a
day (its spin turns by about half a turn per step, so a step's roundings repeat) keeps
|q| at round-off over 2.2 million steps, and liebody accepts its own output."""

from __future__ import annotations

import math

import numpy as np
import pytest

import liebody
from liebody.orbits import Circular

N_SUN = 2 * math.pi / 365.25  # rad/day
EARTH = np.array([0.3296, 0.3296, 0.3307])  # C/(M R^2)-like moments
L_SPIN = EARTH * np.array([0.0, 0.0, 2 * math.pi * 1.0027])  # one turn per sidereal day


def _planet(moments=EARTH):
    body = liebody.RigidBody.batch(moments) if np.ndim(moments) == 2 else liebody.RigidBody(
        moments)
    return liebody.GravityGradient(body, [(N_SUN**2, Circular(N_SUN))])


@pytest.mark.long
def test_a_planet_at_half_a_day_keeps_q_on_the_unit_sphere():
    scene = _planet()
    q0 = liebody.quaternion.exp([0.409, 0.0, 0.0])  # the obliquity
    steps = 2_200_000
    tr = liebody.integrate(scene, q0=q0, L0=L_SPIN, dt=0.5, steps=steps, save_every=steps // 22)
    err = np.abs(np.linalg.norm(tr.q, axis=1) - 1.0)
    # round-off, not the 1.1e-10 of a bias of 5e-17 per step: no growth along the run
    assert err.max() <= 4.5e-16, err
    # liebody accepts its own output
    liebody.quaternion.rotate(tr.q, [1.0, 0.0, 0.0])
    more = liebody.integrate(scene, q0=tr.q[-1], L0=tr.L[-1], t0=tr.t[-1], dt=0.5, steps=10)
    assert more.t[0] == tr.t[-1]


def test_the_simd_kernels_keep_q_on_the_unit_sphere_too():
    moments = np.tile(EARTH, (16, 1))
    q0 = liebody.quaternion.exp(np.array([[0.3 + 0.01 * k, 0.0, 0.0] for k in range(16)]))
    steps = 200_000
    tr = liebody.integrate(_planet(moments), q0=q0, L0=L_SPIN, dt=0.5, steps=steps,
                           save_every=steps // 4, simd=True, threads=1)
    assert tr.info["simd"]
    err = np.abs(np.linalg.norm(tr.q, axis=-1) - 1.0)
    assert err.max() <= 4.5e-16, err.max(axis=0)
