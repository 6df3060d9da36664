"""The AKF's between-event solutions (eqs. 17, 20, generalised to linear R and measurement) against a numerical ODE
integration, and the exactness property that publishing does not change the filter's trajectory."""

import pytest
from scipy.integrate import solve_ivp

from akf.kernels import propagate


def _ode(L0, P0, dt, R0, R1, A0, A1):
    R = lambda t: R0 + (R1 - R0) * t / dt
    A = lambda t: A0 + (A1 - A0) * t / dt

    def rhs(t, z):
        L, P = z
        return [-(P / R(t)) * (L - A(t)), -P * P / R(t)]

    sol = solve_ivp(rhs, (0, dt), [L0, P0], method="DOP853", rtol=1e-11, atol=1e-13)
    return sol.y[0, -1], sol.y[1, -1]


@pytest.mark.parametrize(
    "L0, P0, dt, R0, R1, A0, A1",
    [
        (0.3, 0.09, 0.02, 0.01, 0.01, -0.5, -0.5),  # the paper's case: constant R and measurement
        (1.0, 0.5, 0.5, 0.05, 0.05, 0.2, 0.2),
        (0.3, 0.09, 0.03, 0.01, 0.2, -0.5, -0.5),  # R interpolated between frames (eq. 7)
        (-1.0, 0.02, 0.01, 3.0, 0.004, 0.4, 0.4),  # R falling steeply (clipped frame -> good frame)
        (0.3, 0.09, 0.01, 0.01, 0.03, -0.5, 0.1),  # measurement blended across an exposure (eq. 13)
        (0.0, 0.3, 0.004, 0.002, 0.0021, 0.0, 0.3),  # relative change of R at the series/log boundary
        (0.5, 0.3, 0.004, 0.01, 0.0103, -0.2, 0.3),  # nearly constant R: series branch
        (0.1, 1e-3, 0.2, 1e4, 2e4, 2.0, 1.0),  # saturated frame: almost no pull
    ],
)
def test_propagate_matches_numerical_ode(L0, P0, dt, R0, R1, A0, A1):
    L_num, P_num = _ode(L0, P0, dt, R0, R1, A0, A1)
    L, P = propagate(L0, P0, dt, R0, R1, A0, A1)
    assert P == pytest.approx(P_num, rel=1e-8)
    assert L == pytest.approx(L_num, rel=1e-7, abs=1e-9)


def test_constant_r_is_the_papers_closed_form():
    L0, P0, dt, R, A = 0.7, 0.09, 0.05, 0.02, 0.1
    L, P = propagate(L0, P0, dt, R, R, A, A)
    P_paper = 1 / (1 / P0 + dt / R)  # eq. 20
    assert P == pytest.approx(P_paper, rel=1e-12)
    assert L == pytest.approx((L0 - A) / P0 / (1 / P0 + dt / R) + A, rel=1e-12)  # eq. 17


def test_propagation_is_a_semigroup():
    """Stopping half way (as publishing does) and continuing gives the same state."""
    args = (0.3, 0.09, 0.03, 0.01, 0.2, -0.5, 0.4)
    L, P = propagate(*args)
    Rm, Am = (0.01 + 0.2) / 2, (-0.5 + 0.4) / 2
    L1, P1 = propagate(0.3, 0.09, 0.015, 0.01, Rm, -0.5, Am)
    L2, P2 = propagate(L1, P1, 0.015, Rm, 0.2, Am, 0.4)
    assert (L2, P2) == pytest.approx((L, P), rel=1e-12)
