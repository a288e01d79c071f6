"""Three one-parameter laws for the paper's EDEM sliding angles (Table 8), fitted by least
squares: atan(mu') + a constant angle, atan(k mu'), and the paper's Eq. 5 read with a
level height H0, arcsin(sin(atan mu') + H0 / L). Prints each fit, its RMS over the 17
runs, the residuals of the three mu' level means, and the law's value at Table 10's two
verified mu' (EDEM: 25.64 and 30.69 deg). docs/validation-incline.md, "The reading: late
onsets and the height in Eq. 5".

    python benchmarks/studies/incline-reading-2026-11-28/table8_laws.py
"""

from importlib.resources import files

import numpy as np
import pandas as pd
from scipy.optimize import minimize_scalar

LAWS = {
    "atan mu' + a constant angle [deg]": (lambda p, m: np.degrees(np.arctan(m)) + p, (-10.0, 20.0)),
    "atan(k mu'), k": (lambda p, m: np.degrees(np.arctan(p * m)), (0.5, 3.0)),
    "arcsin(sin atan mu' + H0/L), H0/L": (lambda p, m: np.degrees(np.arcsin(np.sin(np.arctan(m)) + p)), (-0.5, 0.5)),
}


def main() -> None:
    table = pd.read_csv(files("demcal.data") / "paper_table8_sliding_bbd.csv")
    mu = 0.5 + 0.1 * table["F"].to_numpy()  # Table 7: mu' 0.4 / 0.5 / 0.6 at F = -1 / 0 / 1
    y = table["sliding_angle_deg"].to_numpy()
    for name, (law, bounds) in LAWS.items():
        fit = minimize_scalar(lambda p: float(((law(p, mu) - y) ** 2).sum()), bounds=bounds, method="bounded")
        res = law(fit.x, mu) - y
        levels = pd.Series(res).groupby(table["F"]).mean().round(2).tolist()
        at10 = np.round(law(fit.x, np.array([0.40, 0.48])), 2).tolist()
        print(f"{name} = {fit.x:.4f}: RMS {np.sqrt((res ** 2).mean()):.2f} deg over {len(y)} runs, "
              f"level-mean residuals {levels}, Table 10's mu' 0.40 / 0.48 -> {at10}")


if __name__ == "__main__":
    main()
