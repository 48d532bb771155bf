"""A PD law written in Python drives the linear-motor feed axis under the micro-milling cut, beside
the paper's P-PI baseline built into the twin (the guide, docs/src/python.md).

    python twin/python/examples/feed_axis_pd.py [--duration 25]

The PD law with feedforward of the reference, force = m̂·r̈ + b̂·ṙ + k_p·e + k_d·ė, puts both
closed-loop poles at -ω (ω = 2π·50 Hz): k_p = m̂·ω², k_d = 2·m̂·ω - b̂, with the paper's
estimates m̂ = 11 kg and b̂ = 255 N·s/m (Rubio, Ibeas & Luo, §V).
"""

import argparse
import math

import twin

MASS, DAMPING = 11.0, 255.0  # kg, N·s/m: the paper's m̂ and b̂
OMEGA = 2 * math.pi * 50.0   # rad/s: the closed loop's double pole


class FeedAxisPD:
    """The PD law; `update` is called by the twin every control period (10 kHz)."""

    def __init__(self, signals):
        self.x, self.v, self.r, self.dr, self.ddr = (
            signals.index(name) for name in
            ["table.position", "table.velocity", "reference", "reference_rate",
             "reference_acceleration"])
        self.kp = MASS * OMEGA**2
        self.kd = 2 * MASS * OMEGA - DAMPING

    def update(self, t, m):
        error, error_rate = m[self.r] - m[self.x], m[self.dr] - m[self.v]
        force = MASS * m[self.ddr] + DAMPING * m[self.dr] + self.kp * error + self.kd * error_rate
        return [force]  # N, on the table's joint


def compare(duration):
    """Each controller's largest and σ position error (m) and largest force (N) over `duration`."""
    scenario = twin.Scenario("feed-axis-micromilling").duration(duration)
    runs = {
        "P-PI (built in)": scenario.run(),
        "PD (Python)": scenario.run(controller=FeedAxisPD(scenario.signals)),
    }
    return {
        label: (r.metrics["position_error_max"], r.metrics["position_error_sigma"],
                abs(r.efforts["table"]).max())
        for label, r in runs.items()
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=25.0, help="simulated time, s")
    args = parser.parse_args()
    print(f"feed axis, 1 µm sine at 3 rad/s under the cut, {args.duration:g} s:")
    print(f"{'controller':<18} {'max |e| µm':>11} {'σ(e) µm':>9} {'max |F| mN':>11}")
    for label, (peak, sigma, force) in compare(args.duration).items():
        print(f"{label:<18} {peak * 1e6:>11.4f} {sigma * 1e6:>9.4f} {force * 1e3:>11.3f}")


if __name__ == "__main__":
    main()
