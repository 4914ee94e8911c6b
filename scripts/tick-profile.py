#!/usr/bin/env python3
"""Per-source-file instruction profile of one function of the QEMU bench firmware.

Usage (from the repository root, after `cargo xtask fw-bench` built the ELF):

    python3 scripts/tick-profile.py --record exec.log [whole_tick|law_step]
    python3 scripts/tick-profile.py exec.log [whole_tick|law_step]   # profile a log again
    python3 scripts/tick-profile.py exec.log whole_tick --calls 21-200  # those calls only

`--record` runs QEMU with the project's one command line (`cargo xtask qemu-cmd ELF --
-singlestep -d exec,nochain -D exec.log`, defined in hil/targets/src/qemu/cmd.rs: the board,
the CPU and the `-icount` shift of every run), then profiles the log.

The log holds one line per executed instruction (the bench's 2 000 calls of each
function give ~1 GB; build the bench with a smaller `N` in
firmware/app/src/bin/qemu_bench.rs for a quicker run: the averages per call are the
same). Every instruction executed between the function's entry and the return to its
caller is attributed to the source file of the innermost inlined frame
(`arm-none-eabi-addr2line`) and to the function symbol it lies in (`arm-none-eabi-nm`);
prints instructions per call by file and by function. Needs Debian's
`binutils-arm-none-eabi`.
"""
import collections
import re
import shlex
import signal
import subprocess
import sys

ELF = "target/fw/wheelset-qemu-bench.elf"


def record(log: str) -> None:
    """Runs the bench firmware under QEMU with the project's command line, tracing."""
    line = subprocess.run(
        ["cargo", "-q", "xtask", "qemu-cmd", ELF, "--",
         "-singlestep", "-d", "exec,nochain", "-D", log],
        capture_output=True, text=True, check=True).stdout.strip()
    print(f"running: {line}", file=sys.stderr)
    subprocess.run(shlex.split(line), check=True)


def main() -> None:
    # `... | head` ends quietly, as the project's command lines do.
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)
    args = sys.argv[1:]
    if args[:1] in (["--help"], ["-h"]):
        print(__doc__)
        return
    # `--calls A-B`: only the A-th to B-th calls (1-based), e.g. past the start-up.
    first, last = 1, None
    if "--calls" in args:
        k = args.index("--calls")
        m = re.fullmatch(r"(\d+)-(\d+)", args[k + 1] if k + 1 < len(args) else "")
        if not m or not 1 <= int(m.group(1)) <= int(m.group(2)):
            sys.exit("tick-profile: --calls takes A-B, 1 <= A <= B (e.g. 21-200)")
        first, last = int(m.group(1)), int(m.group(2))
        del args[k:k + 2]
    if any(a.startswith("-") and a != "--record" for a in args) or len(args) > 3:
        sys.exit(f"tick-profile: unknown arguments {args}\n{__doc__}")
    if args[:1] == ["--record"]:
        args = args[1:]
        if not args:
            sys.exit(__doc__)
        record(args[0])
    if not args:
        sys.exit(__doc__)
    log, name = args[0], (args[1] if len(args) > 1 else "whole_tick")
    dis = subprocess.run(["arm-none-eabi-objdump", "-d", "-C", ELF],
                         capture_output=True, text=True, check=True).stdout
    entry = ret = None
    for line in dis.splitlines():
        m = re.match(r"^([0-9a-f]+) <wheelset_qemu_bench::bench::(\w+)>:", line)
        if m and m.group(2) == name:
            entry = int(m.group(1), 16)
        m = re.match(r"\s+([0-9a-f]+):\s+(?:[0-9a-f]{4} ?){2}\s+bl\s+[0-9a-f]+ <wheelset_qemu_bench::bench::(\w+)>", line)
        if m and m.group(2) == name:
            ret = int(m.group(1), 16) + 4  # a 32-bit BL
    if entry is None or ret is None:
        sys.exit(f"{name}: entry or call site not found in {ELF}")
    pcs = collections.Counter()
    calls = seen = 0
    inside = False
    try:
        f = open(log)
    except OSError as e:
        sys.exit(f"tick-profile: cannot read the log {log}: {e.strerror} (record one with --record)")
    with f:
        for line in f:
            m = re.search(r"\[[0-9a-f]+/([0-9a-f]+)/", line)
            if not m:
                continue
            pc = int(m.group(1), 16)
            if pc == entry and not inside:
                seen += 1
                if last is not None and seen > last:
                    break
                inside = True
                calls += seen >= first
            elif inside and pc == ret:
                inside = False
            if inside and seen >= first:
                pcs[pc] += 1
    if calls == 0:
        sys.exit(f"{name} never ran in {log} (in the calls asked for)")
    addrs = sorted(pcs)
    out = subprocess.run(["arm-none-eabi-addr2line", "-f", "-e", ELF] + [hex(a) for a in addrs],
                         capture_output=True, text=True, check=True).stdout.splitlines()
    by_file = collections.Counter()
    for i, a in enumerate(addrs):
        path = out[2 * i + 1].split(":")[0]
        if "firmware/" in path:
            key = path.split("firmware/")[-1]
        elif "compiler-builtins" in path:
            key = "compiler-builtins (memcpy/memset)"
        elif "/rustc/" in path:
            key = "core (inlined)"
        else:
            key = path.rsplit("/src/", 1)[0].rsplit("/", 1)[-1] or path
        by_file[key] += pcs[a]
    print(f"{name}: {calls} calls, {sum(pcs.values()) / calls:.1f} instructions per call")
    print("by source file of the innermost inlined frame:")
    for key, n in by_file.most_common():
        print(f"{n / calls:8.1f}  {key}")
    # By the object's function symbols (what is out of line after LTO).
    syms = []
    nm = subprocess.run(["arm-none-eabi-nm", "-C", "-n", "-S", ELF],
                        capture_output=True, text=True, check=True).stdout
    for line in nm.splitlines():
        parts = line.split(" ", 3)
        if len(parts) == 4 and parts[2] in "tTwW":
            syms.append((int(parts[0], 16), int(parts[1], 16), parts[3]))
    by_sym = collections.Counter()
    for a in addrs:
        # Thumb symbols may carry bit 0; compare without it.
        hit = next((n for (s0, sz, n) in syms if (s0 & ~1) <= a < (s0 & ~1) + sz), "?")
        by_sym[hit] += pcs[a]
    print("by function symbol:")
    for key, n in by_sym.most_common():
        print(f"{n / calls:8.1f}  {key[:150]}")


if __name__ == "__main__":
    main()
