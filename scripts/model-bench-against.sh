#!/usr/bin/env bash
# The model's criterion benches (model/benches/flight.rs) of this checkout
# against an old commit's, run in turn ROUNDS times. Each commit's model
# crate is built alone in a workspace of its own (the model needs neither
# iceoryx2 nor zenoh), with this checkout's build flags (.cargo/config.toml).
#
#   scripts/model-bench-against.sh COMMIT [ROUNDS] [FILTER]
set -euo pipefail
if [ $# -lt 1 ]; then
    echo "usage: $0 COMMIT [ROUNDS] [FILTER]" >&2
    exit 2
fi
commit=$1
rounds=${2:-2}
filter=${3:-generation|qlearning|draws}
root=$(git rev-parse --show-toplevel)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
git -C "$root" archive "$commit" model | tar -x -C "$work" && mv "$work/model" "$work/old"
cp -r "$root/model" "$work/new"
python3 - "$root" "$work" <<'PY'
import re, sys
root, work = sys.argv[1], sys.argv[2]
top = open(f"{root}/Cargo.toml").read()
package = top[top.index("[workspace.package]"):top.index("[workspace.dependencies]")]
# The workspace dependencies either side's model names, from its own
# Cargo.toml (`name.workspace = true`, or `{ workspace = true, ... }`).
used = set()
for side in ("old", "new"):
    used |= set(re.findall(r"^([\w-]+)(?:\.workspace\s*=\s*true|\s*=\s*\{\s*workspace\s*=\s*true)",
                           open(f"{work}/{side}/Cargo.toml").read(), re.M))
used.discard("iceoryx2")
deps = [l for l in top[top.index("[workspace.dependencies]"):].split("\n")[1:]
        if (m := re.match(r"^([\w-]+)\s*=", l)) and m.group(1) in used]
release = top[top.index("\n[profile.release]\n") + 1:].split("\n\n")[0]
for side in ("old", "new"):
    path = f"{work}/{side}/Cargo.toml"
    s = open(path).read()
    s = s.replace("iceoryx2 = { workspace = true, optional = true }\n", "")
    s = s.replace('zero-copy = ["dep:iceoryx2"]', "zero-copy = []")
    s += "\n[workspace]\n" + package + "[workspace.dependencies]\n" + "\n".join(deps) + "\n\n" + release + "\n"
    open(path, "w").write(s)
PY
mkdir -p "$work/old/.cargo" "$work/new/.cargo"
cp "$root/.cargo/config.toml" "$work/old/.cargo/"
cp "$root/.cargo/config.toml" "$work/new/.cargo/"
for side in old new; do
    (cd "$work/$side" && CARGO_TARGET_DIR="$work/target-$side" cargo bench --bench flight --no-run -q)
done
for i in $(seq "$rounds"); do
    for side in old new; do
        echo "== $side ($( [ $side = old ] && echo "$commit" || echo this checkout)), round $i"
        (cd "$work/$side" && CARGO_TARGET_DIR="$work/target-$side" \
            cargo bench -q --bench flight -- "$filter" --noplot 2>&1 | grep -E "time:" | grep -v "%")
    done
done
