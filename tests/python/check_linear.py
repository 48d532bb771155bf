"""Checks a `twin linearize` linear.json with python-control (0.10), independently of the twin:

- the frequency response control.frequency_response gives for ss(A, B, C, D) equals the one the
  twin wrote (`frequency_response`, computed in Rust from the same matrices);
- control.c2d(ss(A, B, C, D), control_period, 'zoh') equals the twin's Ad, Bd.

Usage: python check_linear.py linear.json [...]; prints one line per file, exits 1 on a mismatch.
"""

import json
import sys

import control
import numpy as np

RESPONSE_TOLERANCE = 1e-9  # relative to the largest |G| at that frequency
HOLD_TOLERANCE = 1e-12  # relative to the largest entry of Ad or Bd


def check(path):
    with open(path, encoding="utf-8") as f:
        model = json.load(f)
    a, b, c, d = (np.array(model[k], dtype=float) for k in ("A", "B", "C", "D"))
    sys_c = control.ss(a, b, c, d)
    worst_response = 0.0
    for point in model["frequency_response"]:
        omega = point["omega"]
        twin = np.array(point["real"]) + 1j * np.array(point["imag"])
        response = control.frequency_response(sys_c, [omega], squeeze=False)
        theirs = np.asarray(response.complex)[:, :, 0]
        scale = max(np.abs(theirs).max(), np.finfo(float).tiny)
        worst_response = max(worst_response, np.abs(theirs - twin).max() / scale)
    sys_d = control.c2d(sys_c, model["control_period"], "zoh")
    ad, bd = np.array(model["Ad"]), np.array(model["Bd"])
    hold_a = np.abs(sys_d.A - ad).max() / max(np.abs(sys_d.A).max(), 1e-300)
    hold_b = np.abs(sys_d.B - bd).max() / max(np.abs(sys_d.B).max(), 1e-300)
    ok = worst_response <= RESPONSE_TOLERANCE and max(hold_a, hold_b) <= HOLD_TOLERANCE
    print(
        f"{path}: frequency response {worst_response:.2e} (of |G|), "
        f"Ad {hold_a:.2e}, Bd {hold_b:.2e} (of their largest entry): {'ok' if ok else 'MISMATCH'}"
    )
    return ok


if __name__ == "__main__":
    results = [check(p) for p in sys.argv[1:]]
    sys.exit(0 if results and all(results) else 1)
