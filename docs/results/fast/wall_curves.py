#!/usr/bin/env python3
"""Learning curves against wall time: final distance of each evaluation vs the run's wall seconds.

One SVG per env (curves_wall_<env>.svg), one line per run given as LABEL=RUN_DIR (a run directory
holding progress.csv); the env's quality target as a dashed line; log-scaled time axis. Standard
library only.

usage: wall_curves.py OUT_DIR ENV LABEL=RUN_DIR [LABEL=RUN_DIR ...]
"""
import csv
import math
import os
import sys

COLOURS = ["#0072b2", "#d55e00", "#009e73", "#cc79a7", "#e69f00", "#56b4e9"]  # Okabe-Ito, colour-blind safe
TARGETS = {"table": 0.05, "shelf": 0.05, "nav": 0.5, "hri": 0.15}


def read_curve(run_dir):
    pts = []
    with open(os.path.join(run_dir, "progress.csv")) as f:
        for row in csv.DictReader(f):
            try:
                t, d = float(row["wall_s"]), float(row["final_distance"])
            except (KeyError, ValueError):
                continue
            if t > 0 and math.isfinite(d):
                pts.append((t, d))
    return pts


def main():
    out_dir, env, runs = sys.argv[1], sys.argv[2], [a.split("=", 1) for a in sys.argv[3:]]
    curves = [(label, read_curve(d)) for label, d in runs]
    ts = [t for _, c in curves for t, _ in c]
    ds = [d for _, c in curves for _, d in c]
    t_lo, t_hi = 10 ** math.floor(math.log10(min(ts))), 10 ** math.ceil(math.log10(max(ts)))
    d_hi = max(ds + [TARGETS.get(env, 0)]) * 1.05
    W, H, L, R, T, B = 640, 400, 60, 170, 30, 45
    x = lambda t: L + (math.log10(t) - math.log10(t_lo)) / (math.log10(t_hi) - math.log10(t_lo)) * (W - L - R)
    y = lambda d: T + (1 - d / d_hi) * (H - T - B)
    svg = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" font-family="sans-serif" font-size="12">',
           f'<rect width="{W}" height="{H}" fill="white"/>',
           f'<text x="{L}" y="18" font-size="14">{env}: final distance of each evaluation against wall time</text>',
           f'<line x1="{L}" y1="{H - B}" x2="{W - R}" y2="{H - B}" stroke="black"/>',
           f'<line x1="{L}" y1="{T}" x2="{L}" y2="{H - B}" stroke="black"/>']
    e = math.log10(t_lo)
    while 10 ** e <= t_hi * 1.0001:
        px = x(10 ** e)
        svg.append(f'<line x1="{px:.1f}" y1="{H - B}" x2="{px:.1f}" y2="{H - B + 5}" stroke="black"/>')
        svg.append(f'<text x="{px:.1f}" y="{H - B + 18}" text-anchor="middle">{10 ** e:g}</text>')
        e += 1
    svg.append(f'<text x="{(L + W - R) / 2}" y="{H - 8}" text-anchor="middle">wall seconds (log)</text>')
    for i in range(6):
        d = d_hi * i / 5
        svg.append(f'<text x="{L - 6}" y="{y(d) + 4:.1f}" text-anchor="end">{d:.2f}</text>')
    svg.append(f'<text x="14" y="{(T + H - B) / 2}" transform="rotate(-90 14 {(T + H - B) / 2})" '
               f'text-anchor="middle">final distance (m)</text>')
    if env in TARGETS:
        ty = y(TARGETS[env])
        svg.append(f'<line x1="{L}" y1="{ty:.1f}" x2="{W - R}" y2="{ty:.1f}" stroke="grey" stroke-dasharray="5,4"/>')
        svg.append(f'<text x="{W - R + 4}" y="{ty + 4:.1f}" fill="grey">target {TARGETS[env]} m</text>')
    for i, (label, c) in enumerate(curves):
        col = COLOURS[i % len(COLOURS)]
        path = " ".join(f"{x(t):.1f},{y(d):.1f}" for t, d in c)
        svg.append(f'<polyline points="{path}" fill="none" stroke="{col}" stroke-width="2"/>')
        svg.append(f'<text x="{W - R + 4}" y="{T + 16 * i + 12}" fill="{col}">{label}</text>')
    svg.append("</svg>")
    with open(os.path.join(out_dir, f"curves_wall_{env}.svg"), "w") as f:
        f.write("\n".join(svg) + "\n")


if __name__ == "__main__":
    main()
