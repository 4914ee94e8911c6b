#!/usr/bin/env bash
# Side-by-side CPU time and peak memory of the host closed loop and the modal sweep.
#
# Usage (from the repository root, after `cargo build --release -p sim-host`):
#
#     scripts/loop-bench.sh --against OTHER_SIM_HOST [--against ...] [--pairs N] [--this SIM_HOST]
#                           [--instructions] [--parts]
#
# Runs, alternating between each OTHER_SIM_HOST (e.g. builds of earlier commits; repeat
# --against for several) and this build (default target/release/sim-host), N rounds
# (default 7) of each workload on every binary:
#
#   loop:  sim-host run --scenario curve --control lead --loop device   (output discarded)
#   modes: sim-host modes --json DIR/modes.json                         (4 cases x 1 000 points)
#
# With --parts, two more workloads show what the closed loop is made of, the work it
# cannot drop:
#
#   ref:   sim-host run --scenario curve --control lead                 (the continuous reference alone)
#   core:  sim-host run --scenario curve --control lead --loop core     (the sampled run with the
#                                                                        control core called in process: no frame, no link)
#
# and prints, for each binary (by its path) and workload, the medians of the whole
# process's CPU time (user + system, ms, from its exec to its exit; `wait4`'s rusage,
# microsecond resolution) and its peak resident memory (MiB, GNU time's report of a
# second run, which rounds CPU times to 10 ms and so gives the memory only).
# Alternating runs share the machine's state, so the comparison holds on a noisy machine.
# With --instructions, each binary also runs each workload once under valgrind's
# callgrind, whose instruction counts do not depend on the machine's load.
set -euo pipefail

this=target/release/sim-host
against=()
pairs=7
instructions=0
jobs=(loop modes)
while [ $# -gt 0 ]; do
    case "$1" in
        --against) against+=("$2"); shift 2 ;;
        --this) this="$2"; shift 2 ;;
        --pairs) pairs="$2"; shift 2 ;;
        --instructions) instructions=1; shift ;;
        --parts) jobs=(loop modes ref core); shift ;;
        -h|--help) sed -n '2,/^set -e/p' "$0" | grep '^#' | sed 's/^# \{0,1\}//'; exit 0 ;;
        *) echo "loop-bench: unknown argument $1 (see --help)" >&2; exit 2 ;;
    esac
done
[ ${#against[@]} -gt 0 ] || { echo "loop-bench: --against BINARY is required" >&2; exit 2; }
bins=("${against[@]}" "$this")
for b in "${bins[@]}"; do
    [ -x "$b" ] || { echo "loop-bench: $b is not an executable" >&2; exit 2; }
done
command -v python3 >/dev/null || { echo "loop-bench: needs python3 (for wait4)" >&2; exit 2; }
[ -x /usr/bin/time ] || { echo "loop-bench: needs GNU time at /usr/bin/time (Debian package \`time\`)" >&2; exit 2; }

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# One run: appends "cpu_ms rss_kib" to the file $1; the rest is the command. The CPU time
# is the binary's own (user + system, wait4's rusage of a child started by posix_spawn,
# which runs nothing of its own before the exec: the process from its exec to its exit).
# The peak memory comes from a second run under GNU time, whose report is the binary's
# alone (a child's maximum from wait4 would carry the spawning Python's resident set
# over the exec, and GNU time's own CPU time, about a millisecond, would be counted).
measure() {
    local out="$1"; shift
    python3 -c '
import os, sys
rss, cmd = sys.argv[1], sys.argv[2:]
null = os.open(os.devnull, os.O_WRONLY)
quiet = [(os.POSIX_SPAWN_DUP2, null, 1)]
pid = os.posix_spawn(cmd[0], cmd, os.environ, file_actions=quiet)
_, status, ru = os.wait4(pid, 0)
if os.waitstatus_to_exitcode(status) != 0:
    sys.exit(1)
timed = ["/usr/bin/time", "-f", "%M", "-o", rss] + cmd
pid = os.posix_spawn(timed[0], timed, os.environ, file_actions=quiet)
_, status, _ = os.wait4(pid, 0)
if os.waitstatus_to_exitcode(status) != 0:
    sys.exit(1)
print("%.1f %s" % ((ru.ru_utime + ru.ru_stime) * 1000, open(rss).read().split()[-1]))
' "$tmp/rss" "$@" >>"$out" 2>"$tmp/err" </dev/null \
        || { echo "loop-bench: failed: $*" >&2; cat "$tmp/err" >&2; exit 1; }
}

# The arguments of workload $1 (the modal sweep writes its JSON to $2), in `args`.
args_of() {
    case "$1" in
        loop) args=(run --scenario curve --control lead --loop device) ;;
        modes) args=(modes --json "$2") ;;
        ref) args=(run --scenario curve --control lead) ;;
        core) args=(run --scenario curve --control lead --loop core) ;;
    esac
}

for i in $(seq "$pairs"); do
    for side in "${!bins[@]}"; do
        bin=${bins[$side]}
        for job in "${jobs[@]}"; do
            args_of "$job" "$tmp/modes-$side.json"
            measure "$tmp/$side.$job" "$bin" "${args[@]}"
        done
    done
done

median() { sort -n | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }

w=6
for b in "${bins[@]}"; do [ ${#b} -gt $w ] && w=${#b}; done
printf "%-${w}s %-6s %12s %14s   (%s rounds, median)\n" binary job "cpu ms" "peak RSS MiB" "$pairs"
for side in "${!bins[@]}"; do
    for job in "${jobs[@]}"; do
        cpu=$(cut -d' ' -f1 "$tmp/$side.$job" | median)
        rss=$(cut -d' ' -f2 "$tmp/$side.$job" | median)
        printf "%-${w}s %-6s %12s %14.1f\n" "${bins[$side]}" "$job" "$cpu" "$(echo "$rss / 1024" | bc -l)"
    done
done
if [ "$instructions" = 1 ]; then
    command -v valgrind >/dev/null || { echo "loop-bench: --instructions needs valgrind" >&2; exit 2; }
    printf "%-${w}s %-6s %12s\n" binary job "instructions (M, callgrind)"
    for side in "${!bins[@]}"; do
        bin=${bins[$side]}
        for job in "${jobs[@]}"; do
            args_of "$job" "$tmp/modes-cg.json"
            valgrind --tool=callgrind --callgrind-out-file="$tmp/cg" "$bin" "${args[@]}" >/dev/null 2>"$tmp/err" \
                || { echo "loop-bench: callgrind failed: $bin" >&2; cat "$tmp/err" >&2; exit 1; }
            ir=$(sed -n 's/^summary: \([0-9]*\).*/\1/p' "$tmp/cg")
            printf "%-${w}s %-6s %12.1f\n" "$bin" "$job" "$(echo "$ir / 1000000" | bc -l)"
        done
    done
fi
