#!/usr/bin/env bash
# Development certificates for a LunarSim deployment over Zenoh TLS with mutual authentication.
#
#   deploy/security/make-dev-certs.sh [--bridges all|ID,ID...] [--ros2] OUT_DIR ROVERS [ROUTER_HOST ...]
#
# Makes, in OUT_DIR: a development CA (ca.pem, ca.key) and, signed by it, a key and certificate per
# role: router, world, lander, ground, recorder, view and rover-1 .. rover-ROVERS (<role>.key, <role>.pem),
# and with --bridges a bridge-<id> for each real rover's driver bridge (all: bridge-1 .. bridge-ROVERS),
# with --ros2 ros2 (the ROS 2 bridge) and ros2-nodes (the ROS 2 nodes on rmw_zenoh).
# Each certificate's common name is its role: the router's access control matches clients by it.
# The router's certificate names localhost, 127.0.0.1 and every ROUTER_HOST (a host name or an IP
# address) as subject alternative names: clients check the name they connect to against them.
#
# Idempotent: what already exists and is signed by OUT_DIR's CA is kept, only what is missing is made;
# each file is reported as "made" or "kept". For development only: the CA key sits beside the certs.
set -euo pipefail

DAYS=825
OPENSSL=${OPENSSL:-openssl}

usage() {
    echo "usage: $0 [--bridges all|ID,ID...] [--ros2] OUT_DIR ROVERS [ROUTER_HOST ...]   (ROVERS: number of" \
        "rover certificates, 1 or more; --bridges: real rovers whose driver bridge gets a bridge-<id> certificate;" \
        "--ros2: ros2 and ros2-nodes certificates)" >&2
    exit 2
}

BRIDGES=""
ROS2=""
while [ $# -gt 0 ]; do
    case "$1" in
        --bridges) [ $# -ge 2 ] || usage; BRIDGES=$2; shift 2 ;;
        --bridges=*) BRIDGES=${1#--bridges=}; shift ;;
        --ros2) ROS2=yes; shift ;;
        -*) echo "error: unknown option '$1'" >&2; usage ;;
        *) break ;;
    esac
done
[ $# -ge 2 ] || usage
OUT=$1
ROVERS=$2
shift 2
[[ "$ROVERS" =~ ^[0-9]+$ ]] && [ "$ROVERS" -ge 1 ] || { echo "error: ROVERS must be a whole number >= 1, got '$ROVERS'" >&2; exit 2; }
if [ "$BRIDGES" = all ]; then
    BRIDGES=$(seq -s, 1 "$ROVERS")
fi
IFS=, read -r -a BRIDGE_IDS <<<"$BRIDGES"
for id in ${BRIDGE_IDS[@]+"${BRIDGE_IDS[@]}"}; do
    [[ "$id" =~ ^[0-9]+$ ]] && [ "$id" -ge 1 ] && [ "$id" -le "$ROVERS" ] ||
        { echo "error: --bridges takes 'all' or rover ids 1..$ROVERS separated by commas, got '$id'" >&2; exit 2; }
done
command -v "$OPENSSL" >/dev/null || { echo "error: openssl not found (set OPENSSL=/path/to/openssl)" >&2; exit 2; }

mkdir -p "$OUT"
umask 077

new_key() {  # EC P-256 in PKCS#8, which rustls (Zenoh's TLS) reads
    "$OPENSSL" genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out "$1" 2>/dev/null
}

make_ca() {
    if [ -f "$OUT/ca.pem" ] && [ -f "$OUT/ca.key" ]; then
        echo "kept  $OUT/ca.pem (development CA)"
        return
    fi
    new_key "$OUT/ca.key"
    "$OPENSSL" req -x509 -new -key "$OUT/ca.key" -sha256 -days "$DAYS" -subj "/CN=lunarsim-dev-ca" \
        -addext "basicConstraints=critical,CA:TRUE" -addext "keyUsage=critical,keyCertSign,cRLSign" \
        -out "$OUT/ca.pem" 2>/dev/null
    echo "made  $OUT/ca.pem (development CA; its key: $OUT/ca.key)"
}

san_list() {  # localhost, 127.0.0.1 and the router hosts given, as DNS: or IP: entries
    local list="DNS:localhost,IP:127.0.0.1" host
    for host in "$@"; do
        if [[ "$host" =~ ^[0-9.]+$ || "$host" == *:* ]]; then list="$list,IP:$host"; else list="$list,DNS:$host"; fi
    done
    echo "$list"
}

names_of() {  # the certificate's subject alternative names as openssl prints them, or nothing
    "$OPENSSL" x509 -in "$1" -noout -ext subjectAltName 2>/dev/null | tail -n +2 | sed 's/^ *//'
}

make_cert() {  # make_cert ROLE [SAN]: a key and a certificate with CN=ROLE, signed by the CA
    local role=$1 san=${2:-} ext
    if [ -f "$OUT/$role.pem" ] && [ -f "$OUT/$role.key" ] &&
        "$OPENSSL" verify -CAfile "$OUT/ca.pem" "$OUT/$role.pem" >/dev/null 2>&1 &&
        [ "$(names_of "$OUT/$role.pem")" = "$(echo "$san" | sed 's/IP:/IP Address:/g; s/,/, /g')" ]; then
        echo "kept  $OUT/$role.pem"
        return
    fi
    ext=$(mktemp)
    {
        echo "basicConstraints=critical,CA:FALSE"
        echo "keyUsage=critical,digitalSignature,keyEncipherment"
        if [ -n "$san" ]; then
            echo "extendedKeyUsage=serverAuth,clientAuth"
            echo "subjectAltName=$san"
        else
            echo "extendedKeyUsage=clientAuth"
        fi
    } >"$ext"
    new_key "$OUT/$role.key"
    "$OPENSSL" req -new -key "$OUT/$role.key" -subj "/CN=$role" 2>/dev/null |
        "$OPENSSL" x509 -req -CA "$OUT/ca.pem" -CAkey "$OUT/ca.key" -CAcreateserial -sha256 -days "$DAYS" \
            -extfile "$ext" -out "$OUT/$role.pem" 2>/dev/null
    rm -f "$ext"
    echo "made  $OUT/$role.pem (CN=$role${san:+, SAN $san})"
}

make_ca
make_cert router "$(san_list "$@")"
for role in world lander ground recorder view; do
    make_cert "$role"
done
for ((i = 1; i <= ROVERS; i++)); do
    make_cert "rover-$i"
done
for id in ${BRIDGE_IDS[@]+"${BRIDGE_IDS[@]}"}; do
    make_cert "bridge-$((10#$id))"
done
if [ -n "$ROS2" ]; then
    make_cert ros2
    make_cert ros2-nodes
fi
chmod 644 "$OUT"/*.pem
echo "certificates in $OUT: give each process its <role>.pem and <role>.key, and ca.pem to all"
