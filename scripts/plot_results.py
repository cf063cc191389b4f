#!/usr/bin/python3
"""Plots for docs/results.md from training logs and play outputs (needs Debian's python3-matplotlib).

  scripts/plot_results.py curves OUT.png KEY NAME=runs/x/log.jsonl [NAME=…]   # one stat vs samples
  scripts/plot_results.py paths  OUT.png NAME=root_xy.csv [NAME=…]            # root XY trajectories
"""
import csv
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read_log(path):
    rows = []
    with open(path) as f:
        for line in f:
            line = line.strip()
            if line:
                rows.append(json.loads(line))
    return rows


def smooth(values, k=9):
    out = []
    for i in range(len(values)):
        window = [v for v in values[max(0, i - k + 1): i + 1] if v is not None]
        out.append(sum(window) / len(window) if window else None)
    return out


def curves(out, key, runs):
    fig, ax = plt.subplots(figsize=(6.4, 3.6), dpi=120)
    for name, path in runs:
        rows = read_log(path)
        samples = [r["samples"] / 1e6 for r in rows]  # cumulative env samples
        values = [r.get(key) for r in rows]
        ax.plot(samples, smooth(values), label=name)
    ax.set_xlabel("environment samples (millions)")
    ax.set_ylabel(key + "\n(moving mean of 9 iterations)", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(out)


def paths(out, runs):
    fig, ax = plt.subplots(figsize=(5, 5), dpi=120)
    for name, path in runs:
        xs, ys = [], []
        with open(path) as f:
            for row in csv.DictReader(f):
                xs.append(float(row["x"]))
                ys.append(float(row["y"]))
        ax.plot(xs, ys, label=name)
        if xs:
            ax.plot(xs[0], ys[0], "ko", ms=3)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out)


def named(args):
    return [tuple(a.split("=", 1)) for a in args]


if __name__ == "__main__":
    if len(sys.argv) >= 5 and sys.argv[1] == "curves":
        curves(sys.argv[2], sys.argv[3], named(sys.argv[4:]))
    elif len(sys.argv) >= 4 and sys.argv[1] == "paths":
        paths(sys.argv[2], named(sys.argv[3:]))
    else:
        sys.exit(__doc__)
