"""User-defined methods: compositions and splittings registered as data, then integrated
and checked by liebody.testing like any built-in method."""

from __future__ import annotations

import warnings

import numba
import numpy as np
import pytest

import liebody
from liebody import _methods, testing
from liebody import _plan as P

G1 = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))
TRIPLE_JUMP = [G1, 1.0 - 2.0 * G1, G1]


def test_yoshida_triple_jump_is_order_4(registered):
    m = liebody.register_composition("user_triple_jump", TRIPLE_JUMP)
    registered.append(m.name)
    assert m.order == 4 and m.reversible and m.symplectic
    assert "user_triple_jump" in liebody.methods()
    for name in ("hlw", "top"):
        found = testing.assert_order(m, name, 4)
        assert found.rounded == 4
    p = testing.problem("top")
    traj = liebody.integrate(p.scene, q0=p.q0, L0=p.L0, dt=4e-3, steps=100_000,
                             method=m.name, save_every=10)
    assert testing.energy_drift(traj).kind in ("bounded", "random walk")


def test_composition_report():
    r = liebody.composition_report(TRIPLE_JUMP)
    assert r.palindromic and r.order_bound == 4
    assert abs(r.power_sums[3]) < 1e-14 and abs(r.total - 1) < 1e-15
    assert "order at most 4" in str(r)
    r = liebody.composition_report([0.25, 0.75])
    assert not r.palindromic and r.order_bound == 2
    with pytest.raises(ValueError, match="must sum to 1"):
        liebody.composition_report([0.5, 0.6])
    with pytest.raises(ValueError, match="finite numbers"):
        liebody.composition_report([0.5, float("nan")])


def test_composition_checks(registered):
    with pytest.raises(ValueError, match="must sum to 1"):
        liebody.register_composition("user_bad", [0.4, 0.4])
    with pytest.raises(ValueError):
        liebody.register_composition("user_bad", TRIPLE_JUMP, order=6)  # only order 4
    with pytest.raises(ValueError, match="cannot be composed"):
        liebody.register_composition("user_bad", TRIPLE_JUMP, base="rk4")
    with pytest.raises(ValueError, match="unknown method"):
        liebody.register_composition("user_bad", TRIPLE_JUMP, base="nope")
    assert "user_bad" not in liebody.methods()
    m = liebody.register_composition("user_halves", [0.5, 0.5])
    registered.append(m.name)
    assert m.order == 2
    with pytest.raises(ValueError, match="registered already"):
        liebody.register_composition("user_halves", [0.5, 0.5])


def test_lie_trotter_splitting_is_order_1(registered):
    m = liebody.register_splitting("user_lie_trotter",
                                   [("T1", 1.0), ("T2", 1.0), ("T3", 1.0, 1.0)])
    registered.append(m.name)
    assert (m.order, m.reversible) == (1, False)
    found = testing.assert_order(m.name, "asym", 1)
    assert found.rounded == 1
    # a free-body-only splitting is refused on a torqued scene, by name
    with pytest.raises(ValueError, match="cannot integrate"):
        testing.observed_order(m.name, "top")


def test_user_strang_splitting_matches_built_in_order_and_keeps_invariants(registered):
    flows = [("kick", 0.5), ("T1", 0.5), ("T2", 0.5), ("T3", 1.0, 1.0), ("T2", 0.5),
             ("T1", 0.5), ("kick", 0.5)]
    m = liebody.register_splitting("user_strang", flows)
    registered.append(m.name)
    assert (m.order, m.reversible, m.symplectic) == (2, True, True)
    for name in ("lagrange", "top", "asym"):
        testing.assert_order(m.name, name, 2)
    p = testing.problem("lagrange")
    traj = liebody.integrate(p.scene, q0=p.q0, L0=p.L0, dt=0.01, steps=100_000,
                             method=m.name, save_every=10)
    testing.assert_invariants(traj, qnorm=1e-12)


def test_splitting_checks(registered):
    with pytest.raises(ValueError, match=r"T2 runs for 0\.5"):
        liebody.register_splitting("user_bad", [("T1", 1.0), ("T2", 0.5), ("T3", 1.0)])
    with pytest.raises(ValueError, match="unknown sub-flow 'T4'"):
        liebody.register_splitting("user_bad", [("T4", 1.0)])
    with pytest.raises(ValueError, match="'kick' runs for"):
        liebody.register_splitting("user_bad", [("kick", 0.5), ("free", 1.0, 1.0)])
    with pytest.raises(ValueError, match="clocks add up to"):
        liebody.register_splitting("user_bad", [("kick", 0.5), ("free", 1.0), ("kick", 0.5)])
    assert "user_bad" not in liebody.methods()
    # the exact free flow between two half kicks: order 2 on the top
    m = liebody.register_splitting("user_kdk", [("kick", 0.5), ("free", 1.0, 1.0),
                                                ("kick", 0.5)])
    registered.append(m.name)
    testing.assert_order(m.name, "top", 2)


def test_a_registered_method_is_benchmarked(registered, monkeypatch):
    """``python -m bench --register MODULE`` imports the user's module first; its methods
    are then in every benchmark problem that they can integrate."""
    from bench import core
    from bench.problems import problems

    calls = []
    monkeypatch.setattr(core, "run_all", lambda *a, **k: calls.append(k))
    monkeypatch.syspath_prepend(str(__import__("pathlib").Path(__file__).parent))
    registered.append("plugin_triple_jump")
    assert core.main(["--register", "plugin_triple_jump", "--quick", "--only",
                      "work_precision"]) == 0
    assert calls and calls[0]["quick"]
    for key in ("hlw", "top"):
        assert "plugin_triple_jump" in problems()[key].methods()


def test_compositions_of_a_higher_order_base(registered):
    """The power conditions start above the base's order: a symmetric composition of a
    fourth-order base keeps order 4 by itself and gains order 6 when sum g^5 = 0 (the
    triple jump built for order 4 -> 6, Yoshida 1990)."""
    halves = liebody.register_composition("user_dmv4_halves", [0.5, 0.5], base="dmv4")
    registered.append(halves.name)
    assert halves.order == 4
    g = 1.0 / (2.0 - 2.0 ** (1.0 / 5.0))
    six = liebody.register_composition("user_jump6", [g, 1.0 - 2.0 * g, g],
                                       base="splitting4", order=6)
    registered.append(six.name)
    default = liebody.register_composition("user_jump6_default", [g, 1.0 - 2.0 * g, g],
                                           base="splitting4")
    registered.append(default.name)
    assert six.order == default.order == 6
    assert testing.observed_order(halves, "hlw").rounded == 4
    assert testing.observed_order(six, "hlw").rounded == 6
    with pytest.raises(ValueError, match="from a base of order 4: sum g\\^5"):
        liebody.register_composition("user_bad", TRIPLE_JUMP, base="splitting4", order=6)


def test_orders_that_cannot_be_checked_are_refused(registered):
    """A composition that is not symmetric cannot claim more than its base's order, nor a
    splitting that is not palindromic more than order 1 (Lie-Trotter is first order)."""
    with pytest.raises(ValueError, match="order 6 cannot be checked: only a symmetric"):
        liebody.register_composition("user_bad", [0.3, 0.7], order=6)
    with pytest.raises(ValueError, match="order 2 cannot be checked for a sequence"):
        liebody.register_splitting("user_bad", [("T1", 1.0), ("T2", 1.0), ("T3", 1.0)],
                                   order=2)
    assert "user_bad" not in liebody.methods()
    m = liebody.register_composition("user_asym", [0.3, 0.7])
    registered.append(m.name)
    assert m.order == 2 and not m.reversible


def test_a_splitting_whose_kicks_run_at_unmirrored_times_is_not_symmetric(registered):
    """A kick reads the clock: Strang's K(h/2) F(h) K(h/2) is symmetric only with the
    kicks at the two ends of the step. Before: the clocks were ignored, and the variants
    below were called order 2 and reversible (measured: order 1)."""
    for name, flows in (("user_clock_last", [("kick", 0.5), ("free", 1.0), ("kick", 0.5, 1.0)]),
                        ("user_clock_split", [("kick", 0.5, 0.25), ("free", 1.0, 0.5),
                                              ("kick", 0.5, 0.25)])):
        m = liebody.register_splitting(name, flows)
        registered.append(m.name)
        assert m.order == 1 and not m.reversible
        with pytest.raises(ValueError, match="cannot be checked"):
            liebody.register_splitting(name + "_2", flows, order=2)
    strang = liebody.register_splitting("user_strang_kicks",
                                        [("kick", 0.5), ("free", 1.0, 1.0), ("kick", 0.5)])
    registered.append(strang.name)
    assert strang.order == 2 and strang.reversible


def _strang_flows(a: float) -> list:
    return [("T1", a / 2), ("T2", a / 2), ("T3", a), ("T2", a / 2), ("T1", a / 2)]


def test_a_splitting_declaring_a_false_order_is_refused(registered):
    """register_splitting checks a declared order as register_composition does (before:
    Strang declared order 4 and was registered). Strang is order 2: its third-order BCH
    terms do not vanish; Yoshida's triple jump of it, written as sub-flows, is order 4
    (measured against the exact flow) and not 6."""
    with pytest.raises(ValueError, match=r"declared order 4 is false: the terms of degree 3"):
        liebody.register_splitting("user_bad", _strang_flows(1.0), order=4)
    with pytest.raises(ValueError, match=r"declared order 4 is false"):
        liebody.register_splitting("user_bad", [("kick", 0.5), ("free", 1.0, 1.0),
                                                ("kick", 0.5)], order=4)
    flows = _strang_flows(G1) + _strang_flows(1.0 - 2.0 * G1) + _strang_flows(G1)
    with pytest.raises(ValueError, match=r"declared order 6 is false: the terms of degree 5"):
        liebody.register_splitting("user_bad", flows, order=6)
    assert "user_bad" not in liebody.methods()
    m = liebody.register_splitting("user_jump_flows", flows, order=4)
    registered.append(m.name)
    assert testing.assert_order(m, "asym", 4).rounded == 4
    # the composition route refuses the same false claim
    with pytest.raises(ValueError, match=r"sum g\^5"):
        liebody.register_composition("user_bad", TRIPLE_JUMP, order=6)


def test_replacing_a_built_in_method_warns(registered):
    """A registration that replaces a built-in (here the scenes' default, splitting2)
    warns, naming it (before: silent); replacing a user's own method does not."""
    original = _methods.get("splitting2")
    try:
        with pytest.warns(UserWarning, match=r"'splitting2' replaces liebody's built-in "
                                             r"method .*default method of .*HeavyTop"):
            liebody.register_composition("splitting2", [0.5, 0.5], replace=True)
        assert liebody.methods()["splitting2"] is not original
    finally:
        _methods._REGISTRY["splitting2"] = original
        _methods._PLANS.clear()
    m = liebody.register_composition("user_halves2", [0.5, 0.5])
    registered.append(m.name)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        liebody.register_composition("user_halves2", [0.5, 0.5], replace=True)
        liebody.register(original, replace=True)  # the built-in itself: nothing replaced


@numba.njit
def _wobble(t, q, L):
    return np.array([0.05 * np.sin(3.0 * t), 0.05 * np.cos(2.0 * t), 0.0])


def test_kicks_that_advance_the_clock_are_not_merged_across_it(registered):
    """A kick reads the clock at its start: two adjacent kicks merge only when the first
    leaves the clock where it was. Strang with the clock carried by its kicks, and a
    sequence of two such kicks, on a torque of the time: the result does not depend on how
    the run is saved (before, the end kicks merged and read the torque half a step early:
    3.6e-3 apart), and equals the same sequence with the kicks kept apart by vanishing
    free flows."""
    scene = liebody.TorqueBody(liebody.RigidBody((1.0, 2.0, 3.0)), _wobble,
                               orientation_only=True)
    d = 1e-13
    sequences = {
        "kc_strang": [("kick", 0.5, 0.5), ("free", 1.0, 0.0), ("kick", 0.5, 0.5)],
        "kc_pair": [("kick", 0.25, 0.25), ("kick", 0.25, 0.25), ("free", 1.0, 0.0),
                    ("kick", 0.5, 0.5)],
        "kc_apart": [("free", d, 0.0), ("kick", 0.25, 0.25), ("free", d, 0.0),
                     ("kick", 0.25, 0.25), ("free", 1.0 - 3 * d, 0.0), ("kick", 0.5, 0.5),
                     ("free", d, 0.0)]}
    for name, flows in sequences.items():
        registered.append(name)
        liebody.register_splitting(name, flows)

    def run(name, **kw):
        return liebody.integrate(scene, L0=[3.0, 1.0, -2.0], dt=0.05, steps=100, method=name,
                                 **kw).L[-1]

    for name in ("kc_strang", "kc_pair"):
        every = run(name)
        assert np.array_equal(every, run(name, save_every=None))
        assert np.array_equal(every, run(name, diagnostics=True))
    assert np.abs(run("kc_pair") - run("kc_apart")).max() < 1e-12



# SABA_1 (the kick in the middle of the free flow), written canonically and with its first
# free flow cut in two pieces
SABA1 = [("free", 0.5, 0.5), ("kick", 1.0), ("free", 0.5, 0.5)]
SABA1_CUT = [("free", 0.3, 0.3), ("free", 0.2, 0.2), ("kick", 1.0), ("free", 0.5, 0.5)]


def _order_on_a_torque_of_the_time(method: str):
    """The observed order on the ``_wobble`` torque (of the time only), against
    splitting8 at 4096 steps (4.8e-14 from 2048 steps)."""
    scene = liebody.TorqueBody(liebody.RigidBody((1.0, 2.0, 3.0)), _wobble,
                               orientation_only=True)
    L0, t_end = np.array([3.0, 1.0, -2.0]), 2.0
    ref = liebody.integrate(scene, L0=L0, dt=t_end / 4096, steps=4096, method="splitting8",
                            save_every=None)

    def error(n):
        tr = liebody.integrate(scene, L0=L0, dt=t_end / n, steps=n, method=method,
                               save_every=None)
        return testing.state_error(tr.q[-1], tr.L[-1], ref.q[-1], ref.L[-1])

    return testing.observed_order(error=error, t_end=t_end, h_max=0.1)


def test_symmetry_is_judged_after_merging_pieces_of_one_flow(registered):
    """Adjacent pieces of one flow run as one (the plan compiler merges them), so the
    symmetry is that of the merged sequence. Before: judged on the sequence as written, the
    cut SABA_1 was order 1, not reversible, and order=2 was refused; it runs the very same
    steps as SABA_1 and measures order 2 on the heavy top and on a torque of the time."""
    m = liebody.register_splitting("user_saba1_cut", SABA1_CUT)
    registered.append(m.name)
    assert (m.order, m.reversible, m.symplectic) == (2, True, True)
    registered.append("user_saba1_cut_2")
    assert liebody.register_splitting("user_saba1_cut_2", SABA1_CUT, order=2).reversible
    found = testing.observed_order(m, "top")
    assert found.rounded == 2 and abs(found.order - 2.0) < 0.1
    assert _order_on_a_torque_of_the_time(m.name).rounded == 2
    ref = liebody.register_splitting("user_saba1", SABA1)
    registered.append(ref.name)
    p = testing.problem("top")
    runs = [liebody.integrate(p.scene, q0=p.q0, L0=p.L0, dt=0.01, steps=200, method=name)
            for name in (m.name, ref.name)]
    assert np.array_equal(runs[0].q, runs[1].q) and np.array_equal(runs[0].L, runs[1].L)
    # the order check sees the product of the flows: the same verdict on either form
    for order in (2, 3):
        verdicts = []
        for flows in (SABA1_CUT, SABA1):
            try:
                _methods.check_splitting(flows, order)
                verdicts.append("ok")
            except ValueError as exc:
                verdicts.append(str(exc))
        assert verdicts[0] == verdicts[1] and (verdicts[0] == "ok") == (order == 2)


def test_a_piece_of_zero_length_does_not_break_the_symmetry(registered):
    flows = [("kick", 0.5), ("T1", 0.5), ("T2", 0.0), ("T2", 0.5), ("T3", 1.0, 1.0),
             ("T2", 0.5), ("T1", 0.5), ("kick", 0.5)]
    m = liebody.register_splitting("user_strang_zero", flows)
    registered.append(m.name)
    assert (m.order, m.reversible) == (2, True)
    flows = [("kick", 0.5), ("T3", 0.0), ("T1", 0.5), ("T2", 0.5), ("T3", 1.0, 1.0),
             ("T2", 0.5), ("T1", 0.5), ("kick", 0.5)]  # nothing to merge it with
    m = liebody.register_splitting("user_strang_zero_apart", flows, order=2)
    registered.append(m.name)
    assert (m.order, m.reversible) == (2, True)
    assert testing.observed_order(m, "top").rounded == 2
    # a piece of zero length that advances the clock: its advance goes to the piece
    # before, so this is Strang with the clock on the free flow, and runs as it does (the
    # plan compiler dropped the piece with its clock: both kicks read the step's start,
    # measured order 1 on a torque of the time, 4e-3 from Strang after 100 steps)
    flows = [("kick", 0.5), ("free", 1.0), ("free", 0.0, 1.0), ("kick", 0.5)]
    m = liebody.register_splitting("user_zero_with_clock", flows)
    registered.append(m.name)
    assert (m.order, m.reversible) == (2, True)
    strang = liebody.register_splitting("user_strang_clocked",
                                        [("kick", 0.5), ("free", 1.0, 1.0), ("kick", 0.5)])
    registered.append(strang.name)
    scene = liebody.TorqueBody(liebody.RigidBody((1.0, 2.0, 3.0)), _wobble,
                               orientation_only=True)
    a, b = (liebody.integrate(scene, L0=[3.0, 1.0, -2.0], dt=0.05, steps=100, method=name)
            for name in (m.name, strang.name))
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.L, b.L)
    assert _order_on_a_torque_of_the_time(m.name).rounded == 2


def test_a_sequence_not_symmetric_once_merged_stays_first_order(registered):
    """Merged, free(0.2) free(0.2) kick free(0.6) is free(0.4) kick free(0.6): not a
    palindrome. SABA_1 cut, with the clock carried by its kick, reads the torque at the
    step's start: merged, its free flows mirror but the kick's time does not (order 1 on a
    torque of the time; 2 on the heavy top, whose torque does not read the clock)."""
    for name, flows in (("user_merged_asym", [("free", 0.2, 0.2), ("free", 0.2, 0.2),
                                              ("kick", 1.0), ("free", 0.6, 0.6)]),
                        ("user_kick_early", [("free", 0.3), ("free", 0.2),
                                             ("kick", 1.0, 1.0), ("free", 0.5)])):
        m = liebody.register_splitting(name, flows)
        registered.append(m.name)
        assert (m.order, m.reversible) == (1, False)
        with pytest.raises(ValueError, match="order 2 cannot be checked for a sequence"):
            liebody.register_splitting(name + "_2", flows, order=2)
        assert _order_on_a_torque_of_the_time(name).rounded == 1


def test_kicks_are_merged_for_the_judgement_only_where_the_clock_stands_still(registered):
    """Kicks of 1/4 at 0 and 1/2 of the step and 1/2 at its end: merging the first two
    (wrongly: the second reads a later time) would give Strang's kick-free-kick, a
    palindrome. Not merged, it is not symmetric, and measures order 1 on a torque of the
    time; with the clock standing still between the first two kicks they are one kick,
    and the sequence is Strang's (order 2)."""
    split = [("kick", 0.25, 0.5), ("kick", 0.25), ("free", 1.0, 0.5), ("kick", 0.5)]
    joined = [("kick", 0.25), ("kick", 0.25), ("free", 1.0, 1.0), ("kick", 0.5)]
    m_split = liebody.register_splitting("user_kicks_split", split)
    registered.append(m_split.name)
    assert (m_split.order, m_split.reversible) == (1, False)
    with pytest.raises(ValueError, match="order 2 cannot be checked for a sequence"):
        liebody.register_splitting("user_kicks_split_2", split, order=2)
    m_joined = liebody.register_splitting("user_kicks_joined", joined)
    registered.append(m_joined.name)
    assert (m_joined.order, m_joined.reversible) == (2, True)
    for m, p in ((m_split, 1), (m_joined, 2)):
        found = _order_on_a_torque_of_the_time(m.name)
        assert found.rounded == p, (m.name, found)


def _driven_wheels():
    """Three wheels driven at constant motor torques: the rotor momentum is linear in
    time, so the rotations must read it at mirrored times to keep a symmetric order."""
    scene = liebody.ReactionWheels(liebody.RigidBody([1.0, 2.0, 3.0]), axes=np.eye(3),
                                   inertia=0.1, momentum=[0.3, -0.2, 0.1])
    return scene, np.array([1.0, 0.5, -0.7]), np.array([0.4, -0.3, 0.5])


def _wheels_order(method: str):
    scene, L0, u = _driven_wheels()
    t_end = 2.0
    ref = liebody.integrate(scene, L0=L0, dt=t_end / 4096, steps=4096, method="splitting8",
                            save_every=None, controls=u)

    def error(n):
        tr = liebody.integrate(scene, L0=L0, dt=t_end / n, steps=n, method=method,
                               save_every=None, controls=u)
        return testing.state_error(tr.q[-1], tr.L[-1], ref.q[-1], ref.L[-1])

    return testing.observed_order(error=error, t_end=t_end, h_max=0.1)


def test_a_symmetric_splitting_reads_moving_wheels_at_mirrored_times_or_is_refused(
        registered):
    """A T_k piece reads a rotor momentum that changes in time at the middle of its clock
    advance. Strang of T1, T2, T3 without a clock reads it at the step's start every time:
    order 2 on a rigid body, first order on driven wheels (measured 1.00 before, declared
    2): refused there; with the clock on T3 it reads at mirrored times and is order 2."""
    bare = liebody.register_splitting("user_t_strang", [
        ("T1", 0.5), ("T2", 0.5), ("T3", 1.0), ("T2", 0.5), ("T1", 0.5)])
    clocked = liebody.register_splitting("user_t_strang_clocked", [
        ("T1", 0.5), ("T2", 0.5), ("T3", 1.0, 1.0), ("T2", 0.5), ("T1", 0.5)])
    first = liebody.register_splitting("user_t_strang_first", [
        ("T1", 0.5), ("T2", 0.5), ("T3", 1.0), ("T2", 0.5), ("T1", 0.5)], order=1)
    registered.extend([bare.name, clocked.name, first.name])
    assert bare.order == clocked.order == 2
    scene, L0, u = _driven_wheels()
    with pytest.raises(ValueError, match=r"user_t_strang: .*do not mirror"):
        liebody.integrate(scene, L0=L0, dt=0.01, steps=3, method=bare.name, controls=u)
    assert _wheels_order(clocked.name).rounded == 2
    assert _wheels_order(first.name).rounded == 1  # declared first order: runs
    assert testing.observed_order(bare, "asym").rounded == 2  # (a rigid body: no clock read)


def test_a_kick_on_a_torque_free_scene_still_advances_the_clock(registered):
    """Driven wheels without a torque: the kicks do nothing, but their clock advance
    moves when the rotations read the wheels' momentum (it was dropped with them); the
    sequence runs as the same one with the advance on a piece of zero length."""
    with_kick = liebody.register_splitting("user_kick_clock", [
        ("kick", 0.5, 0.5), ("T1", 0.5), ("T2", 0.5), ("T3", 1.0), ("T2", 0.5),
        ("T1", 0.5, 0.5), ("kick", 0.5)], order=1)
    without = liebody.register_splitting("user_zero_clock", [
        ("T2", 0.0, 0.5), ("T1", 0.5), ("T2", 0.5), ("T3", 1.0), ("T2", 0.5),
        ("T1", 0.5, 0.5)], order=1)
    registered.extend([with_kick.name, without.name])
    scene, L0, u = _driven_wheels()
    a, b = (liebody.integrate(scene, L0=L0, dt=0.05, steps=40, method=m.name, controls=u)
            for m in (with_kick, without))
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.L, b.L)


# (flows, symmetric): split kicks, pieces of zero length with clocks, repeated pieces of
# one flow, clocks on a T3 piece and clocks placed asymmetrically. The verdicts are those
# of the merge rules register_splitting restated by hand before it judged the compiled
# plan (each checked by reasoning too: a kick reads the clock at its start; a T_k piece
# on driven wheels reads it mid-clock, so pieces of one axis with clocks out of
# proportion stay apart there; damp pieces never merge)
TRICKY = [
    ([("kick", 0.25, 0.5), ("kick", 0.25), ("free", 1.0, 0.5), ("kick", 0.5)], False),
    ([("kick", 0.25), ("kick", 0.25), ("free", 1.0, 1.0), ("kick", 0.5)], True),
    ([("kick", 0.25), ("kick", 0.25, 1.0), ("free", 1.0), ("kick", 0.5)], True),
    ([("kick", 0.5, 0.5), ("free", 1.0), ("kick", 0.5, 0.5)], False),
    ([("kick", 0.25, 0.25), ("kick", 0.25, 0.25), ("free", 1.0), ("kick", 0.5, 0.5)], False),
    ([("kick", 0.5), ("free", 1.0), ("free", 0.0, 1.0), ("kick", 0.5)], True),
    ([("kick", 0.5), ("free", 1.0, 0.5), ("kick", 0.0, 0.5), ("kick", 0.5)], True),
    ([("kick", 0.5), ("T3", 0.0), ("T1", 0.5), ("T2", 0.5), ("T3", 1.0, 1.0), ("T2", 0.5),
      ("T1", 0.5), ("kick", 0.5)], True),
    ([("kick", 0.5), ("T1", 0.5), ("T2", 0.5), ("T3", 0.0, 1.0), ("T3", 1.0), ("T2", 0.5),
      ("T1", 0.5), ("kick", 0.5)], True),
    ([("kick", 0.5), ("T1", 0.5), ("T2", 0.5), ("T3", 1.0), ("kick", 0.0, 1.0), ("T2", 0.5),
      ("T1", 0.5), ("kick", 0.5)], True),
    (SABA1_CUT, True),
    ([("free", 0.2, 0.2), ("free", 0.2, 0.2), ("kick", 1.0), ("free", 0.6, 0.6)], False),
    ([("free", 0.3), ("free", 0.2), ("kick", 1.0, 1.0), ("free", 0.5)], False),
    ([("T1", 0.25), ("T1", 0.25), ("T2", 0.5), ("T3", 1.0, 1.0), ("T2", 0.5), ("T1", 0.5)],
     True),
    ([("T1", 0.25, 0.25), ("T1", 0.25, 0.25), ("T2", 0.5), ("T3", 1.0), ("T2", 0.5),
      ("T1", 0.5, 0.5)], True),
    ([("T1", 0.25, 0.5), ("T1", 0.25), ("T2", 0.5), ("T3", 1.0), ("T2", 0.5),
      ("T1", 0.5, 0.5)], False),
    ([("T1", 1.0), ("T2", 1.0), ("T3", 1.0, 1.0)], False),
    ([("T1", 0.5, 1.0), ("T2", 0.5), ("T3", 1.0), ("T2", 0.5), ("T1", 0.5)], True),
    ([("kick", 0.5), ("T1", 0.5, 1.0), ("T2", 0.5), ("T3", 1.0), ("T2", 0.5), ("T1", 0.5),
      ("kick", 0.5)], True),
    ([("kick", 0.5), ("free", 1.0), ("kick", 0.5, 1.0)], False),
    ([("kick", 0.5, 0.25), ("free", 1.0, 0.5), ("kick", 0.5, 0.25)], False),
    ([("damp", 0.5), *_strang_flows(1.0)[:2], ("T3", 1.0, 1.0), *_strang_flows(1.0)[3:],
      ("damp", 0.5)], True),
    ([("damp", 0.25), ("damp", 0.25), ("free", 1.0, 1.0), ("damp", 0.5)], False),
    ([("kick", 0.5), ("damp", 0.5), ("free", 1.0, 1.0), ("damp", 0.5), ("kick", 0.5)], True),
]


@pytest.mark.parametrize(("flows", "symmetric"), TRICKY)
def test_the_symmetry_verdict_on_tricky_sequences(registered, flows, symmetric):
    """register_splitting judges the symmetry on the plan compiled for the scenes the
    method runs on: on these sequences it gives the verdict of the merge rules it wrote
    out by hand before (a second copy of the plan compiler's)."""
    m = liebody.register_splitting("user_tricky", flows)
    registered.append(m.name)
    assert (m.order, m.reversible) == ((2, True) if symmetric else (1, False))
    assert _methods._symmetric_as_run(P.FlowSequence(tuple(flows))) == symmetric


def test_a_sequence_symmetric_once_compiled_is_symmetric(registered):
    """Sequences that are not palindromes as written but compile to one are symmetric:
    pieces of T1 and T2 cut differently on the two sides (the plan is Strang's), and
    free(1/2) free(-1/2) free(1), whose first two cancel, leaving their clock to the
    third: the plan and the run are Strang's K F K with the clock on F. Before, the
    hand-written rules kept the cancelled pair as a piece of zero length of its own, and
    called that sequence first order; so did they a first piece of zero length that only
    advances the clock (kept, and not mirrored), where the plan has nothing that acts."""
    cut = [("T1", 0.2), ("T1", 0.3), ("T2", 0.5), ("T3", 1.0, 1.0), ("T2", 0.25),
           ("T2", 0.25), ("T1", 0.5)]
    cancel = [("kick", 0.5), ("free", 0.5), ("free", -0.5, 0.5), ("free", 1.0, 0.5),
              ("kick", 0.5)]
    late = [("T2", 0.0, 0.5), ("T1", 0.5), ("T2", 0.5), ("T3", 1.0), ("T2", 0.5),
            ("T1", 0.5, 0.5)]
    methods = {}
    for name, flows in (("user_cut", cut), ("user_cancel", cancel), ("user_late", late),
                        ("user_strang_t", _strang_flows(1.0)[:2] + [("T3", 1.0, 1.0)]
                         + _strang_flows(1.0)[3:]),
                        ("user_strang_k", [("kick", 0.5), ("free", 1.0, 1.0),
                                           ("kick", 0.5)])):
        methods[name] = liebody.register_splitting(name, flows)
        registered.append(name)
        assert not P.FlowSequence(tuple(flows)).palindromic or name.startswith("user_strang")
        assert (methods[name].order, methods[name].reversible) == (2, True), name
    wheels, L0, u = _driven_wheels()
    torqued = liebody.TorqueBody(liebody.RigidBody((1.0, 2.0, 3.0)), _wobble,
                                 orientation_only=True)
    free = liebody.FreeBody(liebody.RigidBody((1.0, 2.0, 3.0)))
    for scene, a, b in ((free, "user_cut", "user_strang_t"),
                        (torqued, "user_cancel", "user_strang_k")):
        pa, pb = (methods[n].plan(scene, L0, 0.05) for n in (a, b))
        for field in ("kinds", "axes", "coefs", "clock"):
            np.testing.assert_array_equal(getattr(pa, field), getattr(pb, field))
    a, b = (liebody.integrate(torqued, L0=[3.0, 1.0, -2.0], dt=0.05, steps=100, method=n)
            for n in ("user_cancel", "user_strang_k"))
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.L, b.L)
    # the clock of the first piece moves the wheels' reads: refused there as order 2
    with pytest.raises(ValueError, match=r"user_late: .*do not mirror"):
        liebody.integrate(wheels, L0=L0, dt=0.01, steps=3, method="user_late", controls=u)
