#!/usr/bin/env bash
# CI's fuzzing step (called by .ci/run): builds the fuzz targets with cargo-fuzz (installed if
# missing), then per target replays the committed corpus (fuzz/corpus/<target>/, every input
# once) and runs FUZZ_SECONDS (default 30) of new inputs. A crash, a timeout (10 s per input)
# or an input that takes more than 2 GiB fails the step; the input is left in
# fuzz/artifacts/<target>/ and its reproduction command is printed.
#
# New inputs found here go to a scratch folder, not to the committed corpus.
set -euo pipefail
cd "$(dirname "$0")"
seconds="${FUZZ_SECONDS:-30}"

if ! cargo fuzz --version >/dev/null 2>&1; then
    echo "== installing cargo-fuzz"
    start=$SECONDS
    cargo install cargo-fuzz --locked
    echo "cargo-fuzz installed in $((SECONDS - start)) s"
fi

# `--sanitizer none`: AddressSanitizer needs a nightly compiler (-Zsanitizer); libFuzzer's
# coverage instrumentation works on stable. Safe Rust needs no ASan to catch its bugs (bounds,
# overflow, unwrap are panics; cargo fuzz turns on debug assertions and overflow checks).
start=$SECONDS
cargo fuzz build --sanitizer none
echo "fuzz targets built in $((SECONDS - start)) s"

# the targets run offline where permitted (see offline.sh)
source ./offline.sh

scratch="$(mktemp -d)"
trap 'rm -rf "$scratch"' EXIT

# One libFuzzer run of target $1 over its committed corpus (and the step's scratch folder),
# with extra libFuzzer flags; its output goes to $scratch/$1.log.
run_target() {
    local t="$1"
    shift
    # TMPDIR: the targets' scratch folders (one per process) go with the step's own
    TMPDIR="$scratch" "${offline[@]}" cargo fuzz run --sanitizer none "$t" "$scratch/$t" "corpus/$t" -- \
        -rss_limit_mb=2048 -timeout=10 -max_len=262144 \
        -artifact_prefix="artifacts/$t/" -print_final_stats=1 "$@" >"$scratch/$t.log" 2>&1
}

failed=()
for t in $(cargo fuzz list); do
    mkdir -p "corpus/$t" "$scratch/$t" "artifacts/$t"
    start=$SECONDS
    # First every committed input once; then new inputs. libFuzzer's clock counts its corpus
    # load, so the second run is given the replay's time on top of FUZZ_SECONDS (a large
    # corpus, such as worldfile's, would otherwise leave it no time for new inputs).
    if run_target "$t" -runs=0; then
        replay=$((SECONDS - start))
        run_target "$t" -max_total_time=$((seconds + replay)) && ok=1 || ok=0
    else
        ok=0
    fi
    if [ "$ok" = 0 ]; then
        tail -40 "$scratch/$t.log"
        echo "FUZZ REGRESSION in $t: input(s) in fuzz/artifacts/$t/:"
        ls "artifacts/$t"
        echo "reproduce: cd fuzz && cargo fuzz run --sanitizer none $t artifacts/$t/<file>"
        failed+=("$t")
        continue
    fi
    stats="$(grep -E '^#[0-9]+[[:space:]]+DONE' "$scratch/$t.log" | tail -1 || true)"
    echo "$t: ok in $((SECONDS - start)) s (corpus replayed in $replay s): $stats"
done
if [ ${#failed[@]} -gt 0 ]; then
    echo "fuzzing found failures in: ${failed[*]}"
    exit 1
fi
