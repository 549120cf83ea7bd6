#!/usr/bin/env bash
# One guided generation of 100 genomes (criterion's `generation/guided`,
# or the benches FILTER names), today's build against an old commit's (by
# default 1acf3f1, the build before the branches were flown together),
# alternated run by run.
#
# The old commit's simulation, R, pass and their types are copied out of
# git into a small crate of their own (its protocol crate needs iceoryx2
# and zenoh only for their wire types, which the pass does not use), with
# the old `worker/benches/flight.rs` as its bench, so both benches build
# in a minute without a second zenoh.
#
#   scripts/pass-against-old.sh [ROUNDS] [COMMIT] [FILTER]
set -euo pipefail
rounds=${1:-3}
commit=${2:-1acf3f1}
filter=${3:-generation/guided\$}
root=$(git rev-parse --show-toplevel)
old=$(mktemp -d)
trap 'rm -rf "$old"' EXIT
mkdir -p "$old/src/proto" "$old/src/sim" "$old/benches"
show() { git -C "$root" show "$commit:$1" > "$2"; }
for f in check genome outcome params stream; do
    show "protocol/src/$f.rs" "$old/src/proto/$f.rs"
done
for f in sim score guide evaluate reference; do
    show "worker/src/$f.rs" "$old/src/$f.rs"
done
show worker/src/sim/tests.rs "$old/src/sim/tests.rs"
show worker/benches/flight.rs "$old/benches/flight.rs"
python3 - "$old" <<'EOF'
import glob, os, re, sys
root = sys.argv[1]
os.chdir(root)
for f in glob.glob('src/**/*.rs', recursive=True):
    s = open(f).read()
    s = s.replace('lander_protocol::', 'crate::proto::')
    s = s.replace('use iceoryx2::prelude::ZeroCopySend;\n', '')
    s = re.sub(r',\s*ZeroCopySend', '', s)
    s = re.sub(r'#\[type_name\([^)]*\)\]\n', '', s)
    if f.startswith('src/proto/'):
        s = s.replace('use crate::check::', 'use crate::proto::check::')
    if f == 'src/evaluate.rs':
        # The worker's job runner needs the wire types; the bench does not.
        s = s.replace('use crate::proto::wire::{ChunkResult, EvalJob};\n', '')
        i = s.index('/// Evaluates every genome of a checked job')
        s = s[:i] + s[s.index('\n}\n', i) + 3:]
    open(f, 'w').write(s)
b = open('benches/flight.rs').read()
b = b.replace('use lander_protocol::{', 'use oldpass::proto::{')
b = b.replace(' LearnParams,', '')
b = b.replace('use lander_worker::learn::train;\n', '')
b = b.replace('use lander_worker::{', 'use oldpass::{')
b = b[:b.index('fn qlearning')]
b += 'criterion_group!(benches, flights, guided_generation);\ncriterion_main!(benches);\n'
open('benches/flight.rs', 'w').write(b)
open('src/proto.rs', 'w').write('''pub mod check;
pub mod genome;
pub mod outcome;
pub mod params;
pub mod stream;
pub use genome::{Action, Gene};
pub use outcome::{Evaluation, Outcome, State};
pub use params::{Env, GuideParams, Method, Scoring, World};
pub use stream::StreamKey;
''')
open('src/lib.rs', 'w').write('''#![allow(dead_code, unused_imports)]
pub mod evaluate;
pub mod guide;
pub mod proto;
pub mod reference;
pub mod score;
pub mod sim;
pub use evaluate::evaluate;
pub use sim::fly;
#[cfg(test)]
pub(crate) fn test_env(x0: f64, pad_x: f64) -> proto::Env {
    proto::Env { world: proto::World::default(), scoring: proto::Scoring::default(), x0, pad_x }
}
''')
EOF
cat > "$old/Cargo.toml" <<'EOF'
[package]
name = "oldpass"
version = "0.1.0"
edition = "2021"

[workspace]

[dependencies]
serde = { version = "1", features = ["derive"] }
thiserror = "2"
rand = "0.9"
rand_chacha = "0.9"

[dev-dependencies]
criterion = { version = "0.8", default-features = false, features = ["cargo_bench_support"] }
proptest = "1"

[[bench]]
name = "flight"
harness = false

[profile.release]
debug = "line-tables-only"
EOF
cp "$root/Cargo.lock" "$old/"
bench_exe() {
    (cd "$1" && cargo bench $2 --bench flight --no-run --message-format json --quiet) |
        python3 -c 'import json,sys
for l in sys.stdin:
    m = json.loads(l)
    if m.get("reason") == "compiler-artifact" and m["target"]["name"] == "flight" and m.get("executable"):
        print(m["executable"])'
}
new_exe=$(bench_exe "$root" --workspace)
old_exe=$(bench_exe "$old" "")
if [[ -z $new_exe || -z $old_exe ]]; then
    echo "pass-against-old.sh: a flight bench did not build (today's: '$new_exe', $commit's: '$old_exe')" >&2
    exit 1
fi
for ((i = 1; i <= rounds; i++)); do
    for side in new old; do
        if [[ $side == new ]]; then exe=$new_exe dir=$root; else exe=$old_exe dir=$old; fi
        (cd "$dir" && "$exe" --bench "$filter" 2>&1) |
            grep -E '^[a-z][a-z/ ]*time:' | sed "s/^/$side /"
    done
done
