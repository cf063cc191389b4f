#!/usr/bin/env bash
# Checks scripts/reproduce_results.sh without running anything: DRY_RUN=1 for every subcommand, then
# every printed command must parse. For each distinct `maskadapt` invocation:
#   1. every --flag appears in `maskadapt <subcommand> --help`;
#   2. the invocation itself runs with its input files (positional checkpoint or clip, --resume,
#      --base, --generator, --checkpoint) swapped for empty files, its outputs sent to a scratch
#      folder and MASKADAPT_DATA_DIR pointing at an empty folder: it must get past CLI11's parsing and
#      the config checks and stop with `maskadapt: error:` on the swapped input or the missing data
#      (exit 1), not with a parse error (exit 100–127) and not by starting work (10 s timeout);
#   3. every models/ and configs/ path it names exists, and every data path when the data are here.
# plot_results.py lines are checked against its dispatch (mode, arity, NAME=FILE); scripts/*.sh lines
# must exist and pass `bash -n`. Nothing is written outside a temporary folder.
#
#   tests/scripts/reproduce_dry_run.sh [CLI]        # default: build/bin/maskadapt
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
cli=${1:-${CLI:-$repo/build/bin/maskadapt}}
[[ -x "$cli" ]] || { echo "reproduce_dry_run: $cli is not built" >&2; exit 1; }
cli=$(cd "$(dirname "$cli")" && pwd)/$(basename "$cli")
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
subcommands="table1 g1 table2 table2-side table3 table4 recipe shipped figures stage1 stage2"
status=0
for sub in $subcommands all; do
  if ! (cd "$repo" && DRY_RUN=1 RUNS="$tmp/runs" CLI="$cli" scripts/reproduce_results.sh "$sub") > "$tmp/$sub.cmds" 2> "$tmp/$sub.err"; then
    echo "FAIL $sub: DRY_RUN=1 exited non-zero:"; sed 's/^/  /' "$tmp/$sub.err"; status=1
  fi
done
if [[ -e "$tmp/runs" ]]; then echo "FAIL: DRY_RUN=1 created $tmp/runs"; status=1; fi
cd "$repo"
python3 - "$cli" "$tmp" $subcommands <<'PY' || status=1
import os, re, shlex, subprocess, sys

cli, tmp, subs = sys.argv[1], sys.argv[2], sys.argv[3:]
data = os.environ.get("MASKADAPT_DATA_DIR") or os.path.normpath(os.path.join(os.getcwd(), "../shared/data"))
nodata = os.path.join(tmp, "nodata"); os.makedirs(nodata, exist_ok=True)
inputs = {"--resume", "--base", "--generator", "--checkpoint", "--config", "--motions", "--new-motion"}
outputs = {"--out", "--json", "--csv", "--bvh", "--rollout", "--save"}
two_word = {"motion", "checkpoint"}
helps, seen, failures, flag_only = {}, set(), [], []
counts = {}

def help_flags(words):
    key = tuple(words)
    if key not in helps:
        out = subprocess.run([cli, *words, "--help"], capture_output=True, text=True, env=env()).stdout
        helps[key] = set(re.findall(r"(--[a-z0-9][a-z0-9-]*)", out))
    return helps[key]

def env():
    e = dict(os.environ, MASKADAPT_DATA_DIR=nodata, MASKADAPT_KEEP_BLAS_CORE="1")
    return e

def check_paths(sub, argv):
    for a in argv:
        if a.startswith(("models/", "configs/")) and not os.path.exists(a):
            failures.append(f"{sub}: missing file {a}: {shlex.join(argv)}")
        if os.path.isdir(data) and a.startswith(data + "/") and not os.path.exists(a):
            failures.append(f"{sub}: missing data {a}: {shlex.join(argv)}")

def check_cli(sub, argv):
    n = 2 if len(argv) > 2 and argv[1] in two_word else 1
    words, rest = argv[1:1 + n], argv[1 + n:]
    known = help_flags(words)
    for a in rest:
        if a.startswith("--") and a not in known:
            failures.append(f"{sub}: {a} is not a flag of `maskadapt {' '.join(words)}`: {shlex.join(argv)}")
    check_paths(sub, argv)
    # the invocation with inputs swapped for empty files and outputs sent to the scratch folder
    k = len(seen)
    swapped, prev = [], None
    for i, a in enumerate(rest):
        if a.startswith("--"):
            swapped.append(a); prev = a
            continue
        if (i == 0 and not a.startswith("-")) or (prev in inputs and "/" in a):
            f = os.path.join(tmp, "in", f"{k}-{os.path.basename(a)}")
            os.makedirs(os.path.dirname(f), exist_ok=True); open(f, "w").close(); a = f
        elif prev in outputs:
            os.makedirs(os.path.join(tmp, "out", str(k)), exist_ok=True)
            a = os.path.join(tmp, "out", str(k), os.path.basename(a))
        swapped.append(a)
    # one run per shape: paths stand for any path
    key = tuple(words) + tuple("PATH" if "/" in s else s for s in swapped)
    if key in seen:
        return
    seen.add(key)
    # a command with no input to swap would start work (a new training from the built-in motions)
    if not any(a.startswith(os.path.join(tmp, "in")) for a in swapped) and "bandai-walk" not in swapped:
        flag_only.append(shlex.join(argv)); return
    try:
        r = subprocess.run([cli, *words, *swapped], capture_output=True, text=True, env=env(), timeout=10, cwd=os.getcwd())
    except subprocess.TimeoutExpired:
        failures.append(f"{sub}: started work (still running after 10 s): {shlex.join(argv)}"); return
    err = r.stderr + r.stdout
    ok = r.returncode == 1 and "maskadapt: error:" in err and (os.path.join(tmp, "in") in err or nodata in err)
    if not ok:
        failures.append(f"{sub}: exit {r.returncode}, not the expected input error: {shlex.join(argv)}\n    {err.strip()[:400]}")

def check_plot(sub, args):
    check_paths(sub, args)
    mode, rest = (args[0], args[1:]) if args else ("", [])
    named = lambda xs: xs and all("=" in x for x in xs)
    good = {
        "curves": len(rest) >= 3 and named(rest[2:]),
        "paths": len(rest) >= 2 and named(rest[1:]),
        "strip": len(rest) in (2, 3) and (len(rest) == 2 or rest[2].isdigit()),
        "feet": 1 <= len(rest) <= 3,
        "visits": len(rest) >= 2 and named(rest[1:]),
        "windows": len(rest) >= 3 and rest[0].isdigit() and int(rest[0]) >= 1 and named(rest[2:]),
        "hnorm-summary": len(rest) >= 1 and named(rest),
    }.get(mode, False)
    if not good:
        failures.append(f"{sub}: plot_results.py would print its usage: {shlex.join(args)}")

for sub in subs:
    n = 0
    for line in open(os.path.join(tmp, sub + ".cmds")):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        argv = shlex.split(line)
        for j, a in enumerate(argv):   # the redirections
            if a.startswith(">") or a.startswith("2>"):
                argv = argv[:j]; break
        while argv and (argv[0] == "env" or re.match(r"^[A-Z_][A-Z0-9_]*=", argv[0])):
            argv = argv[1:]
        n += 1
        if not argv:
            failures.append(f"{sub}: empty command: {line}")
        elif argv[0] == cli:
            check_cli(sub, argv)
        elif argv[0] == "python3" and argv[1:2] == ["scripts/plot_results.py"]:
            check_plot(sub, argv[2:])
        elif argv[0].startswith("scripts/") and argv[0].endswith(".sh"):
            if subprocess.run(["bash", "-n", argv[0]]).returncode != 0:
                failures.append(f"{sub}: {argv[0]} does not parse")
        elif argv[0] in ("cp", "head"):
            pass
        else:
            failures.append(f"{sub}: unexpected command: {line}")
    counts[sub] = n
    if n == 0:
        failures.append(f"{sub}: DRY_RUN=1 printed no command")

print("reproduce_dry_run: commands printed per subcommand: " + ", ".join(f"{s} {counts[s]}" for s in subs))
print(f"reproduce_dry_run: {len(seen)} distinct maskadapt invocations run against swapped inputs, "
      f"{len(helps)} --help pages read; {len(flag_only)} with no input to swap checked by flag names only:")
for c in flag_only:
    print("  " + c)
for f in failures:
    print("FAIL " + f)
sys.exit(1 if failures else 0)
PY
if [[ $status == 0 ]]; then echo "reproduce_dry_run: OK"; fi
exit $status
