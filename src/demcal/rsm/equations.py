"""Model equations in coded and in actual units.

The coded model y = sum b_t prod x_j^e_tj is rewritten in actual units by substituting
x_j = (X_j - c_j) / h_j (centre c_j, half-range h_j) and expanding the products, which
is how Design-Expert's "Final Equation in Terms of Actual Factors" is obtained.
"""

from __future__ import annotations

from math import comb

from demcal.rsm.terms import Term, degree, display_name, term_name


def _mul(p: dict, q: dict) -> dict:
    out: dict = {}
    for tp, cp in p.items():
        for tq, cq in q.items():
            t = tuple(a + b for a, b in zip(tp, tq))
            out[t] = out.get(t, 0.0) + cp * cq
    return out


def actual_coefficients(coefficients: dict[Term, float], factors) -> dict[Term, float]:
    """Coefficients of the same polynomial in actual factor levels.

    Parameters
    ----------
    coefficients : dict
        ``{term: coefficient}`` in coded units.
    factors : sequence of Factor
        Supplies centre and half-range of each factor.

    Returns
    -------
    dict
        ``{term: coefficient}`` in actual units; terms absent from the coded model but
        produced by the expansion (lower-order terms) are included.
    """
    k = len(factors)
    zero = tuple([0] * k)
    out: dict = {}
    for term, b in coefficients.items():
        poly = {zero: float(b)}
        for j, e in enumerate(term):
            if e == 0:
                continue
            f = factors[j]
            a, c = 1.0 / f.half_range, -f.centre / f.half_range  # x = a X + c
            # (a X + c)^e expanded by the binomial theorem
            piece = {}
            for r in range(e + 1):
                t = [0] * k
                t[j] = r
                piece[tuple(t)] = comb(e, r) * a**r * c ** (e - r)
            poly = _mul(poly, piece)
        for t, v in poly.items():
            out[t] = out.get(t, 0.0) + v
    order = sorted(out, key=lambda t: (degree(t), _sort_key(t)))
    return {t: out[t] for t in order}


def _sort_key(t: Term):
    # within a degree: products of distinct factors first, then powers (Design-Expert)
    return (max(t), [-e for e in t])


def format_equation(response: str, coefficients: dict[Term, float], names, digits: int = 4,
                    display: bool = True) -> str:
    """``response = b0 + b1*A - ...`` with ``digits`` significant digits."""
    parts = []
    for t, b in coefficients.items():
        name = display_name(t, names) if display else term_name(t, names)
        value = f"{abs(b):.{digits}g}"
        if degree(t) == 0:
            parts.append(("-" if b < 0 else "") + value)
        else:
            sep = " " if display else "*"
            parts.append(("- " if b < 0 else "+ ") + f"{value}{sep}{name}")
    if parts and parts[0].startswith("+ "):
        parts[0] = parts[0][2:]
    return f"{response} = " + " ".join(parts)
