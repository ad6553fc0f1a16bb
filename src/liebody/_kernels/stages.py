"""Stage kinds and driver status codes (plain integers, importable without numba)."""

STAGE_AXIS = 0  # exact flow of rate * m_k^2 / 2 about body axis k (params[0] = rate;
#                 params[1] = 1: the angle recurs every step, unit-correct it)
STAGE_SPHERE = 1  # exact flow of rate * |m|^2 / 2 (params[0] = rate)
STAGE_DMV = 2  # discrete Moser-Veselov / RATTLE step (params = moments)
STAGE_EXACT = 3  # exact free-body flow (params = moments)
STAGE_EULER = 4  # explicit Euler on (q, m) (params = moments)
STAGE_RK4 = 5  # classical RK4 on (q, m) (params = moments)
STAGE_LIE_EULER = 6  # Lie-Euler (params = moments)
STAGE_RKMK4 = 7  # Runge-Kutta-Munthe-Kaas 4 (params = moments)

STATUS_OK = 0
STATUS_NONFINITE = 1
STATUS_NO_CONVERGENCE = 2
STAGE_KICK = 8  # torque kick, q fixed (params = torque kind, c1, c2, c3)
STAGE_DAMP = 9  # double-bracket dissipation sub-flow (params = moments, eps)
STAGE_KICK_IMPLICIT = 10  # adjoint (implicit Euler) kick for torques that depend on L

#: width of the per-stage parameter rows
N_PARAMS = 8

TORQUE_NONE = 0
TORQUE_GRAVITY = 1
TORQUE_USER = 2
