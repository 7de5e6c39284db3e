"""The one definition of linear elasticity used by every model (docs/design.md section 5).

Units: ``mu = rho = 1``, so ``lmbda = 1/beta**2 - 2`` (``Params.lame_lambda``).

The constitutive helpers take a displacement *gradient* ``G`` (``G[i, j] = d u_i / d x_j``) so
that the same code serves the 2D strip (``G = ufl.grad(u)``) and the cross-section model, where
fields go as ``u_hat(y) exp(-i k x)`` and ``d/dx -> -i k``: on an interval mesh whose coordinate
is ``y``, ``G = G0 + k G1`` with :func:`cross_section_gradients`.
"""

from __future__ import annotations

import ufl


def strain(grad_u: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """Small-strain tensor ``sym(G)`` of a displacement gradient ``G``."""
    return ufl.sym(grad_u)


def stress(grad_u: ufl.core.expr.Expr, lmbda: float, mu: float) -> ufl.core.expr.Expr:
    """Isotropic Hooke's law ``2 mu eps + lmbda tr(eps) I`` (plane strain, 2x2)."""
    eps = strain(grad_u)
    return 2.0 * mu * eps + lmbda * ufl.tr(eps) * ufl.Identity(2)


def sigma(u: ufl.core.expr.Expr, lmbda: float, mu: float) -> ufl.core.expr.Expr:
    """Stress of a 2D displacement field: ``stress(grad(u), lmbda, mu)``."""
    return stress(ufl.grad(u), lmbda, mu)


def cross_section_gradients(
    u: ufl.core.expr.Expr,
) -> tuple[ufl.core.expr.Expr, ufl.core.expr.Expr]:
    """Split the gradient of ``u_hat(y) exp(-i k x)`` as ``G0 + k G1``.

    Args:
        u: A 2-component field on an interval mesh whose single coordinate is ``y``.

    Returns:
        ``(G0, G1)`` with ``G0 = [[0, u_x'], [0, u_y']]`` and ``G1 = [[-i u_x, 0], [-i u_y, 0]]``
        (rows: components, columns: ``d/dx``, ``d/dy``).
    """
    g0 = ufl.as_matrix([[0, u[0].dx(0)], [0, u[1].dx(0)]])
    g1 = ufl.as_matrix([[-1j * u[0], 0], [-1j * u[1], 0]])
    return g0, g1


def stiffness_density(
    grad_u: ufl.core.expr.Expr, grad_w: ufl.core.expr.Expr, lmbda: float, mu: float
) -> ufl.core.expr.Expr:
    """Integrand ``inner(sigma(u), eps(w))`` (``ufl.inner`` conjugates the test side ``w``)."""
    return ufl.inner(stress(grad_u, lmbda, mu), strain(grad_w))


def mass_density(u: ufl.core.expr.Expr, w: ufl.core.expr.Expr, rho: float = 1.0):
    """Integrand ``rho inner(u, w)`` of the mass form (test function second)."""
    return rho * ufl.inner(u, w)
