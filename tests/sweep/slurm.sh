#!/usr/bin/env bash
# ebh sweep --slurm against a real single-node Slurm started here on localhost: munged with its
# own key and socket, slurmctld and slurmd with a configuration in WORK_DIR (Debian 12's packages
# slurmctld, slurmd, slurm-client and munge; scripts/setup.sh installs them). A tiny plan (3 runs
# of 0.2 s on the tube) is submitted as a job array; `ebh sweep report` collects it.
# Exits 77 (ctest: skipped) with one line saying why when the daemons cannot start (not root, a
# package missing, ports taken, a daemon that does not come up); every wait is bounded and the
# daemons it started are stopped on exit.
#   tests/sweep/slurm.sh EBH_BIN WORK_DIR
set -uo pipefail
ebh=$1
work=$2
skip() { echo "SKIP: $*"; exit 77; }
fail() { echo "FAIL: $*" >&2; exit 1; }

[ "$(id -u)" = 0 ] || skip "the test Slurm runs its daemons as root; not root here"
for p in munged slurmctld slurmd sbatch squeue sinfo; do
  command -v $p >/dev/null 2>&1 || PATH=$PATH:/usr/sbin command -v $p >/dev/null 2>&1 ||
    skip "$p not installed (Debian: munge slurmctld slurmd slurm-client; scripts/setup.sh)"
done
export PATH=$PATH:/usr/sbin

rm -rf "$work"
mkdir -p "$work"/{state,spool,munge,key}
chmod 755 "$work" "$work/munge"
chmod 700 "$work/key"
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null; done
  for p in "${pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$p" 2>/dev/null || break; sleep 0.1; done
    kill -9 "$p" 2>/dev/null
  done
}
trap cleanup EXIT

# Two free ports near a number of this process's own.
port_free() { ! (exec 3<>/dev/tcp/127.0.0.1/"$1") 2>/dev/null; }
base=$((20000 + ($$ % 2000) * 10))
ctld_port= slurmd_port=
for p in $(seq $base 2 $((base + 40))); do
  if port_free $p && port_free $((p + 1)); then ctld_port=$p; slurmd_port=$((p + 1)); break; fi
done
[ -n "$ctld_port" ] || skip "no two free ports in $base-$((base + 41))"

# munge: a key of our own and a socket in the work folder.
if command -v mungekey >/dev/null 2>&1; then
  mungekey -c -k "$work/key/munge.key" >/dev/null 2>&1 || skip "mungekey could not make a key"
else
  dd if=/dev/urandom of="$work/key/munge.key" bs=1024 count=1 2>/dev/null && chmod 400 "$work/key/munge.key"
fi
sock=$work/munge/munge.sock
munged -F -f --socket="$sock" --key-file="$work/key/munge.key" --log-file="$work/munged.log" \
  --pid-file="$work/munged.pid" --seed-file="$work/munged.seed" >"$work/munged.out" 2>&1 &
pids+=($!)
for _ in $(seq 50); do [ -S "$sock" ] && break; sleep 0.1; done
[ -S "$sock" ] || skip "munged did not start: $(tail -1 "$work/munged.out")"

host=$(hostname -s)
cat >"$work/slurm.conf" <<EOF
ClusterName=ebhtest
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
AuthType=auth/munge
AuthInfo=socket=$sock
CredType=cred/munge
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
MpiDefault=none
JobCompType=jobcomp/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
NodeName=$host NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$work/slurm.conf
slurmctld -D -i >"$work/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -N "$host" >"$work/slurmd.out" 2>&1 &
pids+=($!)
state=
for _ in $(seq 100); do  # at most 20 s for the node to be idle
  state=$(timeout 5 sinfo -h -o %t 2>/dev/null | head -1)
  [ "$state" = idle ] && break
  sleep 0.2
done
[ "$state" = idle ] || skip "Slurm did not come up (node '${state:-none}'): $(tail -1 "$work/slurmctld.log" 2>/dev/null) / $(tail -1 "$work/slurmd.log" 2>/dev/null)"

cat >"$work/plan.yaml" <<'EOF'
scenes:
  - {scene: tube, recordings: [tube_insert], reference: {solver.virtual_iterations: 8}}
grid:
  solver.virtual_iterations: [2, 4]
start: 4
duration: 0.2
EOF
out=$work/sweep
"$ebh" sweep "$work/plan.yaml" -o "$out" --slurm --slurm-args "-c 1" >"$work/submit.out" 2>&1 ||
  fail "submit: $(tail -1 "$work/submit.out")"
grep -q 'submitted Slurm job array [0-9]*: 3 tasks for 3 runs' "$work/submit.out" || fail "submit said: $(cat "$work/submit.out")"
job=$(sed -n 's/.*job array \([0-9]*\).*/\1/p' "$work/submit.out")
for _ in $(seq 450); do  # at most 90 s for the array to finish
  [ -z "$(timeout 5 squeue -h -j "$job" 2>/dev/null)" ] && break
  sleep 0.2
done
[ -z "$(timeout 5 squeue -h -j "$job" 2>/dev/null)" ] && [ "$(ls "$out/slurm" | wc -l)" = 3 ] ||
  fail "job array $job not done in 90 s: $(timeout 5 squeue -h 2>&1 | head -3)"
"$ebh" sweep report "$out" >"$work/report.md" 2>"$work/report.err" || fail "report: $(tail -1 "$work/report.err")"
grep -q 'collected 3 runs: 3 ok, 0 failed, 0 not run' "$work/report.err" ||
  fail "report: $(cat "$work/report.err"); task logs: $(cat "$out"/slurm/* | tail -5)"
grep -q '^| \* | solver.virtual_iterations=4 | 1 |' "$work/report.md" || fail "report: $(cat "$work/report.md")"
# Resubmitting a finished sweep submits nothing.
"$ebh" sweep "$work/plan.yaml" -o "$out" --slurm >"$work/again.out" 2>&1 || fail "resubmit: $(tail -1 "$work/again.out")"
grep -q 'all 3 runs are done; nothing to submit' "$work/again.out" || fail "resubmit: $(cat "$work/again.out")"
echo "slurm: job array $job ran 3 runs on $host; report collected them"
