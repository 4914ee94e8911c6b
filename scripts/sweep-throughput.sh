#!/usr/bin/env bash
# A campaign's throughput against what the single closed loop predicts.
#
# Usage (from the repository root, after `cargo build --release -p hil`):
#
#     scripts/sweep-throughput.sh [--points N] [--runs R] [--hil HIL]
#
# 1. The single closed loop: R times (default 7) a one-point campaign on one thread
#    (`hil sweep --param f11=5e6 --jobs 1`, the in-process curve with the phase lead):
#    the CPU time of its thread, as `hil sweep` reports it, is one point's cost inside
#    the process; the median predicts 1 / that points per core-second. (Also printed:
#    the median whole-process CPU time of `hil run`, start-up and output included.)
# 2. The campaign: `hil sweep --param f11=5e6..9e6:N` (default N = 100, every core) and
#    the points per core-second it reports.
# Prints both and their ratio (the campaign's figure over the prediction).
set -euo pipefail

hil=target/release/hil
points=100
runs=7
while [ $# -gt 0 ]; do
    case "$1" in
        --hil) hil="$2"; shift 2 ;;
        --points) points="$2"; shift 2 ;;
        --runs) runs="$2"; shift 2 ;;
        -h|--help) sed -n '2,16p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
        *) echo "sweep-throughput: unknown argument $1 (see --help)" >&2; exit 2 ;;
    esac
done
[ -x "$hil" ] || { echo "sweep-throughput: $hil is not an executable" >&2; exit 2; }
command -v python3 >/dev/null || { echo "sweep-throughput: needs python3 (for wait4)" >&2; exit 2; }

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

median() { sort -g | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'; }
# The "N core-s of CPU" of `hil sweep`'s throughput line.
core_s() { sed -n 's/.*wall, \([0-9.]*\) core-s of CPU.*/\1/p'; }

for _ in $(seq "$runs"); do
    "$hil" sweep --param f11=5e6 --jobs 1 --json "$tmp/one.json" --quiet 2>&1 >/dev/null \
        | grep '^hil sweep: throughput:' | core_s >>"$tmp/point"
    python3 -c '
import os, sys
pid = os.fork()
if pid == 0:
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 1)
    os.dup2(null, 2)
    os.execv(sys.argv[1], sys.argv[1:])
_, status, ru = os.wait4(pid, 0)
if os.waitstatus_to_exitcode(status) != 0:
    sys.exit("hil run failed")
print(ru.ru_utime + ru.ru_stime)
' "$hil" run --json "$tmp/run.json" >>"$tmp/process" </dev/null
done
[ -s "$tmp/point" ] || { echo "sweep-throughput: hil sweep printed no throughput" >&2; exit 1; }
point=$(median <"$tmp/point")
process=$(median <"$tmp/process")

line=$("$hil" sweep --param "f11=5e6..9e6:$points" --json "$tmp/sweep.json" --quiet 2>&1 \
    >/dev/null | grep '^hil sweep: throughput:' || true)
[ -n "$line" ] || { echo "sweep-throughput: hil sweep printed no throughput" >&2; exit 1; }
measured=$(echo "$line" | sed -n 's/.*: \([0-9.]*\) points per core-second.*/\1/p')

awk -v s="$point" -v w="$process" -v m="$measured" -v r="$runs" 'BEGIN {
    p = 1 / s
    printf "single closed loop in process (median of %d one-point campaigns): %.1f ms CPU -> %.2f points per core-second predicted\n", r, s * 1000, p
    printf "  (hil run, whole process, median of %d: %.1f ms CPU)\n", r, w * 1000
    printf "campaign: %.2f points per core-second, %.1f %% of the prediction\n", m, 100 * m / p
}'
echo "$line"
