"""The AKF's between-event solutions (eqs. 17, 20, generalised to linear R and measurement) against a numerical ODE
integration, and the exactness property that publishing does not change the filter's trajectory."""

import math

import pytest
from scipy.integrate import solve_ivp

from akf.kernels import propagate, propagate_one_sided


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


def _ode_one_sided(L0, P0, dt, R0, R1, A0, A1, side, strong):
    """The censored-measurement ODE integrated numerically: R * strong while side * (L - A) < 0, no pull at all
    (R infinite: the state and P stay) on the possible side, the switch located by the integrator's event
    detection. Returns (L, P, crossing time or None)."""
    R = lambda t: R0 + (R1 - R0) * t / dt
    A = lambda t: A0 + (A1 - A0) * t / dt

    def rhs(f):
        return lambda t, z: [-(z[1] / (f * R(t))) * (z[0] - A(t)), -z[1] ** 2 / (f * R(t))]

    def cross(t, z):
        return z[0] - A(t)

    cross.terminal = True
    f = strong if side * (L0 - A0) < 0 else math.inf
    opts = {"method": "DOP853", "rtol": 1e-12, "atol": 1e-14}
    sol = solve_ivp(rhs(f), (0, dt), [L0, P0], events=cross, **opts)
    if sol.status != 1:
        return sol.y[0, -1], sol.y[1, -1], None
    tc, z = sol.t_events[0][0], sol.y_events[0][0]
    sol = solve_ivp(rhs(strong if f == math.inf else math.inf), (tc, dt), z, **opts)
    return sol.y[0, -1], sol.y[1, -1], tc


ONE_SIDED = [
    (0.5, 0.01, 0.02, 0.05, 0.05, 0.0, 1.0, 1, 0.01),  # clipped high, state above; the level overtakes it
    (0.3, 0.05, 0.01, 0.02, 0.05, -0.2, 0.6, -1, 0.05),  # clipped low, state impossibly above; level catches up
    (-0.1, 0.2, 0.05, 0.01, 0.3, 0.4, -0.6, 1, 0.02),  # impossible below a falling level, R rising steeply
]


@pytest.mark.parametrize("L0, P0, dt, R0, R1, A0, A1, side, strong", ONE_SIDED)
def test_one_sided_propagation_switches_side_at_the_crossing(L0, P0, dt, R0, R1, A0, A1, side, strong):
    """Against the numerical ODE with the switch at the time the estimate crosses the clip level (each case
    crosses inside the segment); and split anywhere (before or after the crossing, as an event or a frame window
    would), continuing gives the same state: the solution does not depend on the discretisation."""
    L_num, P_num, tc = _ode_one_sided(L0, P0, dt, R0, R1, A0, A1, side, strong)
    assert tc is not None and 0.05 * dt < tc < 0.95 * dt
    L, P = propagate_one_sided(L0, P0, dt, R0, R1, A0, A1, side, strong)
    assert P == pytest.approx(P_num, rel=1e-8)
    assert L == pytest.approx(L_num, rel=1e-7, abs=1e-9)
    # the rule decided once at the segment start misses the switch by far more
    once = (propagate(L0, P0, dt, R0 * strong, R1 * strong, A0, A1) if side * (L0 - A0) < 0 else (L0, P0))
    assert abs(once[1] - P_num) > 1e-3 * P_num or abs(once[0] - L_num) > 1e-3
    for v in (0.2, 0.5, 0.8):
        Rm, Am = R0 + v * (R1 - R0), A0 + v * (A1 - A0)
        L1, P1 = propagate_one_sided(L0, P0, v * dt, R0, Rm, A0, Am, side, strong)
        L2, P2 = propagate_one_sided(L1, P1, (1 - v) * dt, Rm, R1, Am, A1, side, strong)
        assert (L2, P2) == pytest.approx((L, P), rel=1e-10, abs=1e-12)


def test_one_sided_propagation_without_crossing():
    """A state on the impossible side of a fixed clip level never reaches it: the strong pull throughout; on the
    possible side the state and its variance stay (a clipped response says only that the truth is beyond the clip
    level), also when the level moves away; an unclipped measurement (side 0) is the plain solution."""
    args = (0.1, 0.05, 0.02, 0.01, 0.03, 0.4, 0.4)
    for side, L0, f in ((1, 0.1, 0.02), (-1, 0.7, 0.02), (0, 0.1, 1.0)):
        L, P = propagate_one_sided(L0, *args[1:], side, 0.02)
        assert (L, P) == propagate(L0, *args[1:3], args[3] * f, args[4] * f, *args[5:])
    assert propagate_one_sided(0.7, *args[1:], 1, 0.02) == (0.7, 0.05)
    assert propagate_one_sided(0.7, 0.05, 0.02, 0.01, 0.03, 0.4, 0.1, 1, 0.02) == (0.7, 0.05)  # level falls away
