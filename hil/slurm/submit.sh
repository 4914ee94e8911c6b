#!/bin/bash
# Submits a `hil sweep` campaign to Slurm: an array job of N shards (sweep.sbatch) and
# a merge job (merge.sbatch) that runs when every task of the array has succeeded.
#
#   hil/slurm/submit.sh -n N -o OUT [-c CPUS] [--hil HIL] [--elf ELF --qemu QEMU] -- FLAGS
#
#   -n N        shards: the array is --array=0-(N-1), one task per shard
#   -o OUT      output directory on a file system every node sees: OUT/shards/ (one
#               document per shard), OUT/logs/, and after the merge OUT/sweep.json (the
#               single run's document, byte for byte) and OUT/report/
#   -c CPUS     CPUs per task (default 1): each task runs its points on that many threads
#   --hil HIL   the hil binary (default: hil on PATH, else target/release/hil here;
#               build it with `cargo build --release -p hil`)
#   --elf ELF   --target qemu: the firmware ELF (`cargo fw`: target/fw/wheelset-qemu.elf)
#   --qemu QEMU --target qemu: the qemu-system-arm binary the nodes run
#   FLAGS       hil sweep's flags, the same for every shard: --param ... [--scenario S]
#               [--target inproc|qemu] [--seed N] [--params FILE] [--budget FILE] ...
#   Partition, account, time limit: sbatch's own SBATCH_PARTITION, SBATCH_ACCOUNT,
#   SBATCH_TIMELIMIT environment variables apply to both jobs.
#
# Prints "array job: ID" and "merge job: ID". Follow them with `squeue -u $USER`; the
# result is OUT/sweep.json once the merge job has completed.
#
# When a task fails
#   A task killed by Slurm (node failure, preemption, `scontrol requeue`) runs again by
#   itself (sweep.sbatch sets --requeue) and the merge waits for it: nothing to do.
#   A task that failed for good (its exit status is not 0: OUT/logs/shard-I.log says
#   why) fails the merge's afterok dependency, and a failed dependency is not revived
#   by a requeue: the merge job stays pending (squeue: DependencyNeverSatisfied). Then
#     1. scancel MERGE_JOB_ID
#     2. fix the cause, and resubmit the failed shards with the same N, OUT and FLAGS:
#          hil/slurm/submit.sh --rerun I[,J...] -n N -o OUT [...] -- FLAGS
#        which runs each shard I as a plain job (HIL_SHARD=I/N, not an array task) and
#        a new merge job after them; the shards that succeeded are kept.
#   Running `hil sweep merge OUT/shards/shard-*.json --json OUT/sweep.json` by hand
#   is the same merge; it names any shard that is still missing.
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
usage="usage: $0 [--rerun I[,J...]] -n N -o OUT [-c CPUS] [--hil HIL] [--elf ELF] [--qemu QEMU] -- HIL_SWEEP_FLAGS"
die() {
    echo "submit.sh: $*" >&2
    exit 2
}

n="" out="" cpus=1 hil="" elf="" qemu="" rerun=""
while [ $# -gt 0 ]; do
    case $1 in
    -n) n=${2:-}; shift 2 ;;
    -o) out=${2:-}; shift 2 ;;
    -c) cpus=${2:-}; shift 2 ;;
    --hil) hil=${2:-}; shift 2 ;;
    --elf) elf=${2:-}; shift 2 ;;
    --qemu) qemu=${2:-}; shift 2 ;;
    --rerun) rerun=${2:-}; shift 2 ;;
    --) shift; break ;;
    -h | --help) echo "$usage"; exit 0 ;;
    *) die "unknown option $1 ($usage)" ;;
    esac
done
[ $# -gt 0 ] || die "no hil sweep flags after -- ($usage)"
[[ $n =~ ^[1-9][0-9]*$ ]] || die "-n N: the number of shards, at least 1 (got '$n')"
[ -n "$out" ] || die "-o OUT: the output directory is needed"
[[ $cpus =~ ^[1-9][0-9]*$ ]] || die "-c CPUS: at least 1 (got '$cpus')"
command -v sbatch >/dev/null || die "sbatch not found: run this on a Slurm login node"

if [ -z "$hil" ]; then
    hil=$(command -v hil || true)
    [ -n "$hil" ] || hil=$here/../../target/release/hil
fi
case $hil in */*) ;; *) hil=$(command -v "$hil" || echo "$hil") ;; esac
[ -x "$hil" ] || die "--hil $hil: not an executable (cargo build --release -p hil)"
hil=$(readlink -f "$hil")
exports="ALL,HIL=$hil"
if [ -n "$elf" ]; then
    [ -f "$elf" ] || die "--elf $elf: no such file (cargo fw builds target/fw/wheelset-qemu.elf)"
    exports+=",HIL_ELF=$(readlink -f "$elf")"
fi
if [ -n "$qemu" ]; then
    [ -x "$qemu" ] || die "--qemu $qemu: not an executable"
    exports+=",HIL_QEMU=$(readlink -f "$qemu")"
fi

mkdir -p "$out/shards" "$out/logs"
out=$(readlink -f "$out")
shopt -s nullglob
if [ -z "$rerun" ]; then
    for f in "$out"/shards/shard-*.json "$out/sweep.json"; do
        if [ -e "$f" ]; then
            die "$f: $out holds an earlier campaign's documents; remove them, choose another -o, or --rerun I to redo shards"
        fi
    done
    array=$(sbatch --parsable --array="0-$((n - 1))" --cpus-per-task="$cpus" \
        --export="$exports" --output="$out/logs/shard-%a.log" \
        "$here/sweep.sbatch" "$out" "$@")
    array=${array%%;*}
    echo "array job: $array (shards 0-$((n - 1)) of $n; logs $out/logs/shard-*.log)"
    after="afterok:$array"
else
    after="afterok"
    IFS=, read -r -a redo <<<"$rerun"
    for i in "${redo[@]}"; do
        [[ $i =~ ^[0-9]+$ ]] && [ "$i" -lt "$n" ] || die "--rerun $rerun: $i is not a shard of 0..$((n - 1))"
        rm -f "$out/shards/shard-$i.json"
        job=$(sbatch --parsable --cpus-per-task="$cpus" \
            --export="$exports,HIL_SHARD=$i/$n" --output="$out/logs/shard-$i.log" \
            "$here/sweep.sbatch" "$out" "$@")
        job=${job%%;*}
        echo "rerun job: $job (shard $i/$n; log $out/logs/shard-$i.log)"
        after+=":$job"
    done
fi
merge=$(sbatch --parsable --dependency="$after" --export="$exports" \
    --output="$out/logs/merge.log" "$here/merge.sbatch" "$out")
merge=${merge%%;*}
echo "merge job: $merge (after $after; result $out/sweep.json, report $out/report/)"
