#!/usr/bin/env bash
# Makes the certificates for mutual TLS between a lander coordinator and
# its workers, with openssl: a private CA, a key and certificate for the
# coordinator, and one for the workers.
#
#   make-certs.sh OUTDIR COORDINATOR-SANS [WORKER-SANS]
#   make-certs.sh /tmp/lander-certs IP:10.0.0.5,IP:127.0.0.1,DNS:localhost
#
# COORDINATOR-SANS must name every address workers connect to: a worker
# checks that `--connect tls/10.0.0.5:7447` reached a certificate for
# IP:10.0.0.5. WORKER-SANS default to DNS:lander-worker (the coordinator
# checks only that a worker's certificate comes from this CA).
#
# OUTDIR gets:
#   ca.pem                          the CA certificate: copy to every host
#   ca-key.pem                      the CA key: keep it off the hosts, it mints members
#   coordinator.pem, coordinator-key.pem   for the coordinator's host
#   worker.pem, worker-key.pem             for every worker host
# An existing ca.pem and ca-key.pem in OUTDIR are reused, so running it
# again in the same OUTDIR renews the leaves under the same CA. Keys are
# EC P-256 (PKCS#8), mode 600; certificates are X.509 v3 with
# extendedKeyUsage serverAuth and clientAuth, so either end may use either.
set -euo pipefail

me=$(basename "$0")
usage() {
    echo "usage: $me OUTDIR COORDINATOR-SANS [WORKER-SANS]" >&2
    echo "  e.g. $me ./certs IP:10.0.0.5,IP:127.0.0.1,DNS:localhost" >&2
    exit 2
}
(($# == 2 || $# == 3)) || usage
out=$1
coordinator_sans=$2
worker_sans=${3:-DNS:lander-worker}
san_re='^(IP|DNS):[^,[:space:]]+(,(IP|DNS):[^,[:space:]]+)*$'
for sans in "$coordinator_sans" "$worker_sans"; do
    [[ $sans =~ $san_re ]] || {
        echo "$me: error: '$sans' is not a list like IP:10.0.0.5,DNS:host" >&2
        usage
    }
done
command -v openssl >/dev/null || {
    echo "$me: error: openssl is not installed (apt-get install openssl)" >&2
    exit 1
}

mkdir -p "$out"
umask 077
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

if [[ -f $out/ca.pem && -f $out/ca-key.pem ]]; then
    echo "$me: reusing the CA in $out" >&2
else
    openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes \
        -keyout "$out/ca-key.pem" -out "$out/ca.pem" -days 3650 \
        -subj "/CN=lander-ca" \
        -addext "basicConstraints=critical,CA:TRUE" \
        -addext "keyUsage=critical,keyCertSign,cRLSign" 2>"$tmp/log" || {
        cat "$tmp/log" >&2
        exit 1
    }
fi

# leaf NAME SANS: NAME-key.pem and NAME.pem, signed by the CA.
leaf() {
    local name=$1 sans=$2
    openssl req -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes \
        -keyout "$out/$name-key.pem" -out "$tmp/$name.csr" \
        -subj "/CN=lander-$name" 2>"$tmp/log" || {
        cat "$tmp/log" >&2
        exit 1
    }
    printf '%s\n' \
        "basicConstraints=critical,CA:FALSE" \
        "keyUsage=critical,digitalSignature" \
        "extendedKeyUsage=serverAuth,clientAuth" \
        "subjectAltName=$sans" >"$tmp/$name.ext"
    openssl x509 -req -in "$tmp/$name.csr" -CA "$out/ca.pem" -CAkey "$out/ca-key.pem" \
        -CAcreateserial -CAserial "$tmp/ca.srl" -out "$out/$name.pem" -days 825 \
        -extfile "$tmp/$name.ext" 2>"$tmp/log" || {
        cat "$tmp/log" >&2
        exit 1
    }
    openssl verify -CAfile "$out/ca.pem" "$out/$name.pem" >/dev/null
}
leaf coordinator "$coordinator_sans"
leaf worker "$worker_sans"
chmod 644 "$out/ca.pem" "$out/coordinator.pem" "$out/worker.pem"
chmod 600 "$out/ca-key.pem" "$out/coordinator-key.pem" "$out/worker-key.pem"

echo "$me: wrote to $out: ca.pem ca-key.pem coordinator.pem coordinator-key.pem worker.pem worker-key.pem" >&2
echo "$me: coordinator certificate for $coordinator_sans; keep ca-key.pem off the hosts" >&2
