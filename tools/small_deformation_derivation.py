#!/usr/bin/python3
"""Derives the small-deformation theory of tools/small_deformation.py with sympy and checks
its closed forms (docs/numerics.md, "Small-deformation theory").

Usage: small_deformation_derivation.py   (exit 0 when every closed form is reproduced)

A sphere of radius 1 with outer viscosity 1 and inner viscosity lambda; membrane shear
modulus 1 and area modulus kappa. Lamb's solutions of degree 2 inside and -3 outside, for the
axisymmetric harmonic h = z^2 - (x^2 + y^2)/2 = r^2 P2, plus the straining flow grad(s h / 2)
at infinity. At r = 1 the velocity is continuous and the traction jumps by minus the
membrane's load f = div_s tau (a surface field f_r P2 n + f_t dP2/dtheta e_theta). The
surface moves with the fluid: d e_r/dt and d e_t/dt are the coefficients of P2 and dP2/dtheta
in u_r and u_theta, for the shape r = 1 + e_r P2 and the tangential displacement
e_t dP2/dtheta. That gives d(e_r, e_t)/dt = M (e_r, e_t) + s g.

It asserts that M, D12 and the inclination's lag come out as the closed forms of
small_deformation.py (relaxation_matrix, shear_deformation_slope, shear_inclination_slope),
for symbolic lambda and kappa. The lag: in the frame turning with the membrane (gamma / 2)
the strain turns at gamma, a frequency of Ca in units of G / (mu a); the l = 2 response's
phase lag is Ca [M^-2 g]_r / [-M^-1 g]_r to first order, the inclination's lag half of it.

Checks independent of those closed forms:
- the fluid algebra: a surface tension in place of the membrane gives Taylor's drop rate
  40 (lambda + 1) / ((2 lambda + 3)(19 lambda + 16)) (Taylor 1932; Rallison 1984);
- the frame argument: with the drop's single rate it gives Chaffey & Brenner's (1967) lag
  (19 lambda + 16)(2 lambda + 3) / (80 (lambda + 1)) Ca_sigma;
- the drive g: -[M^-1 g]_r / 2 is Barthes-Biesel's (1980) first-order D12 / Ca,
  5 (3 kappa + 1) / (8 kappa), for every lambda;
- the energy: the membrane's elastic energy E = x^T K x / 2 (x = (e_r, e_t), K from the
  strain energy, not from the load) is dissipated by the two fluids, R dx/dt = -K x with R
  the dissipation's quadratic form. So R = -K M^-1 must be symmetric, free of kappa (the
  fluids' only) and affine in lambda (the inside's dissipation is lambda times its flow's),
  with both parts positive definite. The drop checks leave the response to a tangential
  load unchecked; this checks it, and M's dependence on lambda with it.
"""
import sys

import sympy as sp

import small_deformation  # beside this script, on sys.path as its directory

x, y, z = sp.symbols("x y z", real=True)
lam, kappa, s, e_r, e_t, sigma = sp.symbols("lambda kappa s e_r e_t sigma", positive=True)
theta = sp.symbols("theta", real=True)
X = sp.Matrix([x, y, z])
r2 = x**2 + y**2 + z**2
h = z**2 - (x**2 + y**2) / 2
P2 = (3 * sp.cos(theta) ** 2 - 1) / 2
dP2 = sp.diff(P2, theta)


def grad(f):
    return sp.Matrix([sp.diff(f, v) for v in (x, y, z)])


def lamb(p, phi, n):
    """Lamb's general solution's terms of degree n from the harmonics p (the pressure over
    the viscosity) and phi; the toroidal part does not enter an axisymmetric poloidal field."""
    return ((n + 3) * r2 * grad(p) / (2 * (n + 1) * (2 * n + 3)) - sp.Rational(n, (n + 1) * (2 * n + 3)) * X * p
            + grad(phi))


def traction(u, p, mu):
    """(sigma n) for Lamb's fields of viscosity mu: the pressure is mu p."""
    g = sp.Matrix(3, 3, lambda i, j: sp.diff(u[i], (x, y, z)[j]))
    return mu * (-p * sp.eye(3) + g + g.T) * X / sp.sqrt(r2)


# Points of the unit sphere in the x-z plane with rational coordinates (sin, cos), so that
# r = 1 exactly and the conditions are polynomial identities.
ANGLES = ((sp.Rational(3, 5), sp.Rational(4, 5)), (sp.Rational(5, 13), sp.Rational(12, 13)),
          (sp.Rational(8, 17), sp.Rational(15, 17)))


def frame(sin, cos):
    """The point, P2 and dP2/dtheta there, and the unit vectors n and e_theta."""
    point = {x: sin, y: 0, z: cos}
    n, e_th = sp.Matrix([sin, 0, cos]), sp.Matrix([cos, 0, -sin])
    return point, (3 * cos**2 - 1) / 2, -3 * cos * sin, n, e_th


def surface_velocity(f_r, f_t):
    """(U_r, U_t): the surface's velocity u_r = U_r P2, u_theta = U_t dP2/dtheta, for the
    membrane load f_r P2 n + f_t dP2/dtheta e_theta and the strain s at infinity."""
    a_in, b_in, a_out, b_out = sp.symbols("a_in b_in a_out b_out")
    u_in, p_in = lamb(a_in * h, b_in * h, 2), a_in * h
    r5 = sp.sqrt(r2) ** 5
    u_out, p_out = s * grad(h / 2) + lamb(a_out * h / r5, b_out * h / r5, -3), a_out * h / r5
    jump = traction(u_out, p_out, 1) - traction(u_in, p_in, lam)
    equations = []
    for sin, cos in ANGLES[:2]:  # two angles fix the four constants
        point, p2, dp2, n, e_th = frame(sin, cos)
        du = (u_out - u_in).subs(point)
        dtr = jump.subs(point) + f_r * p2 * n + f_t * dp2 * e_th
        equations += [du.dot(n), du.dot(e_th), dtr.dot(n), dtr.dot(e_th)]
    solution = sp.solve(equations, [a_in, b_in, a_out, b_out], dict=True)
    assert len(solution) == 1, "the interface conditions have no unique solution"
    point, p2, dp2, n, e_th = frame(*ANGLES[2])
    u = u_out.subs(solution[0]).subs(point)
    return sp.simplify(u.dot(n) / p2), sp.simplify(u.dot(e_th) / dp2)


def membrane_load():
    """(f_r, f_t) of div_s tau for the linear tensions tau = (kappa - 1) tr(e) P + 2 e, with
    e_thth = du_th/dth + u_r and e_phph = u_th cot(th) + u_r on the unit sphere."""
    u_r, u_th = e_r * P2, e_t * dP2
    e_thth = sp.diff(u_th, theta) + u_r
    e_phph = u_th * sp.cos(theta) / sp.sin(theta) + u_r
    trace = e_thth + e_phph
    t_thth, t_phph = (kappa - 1) * trace + 2 * e_thth, (kappa - 1) * trace + 2 * e_phph
    f_n = -(t_thth + t_phph)  # the curvatures of the unit sphere
    f_th = sp.diff(t_thth, theta) + (t_thth - t_phph) * sp.cos(theta) / sp.sin(theta)
    f_r, f_t = sp.simplify(f_n / P2), sp.simplify(f_th / dP2)
    assert not (f_r.has(theta) or f_t.has(theta)), "the membrane's load is not of the l = 2 form"
    return f_r, f_t


def membrane_energy_matrix():
    """K with E = x^T K x / 2: the linear membrane's strain energy
    ((kappa - 1) tr(e)^2 + 2 e : e) / 2 integrated over the unit sphere."""
    u_r, u_th = e_r * P2, e_t * dP2
    e_thth = sp.diff(u_th, theta) + u_r
    e_phph = u_th * sp.cos(theta) / sp.sin(theta) + u_r
    density = ((kappa - 1) * (e_thth + e_phph) ** 2 + 2 * (e_thth**2 + e_phph**2)) / 2
    energy = 2 * sp.pi * sp.integrate(sp.expand(density * sp.sin(theta)), (theta, 0, sp.pi))
    return sp.Matrix(2, 2, lambda i, j: sp.diff(energy, (e_r, e_t)[i], (e_r, e_t)[j]))


def main():
    failures = []

    def check(name, got, expected):
        ok = sp.simplify(got - expected) == 0
        print(f"{'ok' if ok else 'FAILED'}: {name}: {sp.factor(got)}")
        if not ok:
            print(f"  expected {sp.factor(expected)}")
            failures.append(name)

    # The drop: a tension sigma in place of tau, div_s (sigma P) = -sigma 2H n with
    # 2H = 2 + 4 e_r P2 for l = 2 (the constant part only shifts the pressure).
    u_drop, _ = surface_velocity(-4 * sigma * e_r, 0)
    drop_rate = -sp.diff(u_drop.subs(s, 0), e_r) / sigma
    check("drop relaxation rate", drop_rate, 40 * (lam + 1) / ((2 * lam + 3) * (19 * lam + 16)))
    # One mode: the phase lag at frequency Ca is Ca / rate, the inclination's half of it.
    check("drop's lag (Chaffey & Brenner)", 1 / (2 * drop_rate), (19 * lam + 16) * (2 * lam + 3) / (80 * (lam + 1)))

    f_r, f_t = membrane_load()
    u_r, u_t = surface_velocity(f_r, f_t)
    M = sp.Matrix([[sp.diff(u, v).subs(s, 0) for v in (e_r, e_t)] for u in (u_r, u_t)])
    g = sp.Matrix([sp.diff(u_r, s), sp.diff(u_t, s)]).subs({e_r: 0, e_t: 0})
    d = (2 * lam + 3) * (19 * lam + 16)
    closed = sp.Matrix([[-4 * kappa * (lam + 4), 12 * (kappa * lam + 4 * kappa - 6 * lam - 4)],
                        [2 * kappa * (7 * lam + 8), -2 * (21 * kappa * lam + 24 * kappa + 26 * lam + 24)]]) / d
    for i in range(2):
        for j in range(2):
            check(f"M[{i}][{j}]", M[i, j], closed[i, j])
    # The energy identity (module docstring): R = -K M^-1.
    R = sp.simplify(-membrane_energy_matrix() * M.inv())
    check("R - R^T (the dissipation's form is symmetric)", sp.simplify(R[0, 1] - R[1, 0]), 0)
    check("dR/dkappa (the dissipation is the fluids')", sp.simplify(sp.diff(R, kappa)).norm(), 0)
    check("d2R/dlambda2 (affine in lambda)", sp.simplify(sp.diff(R, lam, 2)).norm(), 0)
    for name, part in (("outside", R.subs(lam, 0)), ("inside", sp.diff(R, lam))):
        if not (part[0, 0] > 0 and sp.simplify(part.det()) > 0):
            print(f"FAILED: the {name} fluid's dissipation is not positive definite: {part}")
            failures.append(f"dissipation {name}")
    steady = -M.solve(g)
    # Shear at rate gamma is the strain (gamma / 2)(x^2 - y^2) in its principal axes: the
    # harmonic's coefficient is Ca / 2 in these units, and on the equator D12 is e_r.
    check("D12 / Ca in shear", steady[0] / 2, 5 * (3 * kappa + 1) / (8 * kappa))
    lag = M.solve(M.solve(g))[0] / (2 * steady[0])
    check("inclination's lag c", lag, (69 * kappa**2 * lam + 96 * kappa**2 + 63 * kappa * lam + 72 * kappa
                                        + 26 * lam + 24) / (32 * kappa * (3 * kappa + 1)))

    # The numbers the validation script uses are these formulas.
    for value in (0.2, 1.0, 5.0):
        numeric = sp.matrix2numpy(closed.subs({lam: value, kappa: 3}), dtype=float)
        if abs(numeric - small_deformation.relaxation_matrix(value)).max() > 1e-14:
            failures.append(f"relaxation_matrix({value})")
        if abs(float(lag.subs({lam: value, kappa: 3})) - small_deformation.shear_inclination_slope(value)) > 1e-12:
            failures.append(f"shear_inclination_slope({value})")
    if abs(float((steady[0] / 2).subs(kappa, 3)) - small_deformation.shear_deformation_slope()) > 1e-12:
        failures.append("shear_deformation_slope")
    print("every closed form reproduced" if not failures else f"not reproduced: {', '.join(failures)}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
