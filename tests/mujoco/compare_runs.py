#!/usr/bin/env python3
"""Largest differences between two runs in the twin's CSV format, column by column (matched by
name): `python tests/mujoco/compare_runs.py a.csv b.csv [--until SECONDS]`. Angles of joints that
turn without limit are compared as they are (both sides unwrap them)."""

import argparse
import sys

import numpy as np


def read(path):
    with open(path, encoding="utf-8") as f:
        header = f.readline().strip().split(",")
    return header, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


def main() -> int:
    p = argparse.ArgumentParser()
    p.add_argument("a")
    p.add_argument("b")
    p.add_argument("--until", type=float, default=None)
    args = p.parse_args()
    ha, ta = read(args.a)
    hb, tb = read(args.b)
    rows = min(len(ta), len(tb))
    if args.until is not None:
        rows = min(rows, int(np.searchsorted(ta[:, 0], args.until + 1e-12)))
    if not np.allclose(ta[:rows, 0], tb[:rows, 0]):
        raise SystemExit("compare_runs: the runs' times differ")
    print(f"{'column':32} {'max |a - b|':>12} {'at t [s]':>9} {'max |a|':>12}")
    for c, name in enumerate(ha[1:], start=1):
        if name not in hb:
            continue
        d = np.abs(ta[:rows, c] - tb[:rows, hb.index(name)])
        k = int(np.argmax(d))
        print(f"{name:32} {d[k]:12.3e} {ta[k, 0]:9.3f} {np.max(np.abs(ta[:rows, c])):12.4g}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
