#!/usr/bin/python3
"""Plots and tables for docs/results.md from training logs, play and eval-base outputs.

  scripts/plot_results.py curves OUT.png KEY NAME=runs/x/log.jsonl [NAME=…]   # one stat vs samples
  scripts/plot_results.py paths  OUT.png NAME=root_xy.csv [NAME=…]            # root XY trajectories
  scripts/plot_results.py hnorm-summary NAME=eval.json [NAME=…]               # Table 1 rows (markdown)
  scripts/plot_results.py strip  OUT.png rollout.json [EVERY_N_FRAMES]       # side-view stick figures
  scripts/plot_results.py feet   rollout.json [HEIGHT_M] [FROM_S]             # ankle lifts (is there a kick?)
  scripts/plot_results.py visits OUT.png NAME=eval.json [NAME=…]             # which frames of B are met
  scripts/plot_results.py windows EVERY KEY[,KEY…] NAME=log.jsonl [NAME=…]     # means over iteration windows (markdown)

The plots need Debian's python3-matplotlib; the summary needs only Python.
"""
import csv
import json
import sys


def pyplot():
    try:
        import matplotlib
    except ImportError:
        sys.exit("plot_results.py: matplotlib is missing: `scripts/setup.sh --with-plots --no-build` installs Debian's "
                 "python3-matplotlib (run this script with /usr/bin/python3 if another python3 comes first on PATH)")

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


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
    plt = pyplot()
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
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(5, 5), dpi=120)
    for name, path in runs:
        xs, ys = [], []
        with open(path) as f:
            for row in csv.DictReader(f):
                xs.append(float(row["x"]))
                ys.append(float(row["y"]))
        ax.plot(xs, ys, label=name)
        if xs:
            ax.plot(xs[0], ys[0], "ko", ms=3)  # start
            ax.plot(xs[-1], ys[-1], "kx", ms=5)  # end of the recording
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out)


def hnorm_summary(runs):
    """One markdown row per eval-base JSON: H_norm (null mask; mean over the 15 one- and two-part
    masks; both legs), fall rates and speed, from random (RSI) and shared initial states."""
    print("| base | H_norm null (RSI / shared) | H_norm mean of 15 masks (RSI / shared) | H_norm both legs (RSI / shared)"
          " | falls null | falls mean of 15 masks (RSI / shared) | falls both legs (RSI / shared) | speed null (m/s) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for name, path in runs:
        with open(path) as f:
            ev = json.load(f)
        rows = {m["mask"]: m for m in ev["masks"]}
        masked = [m for k, m in rows.items() if k != "none"]

        def mean(key, start):
            return sum(m[start][key] for m in masked) / len(masked)

        null, legs = rows["none"], rows["left_leg,right_leg"]
        print(f"| {name} | {null['rsi']['h_norm']:.3f} / {null['shared']['h_norm']:.3f}"
              f" | {mean('h_norm', 'rsi'):.3f} / {mean('h_norm', 'shared'):.3f}"
              f" | {legs['rsi']['h_norm']:.3f} / {legs['shared']['h_norm']:.3f}"
              f" | {null['rsi']['fall_rate']:.2f}"
              f" | {mean('fall_rate', 'rsi'):.2f} / {mean('fall_rate', 'shared'):.2f}"
              f" | {legs['rsi']['fall_rate']:.2f} / {legs['shared']['fall_rate']:.2f}"
              f" | {null['rsi']['mean_speed']:.2f} |")


def strip(out, rollout_path, every=6):
    """Chronophotograph of a play --rollout file: the skeleton every `every` frames, seen from the
    side of its overall direction of travel (horizontal axis: distance along it, m; vertical:
    height, m). Bodies of masked parts are drawn in colour, the rest in grey."""
    plt = pyplot()
    with open(rollout_path) as f:
        ro = json.load(f)
    bodies = ro["skeleton"]["bodies"]
    frames = ro["frames"]["positions"]  # per frame: 3 × bodies, world metres
    masks = ro["frames"]["masks"]
    parts = ro["part_names"]
    nb = len(bodies)

    def pos(fr, b):
        return frames[fr][3 * b: 3 * b + 3]

    x0, y0, _ = pos(0, 0)
    x1, y1, _ = pos(len(frames) - 1, 0)
    dx, dy = x1 - x0, y1 - y0
    norm = (dx * dx + dy * dy) ** 0.5 or 1.0
    dx, dy = dx / norm, dy / norm
    colours = {"trunk": "#d4a017", "left_arm": "#e06666", "right_arm": "#e69138", "left_leg": "#1f6fd1", "right_leg": "#0f9ba8"}
    fig, ax = plt.subplots(figsize=(8, 2.4), dpi=120)
    lo, hi = 0.0, 0.0
    for fr in range(0, len(frames), every):
        mask = masks[fr] if isinstance(masks[fr], int) else 0
        for b in range(1, nb):
            parent = bodies[b]["parent"]
            p, q = pos(fr, parent), pos(fr, b)
            part = bodies[b]["part"]
            masked = bool(mask & (1 << parts.index(part))) if part in parts else False
            u = [(p[0] - x0) * dx + (p[1] - y0) * dy, (q[0] - x0) * dx + (q[1] - y0) * dy]
            ax.plot(u, [p[2], q[2]], color=colours.get(part, "k") if masked else "0.45", lw=1.4)
            lo, hi = min(lo, *u), max(hi, *u)
    ax.set_xlim(lo - 0.2, hi + 0.2)
    ax.set_ylim(-0.05, 1.9)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel(f"distance along the direction of travel (m); every {every} frames = {every / ro['fps']:.2f} s")
    ax.set_ylabel("height (m)")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out)


def feet(rollout_path, height=0.30, from_s=0.0):
    """How high the ankles go in a play --rollout file, from FROM_S seconds on: the highest ankle
    (world height of the L_Ankle / R_Ankle body origins, metres), when, and the number of frames in which
    either ankle is above HEIGHT metres. A walking step lifts the ankle to about 0.2-0.3 m; a kick
    lifts it higher (docs/results.md, case (a))."""
    with open(rollout_path) as f:
        ro = json.load(f)
    names = [b["name"] for b in ro["skeleton"]["bodies"]]
    missing = [n for n in ("L_Ankle", "R_Ankle") if n not in names]
    if missing:
        sys.exit(f"plot_results.py feet: {rollout_path} has no body named {', '.join(missing)} "
                 f"(skeleton bodies: {', '.join(names)})")
    ankles = [names.index("L_Ankle"), names.index("R_Ankle")]
    first = int(round(from_s * ro["fps"]))
    frames = ro["frames"]["positions"][first:]  # per frame: 3 × bodies, world metres
    if not frames:
        sys.exit(f"plot_results.py feet: {rollout_path} has no frame after {from_s} s")
    heights = [max(fr[3 * b + 2] for b in ankles) for fr in frames]
    above = sum(1 for h in heights if h > height)
    top = max(range(len(heights)), key=heights.__getitem__)
    print(f"{rollout_path}: {len(frames)} frames from {from_s:g} s; highest ankle {heights[top]:.3f} m "
          f"at {(first + top) / ro['fps']:.2f} s; frames with an ankle above {height:.2f} m: {above}")


def visits(out, runs):
    """Share of the visits per frame of the new motion B, from `eval-residual --out eval.json`
    (composition; first row of each file): the counts behind H_norm(adapted | B), clip after clip.
    Prints each run's share per clip and draws one line per run."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 3.2), dpi=120)
    clips = None
    for name, path in runs:
        try:
            with open(path) as f:
                ev = json.load(f)
        except (OSError, ValueError) as e:
            sys.exit(f"plot_results.py visits: cannot read {path}: {e}")
        if not isinstance(ev, dict) or ev.get("task") != "composition" or not ev.get("rows") or "visits_adapted_vs_new" not in ev["rows"][0]:
            sys.exit(f"plot_results.py visits: {path} is not a composition eval-residual --out file with per-frame "
                     f"visits (rows[0].visits_adapted_vs_new: rerun eval-residual --out with a current build)")
        counts = ev["rows"][0]["visits_adapted_vs_new"]
        these = [(c["name"], c["frames"]) for c in ev["new_motion_clips"]]
        if sum(n for _, n in these) != len(counts):
            sys.exit(f"plot_results.py visits: {path}: {len(counts)} counts for {sum(n for _, n in these)} frames of B")
        if clips is not None and these != clips:
            sys.exit(f"plot_results.py visits: {path} was evaluated against another B than {runs[0][1]}")
        clips = these
        total = sum(counts) or 1
        ax.plot(range(len(counts)), [c / total for c in counts], label=name)
        print(f"{name}: {sum(counts)} visits, threshold {ev['threshold_per_body_m']} m per body, "
              f"{sum(1 for c in counts if c)} of {len(counts)} frames of B visited")
    start = 0
    for clip, n in clips:
        if start:
            ax.axvline(start - 0.5, color="0.6", lw=0.8)
        ax.text(start, ax.get_ylim()[1], " " + clip, va="top", fontsize=7)
        start += n
    ax.set_xlabel("frame of B (clip after clip)")
    ax.set_ylabel("share of the visits")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out)


def windows(every, keys, runs):
    """One markdown table per run: the mean of each key over consecutive windows of EVERY
    iterations (null values, e.g. fall_rate in an iteration where no episode ended, are skipped)."""
    for name, path in runs:
        rows = read_log(path)
        print(f"\n{name} ({path}), means over {every}-iteration windows\n")
        print("| iterations | samples (M) | " + " | ".join(keys) + " |")
        print("| --- | --- | " + " | ".join("---" for _ in keys) + " |")
        for start in range(0, len(rows), every):
            chunk = rows[start:start + every]
            cells = []
            for key in keys:
                values = [r.get(key) for r in chunk if r.get(key) is not None]
                cells.append(f"{sum(values) / len(values):.4g}" if values else "–")
            print(f"| {chunk[0]['iteration']}–{chunk[-1]['iteration']} | {chunk[-1]['samples'] / 1e6:.2f} | "
                  + " | ".join(cells) + " |")


def number(text, what):
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not value >= 0.0 or value == float("inf"):
        sys.exit(f"plot_results.py: {what} must be a finite number >= 0, got '{text}'")
    return value


def named(args):
    bad = [a for a in args if "=" not in a]
    if bad:
        sys.exit(f"plot_results.py: expected NAME=FILE, got '{bad[0]}'")
    return [tuple(a.split("=", 1)) for a in args]


if __name__ == "__main__":
    if len(sys.argv) >= 5 and sys.argv[1] == "curves":
        curves(sys.argv[2], sys.argv[3], named(sys.argv[4:]))
    elif len(sys.argv) >= 4 and sys.argv[1] == "paths":
        paths(sys.argv[2], named(sys.argv[3:]))
    elif len(sys.argv) in (4, 5) and sys.argv[1] == "strip":
        strip(sys.argv[2], sys.argv[3], int(sys.argv[4]) if len(sys.argv) == 5 else 6)
    elif 3 <= len(sys.argv) <= 5 and sys.argv[1] == "feet":
        feet(sys.argv[2], *(number(a, what) for a, what in zip(sys.argv[3:], ("HEIGHT_M", "FROM_S"))))
    elif len(sys.argv) >= 4 and sys.argv[1] == "visits":
        visits(sys.argv[2], named(sys.argv[3:]))
    elif len(sys.argv) >= 5 and sys.argv[1] == "windows":
        every = number(sys.argv[2], "EVERY")
        if every < 1 or every != int(every):
            sys.exit(f"plot_results.py: EVERY must be a whole number >= 1, got '{sys.argv[2]}'")
        windows(int(every), sys.argv[3].split(","), named(sys.argv[4:]))
    elif len(sys.argv) >= 3 and sys.argv[1] == "hnorm-summary":
        hnorm_summary(named(sys.argv[2:]))
    else:
        sys.exit(__doc__)
