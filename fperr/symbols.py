"""The two symbols every bound is written in: the unit roundoff ``eps`` and the scale ``L``.

Section 2 of the paper writes every magnitude as c·L^p and every relative error as
1 + a·ε + b·ε²; both symbols are positive reals.
"""
import sympy

eps = sympy.Symbol("eps", positive=True)
L = sympy.Symbol("L", positive=True)

#: The paper's standing assumption (section 2): ε < 1e-5.
EPS_MAX = sympy.Rational(1, 100000)
