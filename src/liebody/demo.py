"""``python -m liebody demo``: a short tour, each number checked against the reference text.

Every section prints the closed form beside what liebody computes and the relative
difference, so a newcomer sees both the physics and the accuracy.
"""

from __future__ import annotations

import numpy as np


def _row(label: str, predicted: float, computed: float) -> str:
    rel = abs(computed - predicted) / max(abs(predicted), 1e-300)
    return f"  {label:<44s} {predicted:>16.10g} {computed:>16.10g} {rel:>10.1e}"


def _header(title: str) -> None:
    print(f"\n{title}")
    print(f"  {'quantity':<44s} {'closed form':>16s} {'liebody':>16s} {'rel. diff':>10s}")


def tour_inertia() -> None:
    """Reference text 1.2.1 (thin disk, parallel axes) and 1.3 (principal axes)."""
    from liebody import RigidBody, inertia

    M, R = 2.0, 0.5
    disk = inertia.thin_disk(M, R)
    edge = inertia.parallel_axis(np.diag(disk), M, [R, 0.0, 0.0])
    _header("Thin disk (text 1.2.1): moments about the centre and about an edge point")
    print(_row("I_zz about the centre  = M R^2 / 2", M * R**2 / 2, disk[2]))
    print(_row("I_zz about the edge    = 3 M R^2 / 2", 3 * M * R**2 / 2, edge[2, 2]))

    # a rigid "molecule": four point masses, principal axes from the tensor
    masses = np.array([1.0, 2.0, 1.5, 0.5])
    pos = np.array([[0.0, 0.0, 0.0], [1.0, 0.2, 0.0], [0.1, 1.2, 0.3], [0.4, 0.4, 1.1]])
    body = RigidBody.from_point_masses(masses, pos)
    I_cm = inertia.tensor(masses, pos)
    _header("Point masses (text 1.3): principal moments = eigenvalues of I about the CM")
    for k, (lam, mom) in enumerate(zip(np.linalg.eigvalsh(I_cm), body.moments, strict=True)):
        print(_row(f"I_{k + 1}", lam, mom))
    T_axes = body.kinetic_energy([0.3, -0.2, 0.5])
    omega_in = body.axes @ np.array([0.3, -0.2, 0.5])
    print(_row("T = 1/2 omega.I.omega (input frame vs axes)", 0.5 * omega_in @ I_cm @ omega_in,
               float(T_axes)))


def tour_euler() -> None:
    """Reference text 1.6: z-x-z Euler angles, V, the rotation angle Phi."""
    from scipy.spatial.transform import Rotation

    from liebody import euler, quaternion

    angles = np.array([0.7, 1.2, -2.4])
    V = euler.matrix(*angles)
    V_scipy = Rotation.from_euler("ZXZ", angles).as_matrix()
    q = euler.to_quaternion(angles)
    back = euler.from_quaternion(q)
    phi, theta, psi = angles
    Phi = euler.rotation_angle(angles)
    _header("Euler angles (text 1.6): (phi, theta, psi) = (0.7, 1.2, -2.4)")
    print(f"  V = V1(phi) V2(theta) V3(psi) vs scipy from_euler('ZXZ'): max difference "
          f"{np.abs(V - V_scipy).max():.1e}")
    for name, a, b in zip(("phi", "theta", "psi"), angles, back, strict=True):
        print(_row(f"{name} after angles -> quaternion -> angles", a, b))
    print(_row("cos(Phi/2) = cos((phi+psi)/2) cos(theta/2)",
               np.cos((phi + psi) / 2) * np.cos(theta / 2), np.cos(Phi / 2)))
    print(_row("|q| of the rotation", 1.0, float(np.linalg.norm(q))))
    lock = euler.from_quaternion(quaternion.exp([0.0, 0.0, 0.9]))
    print(f"  gimbal lock (theta = 0): only phi + psi is defined; liebody returns "
          f"(phi, theta, psi) = ({lock[0]:.3f}, {lock[1]:.3f}, {lock[2]:.3f})")


def run(plot_dir: str | None = None) -> int:
    """Run the tour; ``plot_dir`` is accepted for forward compatibility (no figures yet)."""
    print("liebody demo: the reference text's formulas, computed")
    tour_inertia()
    tour_euler()
    if plot_dir is not None:
        print(f"\n(--plot {plot_dir}: no figures in this tour)")
    return 0
