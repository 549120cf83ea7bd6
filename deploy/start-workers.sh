#!/usr/bin/env bash
# Starts N lander-worker processes on this host, serving one run of a
# coordinator reached over zenoh, and waits for them.
#
#   start-workers.sh --run ID --connect ENDPOINT [-n N] [--credentials FILE]
#                    [--zenoh-config FILE] [--metrics HOST:PORT]
#                    [-- EXTRA-WORKER-FLAGS...]
#
# N defaults to the number of cores (nproc). With --metrics, worker i of N
# serves Prometheus metrics at HOST:PORT+i-1 (deploy/prometheus/). The worker binary is
# $LANDER_WORKER if set, else ../target/release/lander-worker beside this
# script, else lander-worker on PATH. SIGTERM and SIGINT are passed on to
# every worker (as SIGTERM); the script then waits for them all. It exits 0
# when every worker exited cleanly (the run finished, the coordinator went
# away, or a signal stopped them), 1 if any worker failed, 2 on bad usage.
# Each worker's stderr is its own, already prefixed "lander-worker <id>:".
set -euo pipefail

me=$(basename "$0")
if ((BASH_VERSINFO[0] < 5 || (BASH_VERSINFO[0] == 5 && BASH_VERSINFO[1] < 1))); then
    echo "$me: error: needs bash 5.1 or newer (this is $BASH_VERSION)" >&2
    exit 2
fi

usage() {
    cat >&2 <<USAGE
usage: $me --run ID --connect ENDPOINT [-n N] [--credentials FILE] [--zenoh-config FILE] [--metrics HOST:PORT] [-- WORKER-FLAGS...]

  --run ID              the run to serve, as printed by 'lander run --attach --run-id ID'
  --connect ENDPOINT    the coordinator (or a zenoh router), e.g. tcp/10.0.0.5:7447 or tls/10.0.0.5:7447
  -n N                  how many workers to start [default: nproc = $(nproc)]
  --credentials FILE    a 'user:password' file, for a coordinator started with --users
  --zenoh-config FILE   a zenoh JSON5 configuration, e.g. for TLS (deploy/zenoh/worker-tls.json5)
  --metrics HOST:PORT   worker i serves Prometheus metrics at HOST:PORT+i-1
  -- WORKER-FLAGS...    anything else is passed to every lander-worker (e.g. --quiet)

The worker binary is \$LANDER_WORKER, else ../target/release/lander-worker beside
this script, else lander-worker on PATH.
USAGE
}

die_usage() {
    echo "$me: error: $*" >&2
    usage
    exit 2
}

run="" connect="" n="" credentials="" zenoh_config="" metrics=""
extra=()
while (($# > 0)); do
    case "$1" in
        --run | --connect | -n | --credentials | --zenoh-config | --metrics)
            (($# >= 2)) || die_usage "$1 needs a value"
            case "$1" in
                --run) run=$2 ;;
                --connect) connect=$2 ;;
                -n) n=$2 ;;
                --credentials) credentials=$2 ;;
                --zenoh-config) zenoh_config=$2 ;;
                --metrics) metrics=$2 ;;
            esac
            shift 2
            ;;
        --run=* | --connect=* | --credentials=* | --zenoh-config=* | --metrics=*)
            value=${1#*=}
            case "$1" in
                --run=*) run=$value ;;
                --connect=*) connect=$value ;;
                --credentials=*) credentials=$value ;;
                --zenoh-config=*) zenoh_config=$value ;;
                --metrics=*) metrics=$value ;;
            esac
            shift
            ;;
        -h | --help)
            usage
            exit 0
            ;;
        --)
            shift
            extra=("$@")
            break
            ;;
        *) die_usage "unknown argument '$1'" ;;
    esac
done

[[ -n $run ]] || die_usage "--run ID is required"
[[ -n $connect ]] || die_usage "--connect ENDPOINT is required"
if [[ -z $n ]]; then
    n=$(nproc)
fi
[[ $n =~ ^[1-9][0-9]*$ ]] || die_usage "-n must be a positive whole number (got '$n')"
metrics_host="" metrics_port=""
if [[ -n $metrics ]]; then
    [[ $metrics =~ ^(.+):([0-9]+)$ ]] || die_usage "--metrics must be HOST:PORT (got '$metrics')"
    metrics_host=${BASH_REMATCH[1]} metrics_port=${BASH_REMATCH[2]}
    ((metrics_port >= 1 && metrics_port + n - 1 <= 65535)) ||
        die_usage "--metrics ports $metrics_port to $((metrics_port + n - 1)) are not all valid ports"
fi
for file in "$credentials" "$zenoh_config"; do
    if [[ -n $file && ! -r $file ]]; then
        die_usage "cannot read '$file'"
    fi
done

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
if [[ -n ${LANDER_WORKER:-} ]]; then
    worker=$LANDER_WORKER
elif [[ -x $here/../target/release/lander-worker ]]; then
    worker=$here/../target/release/lander-worker
elif worker=$(command -v lander-worker); then
    :
else
    echo "$me: error: no lander-worker: set LANDER_WORKER, build it with 'cargo build --workspace --release', or put it on PATH" >&2
    exit 2
fi
[[ -x $worker ]] || {
    echo "$me: error: '$worker' is not an executable" >&2
    exit 2
}

args=(--run "$run" --transport zenoh --connect "$connect")
[[ -z $credentials ]] || args+=(--credentials "$credentials")
[[ -z $zenoh_config ]] || args+=(--zenoh-config "$zenoh_config")
args+=("${extra[@]}")

pids=()
stop() {
    echo "$me: stopping ${#pids[@]} worker(s)" >&2
    # A worker already gone is fine.
    kill -TERM "${pids[@]}" 2>/dev/null || true
}
trap stop TERM INT

for ((i = 1; i <= n; i++)); do
    own=()
    [[ -z $metrics ]] || own=(--metrics "$metrics_host:$((metrics_port + i - 1))")
    "$worker" "${args[@]}" "${own[@]}" &
    pids+=($!)
done
echo "$me: started $n worker(s) of $worker for run $run at $connect: ${pids[*]}" >&2

# Each worker is waited for by its pid, which bash answers with the exit
# status even for a worker that ended long ago: `wait -n` looks only at the
# job table, from which bash may already have dropped a worker that exited
# at once, and then says 127. A trapped signal interrupts the wait with a
# status above 128 while the worker still runs; then we wait again.
failed=0
for pid in "${pids[@]}"; do
    while true; do
        status=0
        wait "$pid" || status=$?
        if ((status > 128)) && kill -0 "$pid" 2>/dev/null; then
            continue
        fi
        break
    done
    if ((status != 0)); then
        echo "$me: worker $pid failed (exit status $status)" >&2
        failed=$((failed + 1))
    fi
done

if ((failed > 0)); then
    echo "$me: $failed of $n worker(s) failed" >&2
    exit 1
fi
echo "$me: all $n worker(s) exited cleanly" >&2
