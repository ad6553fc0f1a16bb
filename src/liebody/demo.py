"""``python -m liebody demo [--plot DIR]``: classical rigid-body phenomena, simulated.

Four scenes, each checked against its closed form: the rigid Earth's Chandler wobble
(the force-free symmetric top), the instability of rotation about the intermediate
axis (stability of rotation about the principal axes), the Dzhanibekov flips that
follow (their period ``4 K(k)/nu``, Landau & Lifshitz, *Mechanics*, §37), and a
Lagrange top released from rest (the heavy symmetric top); the other three topics are
those of Hand & Finch, *Analytical Mechanics*, ch. 8. For each, a small table prints the
prediction, the simulation, their relative difference, and the drift of the
invariants. ``--plot DIR`` also writes PNG figures (needs matplotlib, the ``plot``
extra).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

_W = 78


def _title(text: str) -> None:
    print()
    print(text)
    print("-" * min(_W, len(text)))


def _table(rows: list[tuple[str, float, float]]) -> None:
    print(f"  {'quantity':<38s} {'predicted':>12s} {'simulated':>12s} {'rel. diff':>10s}")
    for label, pred, sim in rows:
        rel = abs(sim - pred) / abs(pred) if pred != 0 else abs(sim)
        print(f"  {label:<38s} {pred:>12.6g} {sim:>12.6g} {rel:>10.1e}")


def _drift(label: str, values: np.ndarray, scale: float | None = None) -> str:
    values = np.asarray(values, dtype=float)
    scale = scale if scale is not None else float(np.max(np.abs(values[0]))) or 1.0
    d = float(np.max(np.abs(values - values[0]))) / scale
    return f"{label} {d:.1e}"


def _invariants(traj) -> None:
    parts = [_drift("energy", traj.energy), _drift("|L|", traj.casimir),
             _drift("L_space", traj.L_space, float(np.linalg.norm(traj.L_space[0]))),
             _drift("|q|", traj.quaternion_norm, 1.0)]
    print("  relative drift over the run: " + ", ".join(parts))


# --------------------------------------------------------------------------- the scenes


def chandler(plot_dir: Path | None) -> None:
    """Force-free symmetric top: the rigid Earth's free wobble, period A/(C - A) sidereal days."""
    import liebody
    from liebody import analysis, bodies

    earth = bodies.earth()
    day = bodies.SIDEREAL_DAY
    spin = bodies.earth_spin()
    offset = 1e-6  # rad between the rotation axis and the figure axis (about 6 m at the pole)
    omega0 = spin * np.array([np.sin(offset), 0.0, np.cos(offset)])
    predicted = analysis.chandler_period(earth)  # sidereal days
    t_end = 3 * predicted * day
    # a free symmetric body: the default method is its exact flow (trigonometric), one
    # sample a day
    traj = liebody.integrate(liebody.FreeBody(earth), omega0=omega0, dt=day,
                             t_end=round(t_end / day) * day)
    measured = analysis.wobble_period(traj) / day
    _title("1. Chandler wobble of the rigid Earth (force-free symmetric top)")
    print(f"  Earth: (C - A)/C = {bodies.EARTH_H}, spin 1 sidereal day; exact flow, "
          f"{len(traj)} daily samples")
    _table([("wobble period [sidereal days]", predicted, measured)])
    print("  (observed: ~433 days; the real Earth is not rigid: elastic mantle, oceans, core)")
    _invariants(traj)
    if plot_dir is not None:
        import matplotlib.pyplot as plt

        polar = traj.omega[:, :2] / spin * 206264.806 * 1e3  # milliarcseconds
        fig, ax = plt.subplots(figsize=(5.5, 5.5))
        ax.plot(polar[:, 0], polar[:, 1], lw=1)
        ax.plot(polar[0, 0], polar[0, 1], "o", label="start")
        ax.set_xlabel("omega_1 / |omega|  [mas]")
        ax.set_ylabel("omega_2 / |omega|  [mas]")
        ax.set_title(f"Rigid-Earth pole wobble (body frame)\nperiod {measured:.2f} sidereal "
                     f"days (closed form {predicted:.2f})")
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
        ax.legend()
        _save(fig, plot_dir / "chandler_wobble.png")


def intermediate_axis(plot_dir: Path | None) -> None:
    """Stability of the principal axes: about the middle one omega grows ~ exp(sqrt(r1 r3) w2 t)."""
    import liebody
    from liebody import analysis

    moments = np.array([1.0, 2.0, 3.0])
    body = liebody.RigidBody(moments)
    w2 = 1.0
    eps = 1e-8
    omega0 = np.array([eps, w2, eps])
    pred = analysis.stability(moments, w2, axis=1)
    traj = liebody.integrate(liebody.FreeBody(body), omega0=omega0, dt=0.05, t_end=30.0)
    # late enough for the decaying exp(-rate t) part to have died out, early enough for the
    # perturbation (1e-8 e^{rate t}) to stay in the linear regime
    window = (traj.t > 10.0) & (traj.t < 24.0)
    fitted = analysis.fit_growth_rate(traj, component=0, window=window)
    stable1 = analysis.stability(moments, 1.0, axis=0)
    stable3 = analysis.stability(moments, 1.0, axis=2)
    _title("2. Rotation about the intermediate axis is unstable (linear stability)")
    print(f"  I = {moments.tolist()}, omega = (1e-8, 1, 1e-8); exact flow at the output times")
    _table([("growth rate sqrt(r1 r3) omega2", pred.rate, fitted)])
    print(f"  axes 1 and 3 are stable, oscillating at sqrt(r2 r3) w1 = {stable1.rate:.4f} and "
          f"sqrt(r1 r2) w3 = {stable3.rate:.4f}")
    _invariants(traj)
    if plot_dir is not None:
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6.5, 4.5))
        ax.semilogy(traj.t, np.abs(traj.omega[:, 0]), lw=1, label="|omega_1| (simulated)")
        # linearised solution: w1 = eps [cosh(lt) - (r1 w2 / l) sinh(lt)] with l the rate
        r1 = (moments[2] - moments[1]) / moments[0]
        amp = 0.5 * eps * abs(1.0 - r1 * w2 / pred.rate)
        ax.semilogy(traj.t, amp * np.exp(pred.rate * traj.t), "--", lw=1,
                    label=f"linear theory, rate sqrt(r1 r3) w2 = {pred.rate:.4f}")
        ax.set_xlabel("t")
        ax.set_ylabel("|omega_1|  (rad per unit time)")
        ax.set_title("Intermediate-axis instability: exponential growth")
        ax.set_ylim(1e-9, 3)
        ax.grid(alpha=0.3, which="both")
        ax.legend()
        _save(fig, plot_dir / "intermediate_axis_growth.png")


def flips(plot_dir: Path | None) -> None:
    """Landau & Lifshitz §37: the flips of the T-handle repeat every 2 K(k)/nu."""
    import liebody
    from liebody import analysis

    moments = np.array([1.0, 2.0, 3.0])
    body = liebody.RigidBody(moments)
    L0 = np.array([1e-2, 2.0, 1e-2])
    period = analysis.flip_period(moments, L0)
    traj = liebody.integrate(liebody.FreeBody(body), L0=L0, dt=0.01, t_end=300.0,
                             method="splitting8")
    L2 = traj.L[:, 1]
    idx = np.flatnonzero(np.sign(L2[:-1]) != np.sign(L2[1:]))
    crossings = traj.t[idx] - L2[idx] * (traj.t[idx + 1] - traj.t[idx]) / (L2[idx + 1] - L2[idx])
    spacing = np.mean(np.diff(crossings))
    _title("3. Dzhanibekov flips (Landau & Lifshitz §37, elliptic integral K(k))")
    print(f"  I = {moments.tolist()}, L0 = {L0.tolist()}; splitting8, dt = 0.01, "
          f"{len(crossings)} flips")
    _table([("time between flips 2K(k)/nu", period / 2, spacing)])
    _invariants(traj)
    if plot_dir is not None:
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7.5, 4))
        for k, name in enumerate(("L_1", "L_2", "L_3")):
            ax.plot(traj.t, traj.L[:, k], lw=1, label=name)
        ax.set_xlabel("t")
        ax.set_ylabel("body angular momentum")
        ax.set_title(f"Dzhanibekov flips: L_2 reverses every {spacing:.3f} "
                     f"(2K(k)/nu = {period / 2:.3f})")
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right")
        _save(fig, plot_dir / "dzhanibekov_flips.png")


def lagrange_top(plot_dir: Path | None) -> None:
    """Heavy symmetric top: released from rest, it nutates with cusps."""
    import liebody
    from liebody import euler
    from liebody import lagrange_top as lt

    I1, I3, mgl = 5.0, 1.0, 20.0
    body = liebody.RigidBody([I1, I1, I3])
    top = liebody.HeavyTop(body, mass=20.0, cm=[0.0, 0.0, 1.0], g=1.0)
    theta0, spin = 0.5, 30.0
    q0 = euler.to_quaternion([0.0, theta0, 0.0])
    L0 = np.array([0.0, 0.0, I3 * spin])  # released: phidot = thetadot = 0
    motion = lt.LagrangeTop.from_heavy_top(top).motion_from_state(q0, L0)
    turning = motion.turning_points()
    th1, th2 = turning.theta1, turning.theta2
    period = motion.nutation_period()
    traj = liebody.integrate(top, q0=q0, L0=L0, dt=1e-3, t_end=6.0)
    angles = traj.euler_angles(unwrap=True)
    theta = angles[:, 1]
    # nutation period from the times theta returns to its minimum (parabola through 3 samples)
    i = np.flatnonzero((theta[1:-1] < theta[:-2]) & (theta[1:-1] <= theta[2:])) + 1
    a, b, c = theta[i - 1], theta[i], theta[i + 1]
    t_min = traj.t[i] + 0.5 * (traj.t[1] - traj.t[0]) * (a - c) / (a - 2 * b + c)
    measured_period = float(np.mean(np.diff(np.r_[0.0, t_min])))
    _title("4. Lagrange top released from rest (heavy symmetric top)")
    print(f"  I1 = {I1}, I3 = {I3}, M g l = {mgl}, theta(0) = {theta0}, spin {spin}; "
          f"splitting2 (exact symmetric free flow), dt = 1e-3")
    _table([("upper turning point theta1", th1, float(theta.min())),
            ("lower turning point theta2", th2, float(theta.max())),
            ("nutation period (quadrature)", period, measured_period)])
    print(f"  motion of the symmetry axis: {motion.motion_kind()} "
          f"(released with phidot = 0)")
    _invariants_top(traj)
    if plot_dir is not None:
        import matplotlib.pyplot as plt

        axis = traj.orientation
        from liebody import quaternion

        tip = quaternion.rotate(axis, [0.0, 0.0, 1.0])
        fig, ax = plt.subplots(figsize=(5.5, 5.5))
        ax.plot(tip[:, 0], tip[:, 1], lw=1)
        r1, r2 = np.sin(th1), np.sin(th2)
        s = np.linspace(0, 2 * np.pi, 200)
        ax.plot(r1 * np.cos(s), r1 * np.sin(s), "k:", lw=0.8, label="theta1, theta2")
        ax.plot(r2 * np.cos(s), r2 * np.sin(s), "k:", lw=0.8)
        ax.set_aspect("equal")
        ax.set_xlabel("x (space)")
        ax.set_ylabel("y (space)")
        ax.set_title("Symmetry axis seen from above: cusps at theta1")
        ax.legend(loc="upper right")
        ax.grid(alpha=0.3)
        _save(fig, plot_dir / "lagrange_top_cusps.png")


def _invariants_top(traj) -> None:
    parts = [_drift("energy", traj.energy),
             _drift("L_z (space)", traj.L_space[:, 2], float(np.linalg.norm(traj.L[0]))),
             _drift("L_3 (body)", traj.L[:, 2], float(np.linalg.norm(traj.L[0]))),
             _drift("|q|", traj.quaternion_norm, 1.0)]
    print("  relative drift over the run: " + ", ".join(parts))


def _save(fig, path: Path) -> None:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    import matplotlib.pyplot as plt

    plt.close(fig)
    print(f"  wrote {path}")


def run(plot_dir: str | None = None) -> int:
    """Run the tour; with ``plot_dir``, also write the figures there."""
    start = time.perf_counter()
    out = None
    if plot_dir is not None:
        try:
            import matplotlib

            matplotlib.use("Agg")
        except ImportError:
            print("--plot needs matplotlib: pip install 'liebody[plot]'")
            return 2
        out = Path(plot_dir)
        out.mkdir(parents=True, exist_ok=True)
    print("liebody demo: classical rigid-body phenomena, simulated and checked against "
          "their closed forms")
    chandler(out)
    intermediate_axis(out)
    flips(out)
    lagrange_top(out)
    print(f"\n(done in {time.perf_counter() - start:.1f} s, including numba compilation on "
          f"the first run; later runs load the compiled kernels from the cache)")
    return 0
