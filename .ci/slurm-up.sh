#!/usr/bin/env bash
# Starts a one-node SLURM cluster on this machine for the cluster tests (tests/slurm_cluster.rs):
# Debian 12's slurmctld / slurmd / slurm-client / munge (installed if missing), all on loopback,
# config and state in one directory (no systemd), as root. Usage:
#
#     eval "$(.ci/slurm-up.sh [DIR])"     # default DIR /tmp/xpflow-slurm; prints `export SLURM_CONF=DIR/slurm.conf`
#     .ci/slurm-down.sh [DIR]             # stops the three daemons by their pid files
#
# The node is this machine's real CPUs and memory (`slurmd -C`), named `localhost` at 127.0.0.1.
# Facts this follows (slurm 22.05, munge 0.5.15): SlurmUser/SlurmdUser root avoid chowning;
# proctrack/linuxproc, task/none, no accounting, no cgroups; select/cons_tres with CR_Core, so that
# one node runs as many tasks as it has cores (select/linear runs one job per node at a time);
# munged refuses a socket directory without o+x (key directory 0700, socket directory 0755, key 0400).
# Everything this prints on stdout is shell to eval; progress goes to stderr.
set -euo pipefail
DIR=${1:-/tmp/xpflow-slurm}
log() { echo "slurm-up: $*" >&2; }

if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null || ! command -v sbatch >/dev/null \
    || ! command -v munged >/dev/null; then
    [ "$(id -u)" = 0 ] || { log "SLURM is not installed and this is not root: cannot install it"; exit 1; }
    log "installing slurmctld slurmd slurm-client munge (apt)"
    apt-get update -qq >&2
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
        slurmctld slurmd slurm-client munge >&2
fi
[ "$(id -u)" = 0 ] || { log "the daemons run as root here (SlurmUser=root); run as root"; exit 1; }

# an earlier cluster in DIR: stopped first, so that a rerun starts from a known state
"$(dirname "$0")/slurm-down.sh" "$DIR" >&2 || true
rm -rf "$DIR"
mkdir -p "$DIR"/{munge-key,munge,state,spool,log}
chmod 0755 "$DIR" "$DIR/munge" "$DIR/log"
chmod 0700 "$DIR/munge-key"

# munge: a fresh key, its own socket
dd if=/dev/urandom of="$DIR/munge-key/munge.key" bs=1024 count=1 status=none
chmod 0400 "$DIR/munge-key/munge.key"
munged --force --key-file="$DIR/munge-key/munge.key" --socket="$DIR/munge/munge.socket" \
    --pid-file="$DIR/munge/munged.pid" --log-file="$DIR/log/munged.log" \
    --seed-file="$DIR/munge-key/munged.seed"

# the node as slurmd sees it (CPUs, boards, sockets, cores, threads, memory), renamed localhost
node=$(slurmd -C | head -n1 | sed -e 's/^NodeName=[^ ]*//')
cat >"$DIR/slurm.conf" <<EOF
ClusterName=xpflow
SlurmctldHost=$(hostname -s)(127.0.0.1)
SlurmctldPort=${XPFLOW_SLURMCTLD_PORT:-6817}
SlurmdPort=${XPFLOW_SLURMD_PORT:-6818}
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$DIR/munge/munge.socket
CredType=cred/munge
StateSaveLocation=$DIR/state
SlurmdSpoolDir=$DIR/spool
SlurmctldPidFile=$DIR/slurmctld.pid
SlurmdPidFile=$DIR/slurmd.pid
SlurmctldLogFile=$DIR/log/slurmctld.log
SlurmdLogFile=$DIR/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MailProg=/bin/true
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MinJobAge=60
NodeName=localhost NodeAddr=127.0.0.1 $node State=UNKNOWN
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF="$DIR/slurm.conf"
slurmctld -i
slurmd -N localhost

# ready when the node is idle (about 1.5 s after the start)
for _ in $(seq 1 60); do
    if sinfo -h -N -o '%T' 2>/dev/null | grep -qx idle; then
        log "one-node cluster up: $(sinfo -h -N -o '%N %c CPUs %m MB %T'), config $SLURM_CONF"
        echo "export SLURM_CONF=$SLURM_CONF"
        exit 0
    fi
    sleep 0.5
done
log "the node did not become idle in 30 s; logs in $DIR/log:"
tail -n 20 "$DIR"/log/*.log >&2 || true
exit 1
