#!/usr/bin/env python3
"""Medians and ratios of BM_Options/... from a Google Benchmark JSON file (maskadapt_bench_sim).

    maskadapt_bench_sim --benchmark_filter=BM_Options --benchmark_repetitions=5 \
        --benchmark_enable_random_interleaving=true --benchmark_format=json > options.json
    python3 benchmarks/sim/option_ratios.py options.json

Prints, per motion (stand / random), µs of wall time per env control step (median of the
repetitions) and its ratio to "old" (the settings before issue 13) measured in the same run.
"""
import json
import statistics
import sys
from collections import defaultdict

data = json.load(open(sys.argv[1]))
ctx = data.get("context", {})
print(f"# {ctx.get('date', '?')}  host {ctx.get('host_name', '?')}  cpus {ctx.get('num_cpus', '?')}"
      f"  load_avg {ctx.get('load_avg', '?')}")
times = defaultdict(list)
resets = defaultdict(float)
for b in data["benchmarks"]:
    if b.get("run_type") != "iteration" or not b["name"].startswith("BM_Options/"):
        continue
    name = "/".join(p for p in b["name"].split("/") if not p.startswith(("min_time:", "real_time", "repeats:")))
    times[name].append(b["us_per_control_step"])
    resets[name] = max(resets[name], b.get("resets", 0))
for motion in ("stand", "random"):
    base = statistics.median(times[f"BM_Options/{motion}/old"])
    print(f"\n| {motion}: option set | µs per control step (median of {len(times[f'BM_Options/{motion}/old'])}) "
          f"| ratio vs old | min–max µs | resets |")
    print("|---|---|---|---|---|")
    for name, ts in sorted(times.items(), key=lambda kv: (not kv[0].endswith("/old"), kv[0])):
        if not name.startswith(f"BM_Options/{motion}/"):
            continue
        m = statistics.median(ts)
        print(f"| {name.split('/', 2)[2]} | {m:.0f} | {m / base:.3f} | {min(ts):.0f}–{max(ts):.0f} | {resets[name]:.0f} |")
