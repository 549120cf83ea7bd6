#!/usr/bin/env bash
# Makes zenoh user/password files for a lander coordinator and its workers,
# each user with a fresh random password.
#
#   make-users.sh OUTDIR USER...
#   make-users.sh ./creds host-b host-c
#
# OUTDIR gets:
#   users.txt            one `user:password` line per user, for
#                        `lander run ... --users users.txt` (coordinator host)
#   USER.credentials     that user's `user:password` line, for
#                        `lander-worker ... --credentials USER.credentials`
#                        (or start-workers.sh --credentials) on that worker host
# A user already in users.txt keeps its password; new users are appended.
# Every file is mode 600. One user per worker host lets you shut out a
# single host later: delete its line and restart the coordinator.
set -euo pipefail

me=$(basename "$0")
if (($# < 2)); then
    echo "usage: $me OUTDIR USER..." >&2
    echo "  e.g. $me ./creds host-b host-c" >&2
    exit 2
fi
out=$1
shift
for user in "$@"; do
    [[ $user =~ ^[A-Za-z0-9._-]+$ ]] || {
        echo "$me: error: user names are letters, digits, '.', '_' or '-' (got '$user')" >&2
        exit 2
    }
done

mkdir -p "$out"
umask 077
touch "$out/users.txt"
chmod 600 "$out/users.txt"
for user in "$@"; do
    line=$(awk -F: -v u="$user" '$1 == u { print; exit }' "$out/users.txt")
    if [[ -z $line ]]; then
        # 128 random bits, hex: nothing zenoh would trim or split on.
        password=$(od -An -tx1 -N16 /dev/urandom | tr -d ' \n')
        line="$user:$password"
        printf '%s\n' "$line" >>"$out/users.txt"
    fi
    printf '%s\n' "$line" >"$out/$user.credentials"
    chmod 600 "$out/$user.credentials"
done
echo "$me: wrote $out/users.txt (for the coordinator's --users) and $(printf '%s.credentials ' "$@")" >&2
