"""Polynomial model terms in coded factors.

A term is a tuple of exponents, one per factor: ``(1, 1, 0)`` is A*B, ``(2, 0, 0)`` is
A^2, ``(0, 0, 0)`` the intercept. Term order follows Design-Expert: intercept, main
effects, two-factor interactions, squares, then cubic terms.
"""

from __future__ import annotations

import itertools

import numpy as np

from demcal.errors import ConfigError

Term = tuple[int, ...]

#: Model orders understood by :func:`model_terms`, lowest first.
ORDERS = ("mean", "linear", "2fi", "quadratic", "cubic")

_ALIASES = {"main": "linear", "first": "linear", "interaction": "2fi", "twofi": "2fi",
            "2-fi": "2fi", "second": "quadratic", "quad": "quadratic", "third": "cubic"}


def normalise_order(order: str) -> str:
    o = str(order).strip().lower()
    o = _ALIASES.get(o, o)
    if o not in ORDERS:
        raise ConfigError(f"unknown model {order!r}; use linear, 2fi, quadratic or cubic.")
    return o


def degree(term: Term) -> int:
    return int(sum(term))


def _unit(k, *idx) -> Term:
    t = [0] * k
    for i in idx:
        t[i] += 1
    return tuple(t)


def order_terms(k: int, order: str) -> list[Term]:
    """Terms added by model ``order`` on top of the previous order (intercept for 'mean')."""
    order = normalise_order(order)
    if order == "mean":
        return [tuple([0] * k)]
    if order == "linear":
        return [_unit(k, i) for i in range(k)]
    if order == "2fi":
        return [_unit(k, i, j) for i, j in itertools.combinations(range(k), 2)]
    if order == "quadratic":
        return [_unit(k, i, i) for i in range(k)]
    # cubic: three-factor products, A^2*B type, then pure cubes
    terms = [_unit(k, i, j, m) for i, j, m in itertools.combinations(range(k), 3)]
    for i in range(k):
        for j in range(k):
            if i != j:
                terms.append(_unit(k, i, i, j))
    terms += [_unit(k, i, i, i) for i in range(k)]
    return terms


def model_terms(k: int, order: str = "quadratic") -> list[Term]:
    """All terms of the full model of ``order`` in ``k`` factors, intercept first."""
    order = normalise_order(order)
    terms = []
    for o in ORDERS[: ORDERS.index(order) + 1]:
        terms += order_terms(k, o)
    return terms


def term_name(term: Term, names) -> str:
    """Machine name: factor names joined by ``*``, powers as ``^2``; ``Intercept``."""
    if degree(term) == 0:
        return "Intercept"
    parts = []
    for n, e in zip(names, term):
        if e == 1:
            parts.append(str(n))
        elif e > 1:
            parts.append(f"{n}^{e}")
    return "*".join(parts)


_SUPERSCRIPT = {2: "\u00b2", 3: "\u00b3"}


def display_name(term: Term, names) -> str:
    """Design-Expert style: ``AB``, ``A²``, ``A²B`` for one-letter names, else ``e·mu``."""
    if degree(term) == 0:
        return "Intercept"
    single = all(len(str(n)) == 1 for n in names)
    parts = []
    for n, e in zip(names, term):
        if e >= 1:
            parts.append(f"{n}{_SUPERSCRIPT.get(e, '^' + str(e)) if e > 1 else ''}")
    return ("" if single else "\u00b7").join(parts)


def parse_term(name: str, names) -> Term:
    """Inverse of :func:`term_name`."""
    names = list(names)
    if name == "Intercept":
        return tuple([0] * len(names))
    t = [0] * len(names)
    for part in name.split("*"):
        base, _, power = part.partition("^")
        if base not in names:
            raise ConfigError(f"term {name!r} names an unknown factor {base!r}.")
        t[names.index(base)] += int(power or 1)
    return tuple(t)


def model_matrix(x: np.ndarray, terms) -> np.ndarray:
    """Columns of the model matrix for coded points ``x`` of shape ``(n, k)``."""
    x = np.atleast_2d(np.asarray(x, dtype=float))
    cols = []
    for t in terms:
        col = np.ones(x.shape[0])
        for j, e in enumerate(t):
            if e:
                col = col * x[:, j] ** e
        cols.append(col)
    return np.column_stack(cols) if cols else np.empty((x.shape[0], 0))


def contains(parent: Term, child: Term) -> bool:
    """True when ``child`` divides ``parent`` (A divides A*B and A^2): hierarchy."""
    return parent != child and all(c <= p for c, p in zip(child, parent))


class Polynomial:
    """Fast evaluation of sum_t c_t prod_j x_j^e_tj and its gradient at many points.

    Parameters
    ----------
    terms : sequence of Term
    coefficients : sequence of float
    """

    def __init__(self, terms, coefficients):
        self.E = np.asarray(terms, dtype=float).reshape(len(terms), -1)
        self.c = np.asarray(coefficients, dtype=float)
        k = self.E.shape[1]
        # derivative d/dx_j: coefficient c_t e_tj, exponents E_t - unit_j; all j stacked
        blocks, cols = [], []
        for j in range(k):
            e = self.E[:, j]
            keep = e > 0
            dE = self.E[keep].copy()
            dE[:, j] -= 1
            blocks.append(dE)
            col = np.zeros((int(keep.sum()), k))
            col[:, j] = self.c[keep] * e[keep]
            cols.append(col)
        self._dE = np.vstack(blocks) if blocks else np.zeros((0, k))
        self._dC = np.vstack(cols) if cols else np.zeros((0, k))

    @staticmethod
    def _monomials(X, E):
        if E.shape[0] == 0:
            return np.zeros((X.shape[0], 0))
        return np.prod(X[:, None, :] ** E[None, :, :], axis=2)

    def __call__(self, X) -> np.ndarray:
        X = np.atleast_2d(np.asarray(X, dtype=float))
        return self._monomials(X, self.E) @ self.c

    def gradient(self, X) -> np.ndarray:
        """``(n, k)`` gradient at the points ``X``."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        return self._monomials(X, self._dE) @ self._dC
