#!/usr/bin/env bash
# Side-by-side wall and CPU time of the processor-in-the-loop run: the 20 s `curve`
# closed through the QEMU firmware over the bulk channel, this build's exchange (two in
# flight, the frames of a wait in one write each way, the harness's thread on QEMU's core)
# against the exchange before: lock-step (`WHEELSET_QEMU_IN_FLIGHT=1`: one frame in
# flight, each written at once) with QEMU alone pinned (`WHEELSET_QEMU_PIN=qemu`), or a
# build of an earlier commit with --against; and between them the lock-step exchange on
# one core, to show what each part gives.
#
# Usage (from the repository root, after `cargo build --release -p hil` and `cargo fw`):
#
#     scripts/pil-bench.sh [--rounds N] [--before-elf OLD.elf] [--against OLD_HIL] [--this HIL]
#                          [--uart] [--syscalls]
#
# Runs N rounds (default 5), alternating, of
#
#   before:   WHEELSET_QEMU_IN_FLIGHT=1 WHEELSET_QEMU_PIN=qemu WHEELSET_QEMU_ELF=OLD.elf
#             HIL run --target qemu --qemu-link bulk   (or OLD_HIL run ...)
#   lockstep: WHEELSET_QEMU_IN_FLIGHT=1 HIL run --target qemu --qemu-link bulk
#   now:      HIL run --target qemu --qemu-link bulk   (the default ELF, target/fw/wheelset-qemu.elf)
#
# OLD.elf is the firmware before (e.g. `cargo fw` in a worktree of an earlier commit:
# `git worktree add /tmp/before COMMIT`); without --before-elf both use the default ELF.
# (the default reference and checks, `--json` of each run kept) and prints for each the
# median wall time (s), the median CPU time of the run with its QEMU (user + system, s:
# `wait4`'s rusage of the whole process tree), the exchanges per second of wall time and
# the speed-up of the medians. Then it checks that the runs' documents and CSVs are
# the same byte for byte (every trajectory record and the link columns; with
# --before-elf the device's stack mark aside, which is the firmware's own; the frames
# themselves are compared by `cargo test -p hil --test qemu_bulk`). With --uart, the
# UART path too (one round each way: a minute or two each). With --syscalls, one
# more run of each under `strace -f -c`: system calls per exchange, by call.
# Alternating runs share the machine's state, so the comparison holds on a noisy
# machine; the load average is printed beside.
set -euo pipefail

this=target/release/hil
against=""
before_elf=""
rounds=5
uart=0
syscalls=0
while [ $# -gt 0 ]; do
    case "$1" in
        --rounds) rounds="$2"; shift 2 ;;
        --against) against="$2"; shift 2 ;;
        --before-elf) before_elf="$2"; shift 2 ;;
        --this) this="$2"; shift 2 ;;
        --uart) uart=1; shift ;;
        --syscalls) syscalls=1; shift ;;
        -h|--help) sed -n '2,/^set -e/p' "$0" | grep '^#' | sed 's/^# \{0,1\}//'; exit 0 ;;
        *) echo "pil-bench: unknown argument $1 (see --help)" >&2; exit 2 ;;
    esac
done
case "$rounds" in
    ''|*[!0-9]*|0) echo "pil-bench: --rounds $rounds: a whole number of rounds, at least 1" >&2; exit 2 ;;
esac
if [ -n "$before_elf" ] && [ ! -f "$before_elf" ]; then
    echo "pil-bench: --before-elf $before_elf: no such file" >&2
    exit 2
fi
for b in "$this" ${against:+"$against"}; do
    [ -x "$b" ] || { echo "pil-bench: $b is not an executable (cargo build --release -p hil)" >&2; exit 2; }
done
command -v python3 >/dev/null || { echo "pil-bench: needs python3 (for wait4)" >&2; exit 2; }
if [ "$syscalls" = 1 ]; then
    command -v strace >/dev/null || { echo "pil-bench: --syscalls needs strace" >&2; exit 2; }
fi

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# One run: appends "wall_s cpu_s" to the file $1; $2 is a tag for its outputs, the rest
# the command. The CPU time is the process tree's (the harness and its QEMU, which it
# waits for): wait4's rusage of the child, which counts its waited-for children.
measure() {
    local out=$1 tag=$2
    shift 2
    python3 - "$out" "$tmp/$tag" "$@" <<'EOF'
import os, sys, time
out, tag, argv = sys.argv[1], sys.argv[2], sys.argv[3:]
argv = argv + ["--json", tag + ".json", "--csv", tag + ".csv"]
t0 = time.monotonic()
pid = os.posix_spawnp(argv[0], argv, os.environ)
_, status, ru = os.wait4(pid, 0)
wall = time.monotonic() - t0
if os.waitstatus_to_exitcode(status) != 0:
    sys.exit("pil-bench: %s exited with %d" % (" ".join(argv), os.waitstatus_to_exitcode(status)))
with open(out, "a") as f:
    f.write("%.3f %.3f\n" % (wall, ru.ru_utime + ru.ru_stime))
EOF
}

# The run before, in a subshell with its environment: one exchange in flight (unless an
# old build), its ELF if given.
run_before() {
    local tag=$1
    shift
    (
        [ -z "$before_elf" ] || export WHEELSET_QEMU_ELF="$before_elf"
        if [ -n "$against" ]; then
            measure "$tmp/before" "$tag" "$against" run --quiet --target qemu "$@"
        else
            export WHEELSET_QEMU_IN_FLIGHT=1 WHEELSET_QEMU_PIN=qemu
            measure "$tmp/before" "$tag" "$this" run --quiet --target qemu "$@"
        fi
    ) </dev/null >/dev/null
}
run_lockstep() {
    local tag=$1
    shift
    WHEELSET_QEMU_IN_FLIGHT=1 measure "$tmp/lockstep" "$tag" "$this" run --quiet --target qemu "$@" </dev/null >/dev/null
}
run_now() {
    local tag=$1
    shift
    measure "$tmp/now" "$tag" "$this" run --quiet --target qemu "$@" </dev/null >/dev/null
}

echo "pil-bench: $rounds rounds of the 20 s curve over the bulk channel; load average $(cut -d' ' -f1-3 /proc/loadavg)"
for r in $(seq 1 "$rounds"); do
    run_before "before-$r" --qemu-link bulk
    run_lockstep "lockstep-$r" --qemu-link bulk
    run_now "now-$r" --qemu-link bulk
    printf '  round %d: before %s s, lock-step on one core %s s, now %s s wall\n' "$r" \
        "$(tail -n1 "$tmp/before" | cut -d' ' -f1)" "$(tail -n1 "$tmp/lockstep" | cut -d' ' -f1)" \
        "$(tail -n1 "$tmp/now" | cut -d' ' -f1)"
done
# The device's stack mark (`stack_peak` of its Status) is the firmware's own: another
# build's (--before-elf) may differ there and nowhere else.
same_docs() {
    if [ -n "$before_elf" ]; then
        cmp -s <(grep -v '"stack_peak"' "$1") <(grep -v '"stack_peak"' "$2")
    else
        cmp -s "$1" "$2"
    fi
}
for r in $(seq 1 "$rounds"); do
    same_docs "$tmp/before-$r.json" "$tmp/now-$r.json" || {
        echo "pil-bench: round $r: the two runs' json differ" >&2
        exit 1
    }
    cmp -s "$tmp/before-$r.csv" "$tmp/now-$r.csv" || {
        echo "pil-bench: round $r: the two runs' csv differ" >&2
        exit 1
    }
    cmp -s "$tmp/lockstep-$r.json" "$tmp/now-$r.json" && cmp -s "$tmp/lockstep-$r.csv" "$tmp/now-$r.csv" || {
        echo "pil-bench: round $r: the lock-step run on one core differs" >&2
        exit 1
    }
done

# Median of column $2 of file $1.
median() {
    sort -g -k"$2,$2" "$1" | awk -v c="$2" '{ v[NR] = $c } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'
}
exchanges=100000
summary() {
    local name=$1 file=$2
    local wall cpu
    wall=$(median "$file" 1)
    cpu=$(median "$file" 2)
    printf '%-8s %8.2f s wall %8.2f s CPU %10.0f exchanges/s %6.1fx real time\n' "$name" "$wall" "$cpu" \
        "$(echo "$exchanges / $wall" | bc -l)" "$(echo "20 / $wall" | bc -l)"
}
echo "medians of $rounds (the harness with its QEMU; the documents and CSVs of each pair identical):"
summary before "$tmp/before"
summary lockstep "$tmp/lockstep"
summary now "$tmp/now"
ratio() { echo "$(median "$1" "$3") / $(median "$2" "$3")" | bc -l; }
printf 'speed-up: %.2fx wall, %.2fx CPU (now against before); %.2fx wall, %.2fx CPU (now against lock-step on one core); load average now %s\n' \
    "$(ratio "$tmp/before" "$tmp/now" 1)" "$(ratio "$tmp/before" "$tmp/now" 2)" \
    "$(ratio "$tmp/lockstep" "$tmp/now" 1)" "$(ratio "$tmp/lockstep" "$tmp/now" 2)" \
    "$(cut -d' ' -f1-3 /proc/loadavg)"

if [ "$uart" = 1 ]; then
    # The UART keeps one exchange in flight: what it gets is the placement.
    run_before uart-before
    run_now uart-now
    echo "UART path (one round each; one exchange in flight both ways):"
    tail -n1 "$tmp/before" >"$tmp/uart-before.row"
    tail -n1 "$tmp/now" >"$tmp/uart-now.row"
    summary before "$tmp/uart-before.row"
    summary now "$tmp/uart-now.row"
fi

if [ "$syscalls" = 1 ]; then
    echo "system calls per exchange (strace -f -c, the harness and its QEMU):"
    for which in before now; do
        (
            bin=$this
            if [ "$which" = before ]; then
                [ -z "$before_elf" ] || export WHEELSET_QEMU_ELF="$before_elf"
                if [ -n "$against" ]; then bin=$against; else export WHEELSET_QEMU_IN_FLIGHT=1 WHEELSET_QEMU_PIN=qemu; fi
            fi
            strace -f -c -o "$tmp/strace-$which" "$bin" run --quiet --target qemu --qemu-link bulk >/dev/null
        )
        awk -v n="$exchanges" -v w="$which" '
            # strace -c: % time, seconds, usecs/call, calls, [errors,] syscall.
            $1 ~ /^[0-9.]+$/ && $NF != "total" { calls[$NF] = $4; total += $4 }
            END {
                printf "  %-6s %6.2f in all:", w, total / n
                for (c in calls) if (calls[c] / n >= 0.05) printf " %s %.2f", c, calls[c] / n
                printf "\n"
            }' "$tmp/strace-$which"
    done
fi
