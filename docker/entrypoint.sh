#!/bin/sh
# Starts one node of the Docker Slurm cluster: `controller` (munged + slurmctld),
# `compute` (munged + slurmd, node name = container hostname), or `login` (munged and
# a shell, for orch). The controller creates the munge key in the shared volume once;
# the others wait for it.
set -eu
role=${1:-login}
key=/etc/munge/munge.key

if [ "$role" = controller ] && [ ! -s "$key" ]; then
    dd if=/dev/urandom of="$key" bs=1 count=1024 2>/dev/null
fi
for _ in $(seq 120); do [ -s "$key" ] && break; sleep 0.5; done
[ -s "$key" ] || { echo "orch-node: no munge key in $key" >&2; exit 1; }
chown munge:munge "$key" && chmod 400 "$key"
mkdir -p /run/munge && chown munge:munge /run/munge
runuser -u munge -- munged

case "$role" in
    controller)
        mkdir -p /var/spool/slurmctld
        exec slurmctld -D
        ;;
    compute)
        mkdir -p /var/spool/slurmd
        exec slurmd -D -N "$(hostname)"
        ;;
    login)
        shift || true
        if [ $# -gt 0 ]; then exec "$@"; else exec sleep infinity; fi
        ;;
    *)
        echo "orch-node: unknown role $role (controller, compute or login)" >&2
        exit 2
        ;;
esac
