#!/usr/bin/env bash
# A fuzzing campaign: each target in turn (one job, one core) for SECONDS of wall time, growing
# fuzz/corpus/<target>/ from it and from fuzz/seeds/<target>/ (make_seeds.py). libFuzzer runs in
# fork mode so a crash, timeout or out-of-memory input is saved to fuzz/artifacts/<target>/ and
# the campaign goes on. Per target it prints the CPU time and libFuzzer's last stats line.
#
#   fuzz/campaign.sh [SECONDS] [TARGET...]     (default: 600 s, every target)
#
# Afterwards: minimise the corpora (`cargo fuzz cmin --sanitizer none TARGET`), reproduce each
# artifact (`cargo fuzz run --sanitizer none TARGET fuzz/artifacts/TARGET/crash-...`), fix it and
# keep it as a test in its crate.
set -euo pipefail
cd "$(dirname "$0")"
seconds="${1:-600}"
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || mapfile -t targets < <(cargo fuzz list)
# The targets write each input's files (includes, bitmaps, logs) and libFuzzer its fork-mode
# temporaries under TMPDIR: on a disk filesystem every input then waits on the journal (the cfg
# target spent most of its wall time waiting), so use memory when the machine has it.
if [ -z "${TMPDIR:-}" ] && [ -w /dev/shm ]; then
    export TMPDIR=/dev/shm
fi
cargo fuzz build --sanitizer none
# the targets run offline where permitted (see offline.sh)
source ./offline.sh
# where cargo put the binaries (CARGO_TARGET_DIR honoured)
bin="$(cargo metadata --format-version 1 --no-deps |
    python3 -c 'import json, sys; print(json.load(sys.stdin)["target_directory"])')"
bin="$bin/x86_64-unknown-linux-gnu/release"
mkdir -p logs
for t in "${targets[@]}"; do
    mkdir -p "corpus/$t" "artifacts/$t"
    seeds=()
    [ -d "seeds/$t" ] && seeds=("seeds/$t")
    log="logs/$t.log"
    echo "== $t: $seconds s"
    /usr/bin/time -f "$t cpu_seconds %U user %S sys %e wall" -o "logs/$t.time" \
        "${offline[@]}" "$bin/$t" "corpus/$t" "${seeds[@]}" \
        -fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1 \
        -rss_limit_mb=2048 -timeout=10 -max_len=262144 \
        -max_total_time="$seconds" -artifact_prefix="artifacts/$t/" \
        -print_final_stats=1 >"$log" 2>&1 || true
    cat "logs/$t.time"
    grep -E '^#[0-9]+' "$log" | tail -1 || true
    ls "artifacts/$t" | head -20
done
