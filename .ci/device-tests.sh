#!/bin/sh
# The GPU test binaries on a lent GPU (the device tool's machine): built
# and stripped here, carried there as one archive, run there with the
# agreement probe's verdict and one row per binary.
#
#   .ci/device-tests.sh stage     # here: builds, strips and packs
#                                 # target/device-tests.tar.xz (carry it)
#   .ci/device-tests.sh run       # there, in the repository root:
#                                 # unpacks and runs every binary
#   .ci/device-tests.sh bench     # there, after run (or alone): the
#                                 # gpu_step bench's tables at SIZES
#                                 # (default 33,65,257,513), quick
#
# The device's copy of the working tree may stand at another path than
# this one, and the test binaries find the repository (its scenes,
# shaders and the wgcloth binary) at the path they were built in
# (CARGO_MANIFEST_DIR): `run` links that path to the copy when it does
# not exist there. POLICY (bits, bounded or empty for the probe's
# choice) sets WGCLOTH_AGREEMENT; TIMEOUT (default 300 s) caps each
# binary; TESTS (default: every GPU test binary) names the binaries to run.
set -eu

archive=target/device-tests.tar.xz
# The test binaries that run on the GPU (the rest need no adapter).
gpu_tests="agreement kernel_twins gpu_implicit gpu_matrix workgroup workgroup_implicit
gpu_bending mesh_colliders self_collision colliders moving_pins default_limits
gpu_behaviour gpu_explicit gpu_semi_implicit gpu_scenes gpu_skipping gpu_handover
batch async_api profile materials meshes shaders"

stage() {
    out=target/device-tests
    rm -rf "$out"
    mkdir -p "$out/bin"
    cargo build --release --bin wgcloth
    list=$(mktemp)
    cargo test --release --no-run --message-format=json >"$list"
    for t in $gpu_tests; do
        exe=$(python3 -c '
import json, sys
for line in open(sys.argv[1]):
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m["target"]["name"] == sys.argv[2] \
            and "test" in m["target"]["kind"] and m.get("executable"):
        print(m["executable"])
' "$list" "$t" | tail -1)
        [ -n "$exe" ] || { echo "device-tests.sh: no test binary $t" >&2; exit 2; }
        cp "$exe" "$out/bin/$t"
        strip "$out/bin/$t"
    done
    rm -f "$list"
    # The step-time bench, for the performance tables (docs/performance.md).
    cargo bench --bench gpu_step --no-run --message-format=json >"$list.bench"
    bench=$(python3 -c '
import json, sys
for line in open(sys.argv[1]):
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m["target"]["name"] == "gpu_step" \
            and m.get("executable"):
        print(m["executable"])
' "$list.bench" | tail -1)
    [ -n "$bench" ] || { echo "device-tests.sh: no gpu_step bench binary" >&2; exit 2; }
    cp "$bench" "$out/bin/gpu_step"
    strip "$out/bin/gpu_step"
    rm -f "$list.bench"
    cp target/release/wgcloth "$out/bin/wgcloth"
    strip "$out/bin/wgcloth"
    printf '%s\n' "$PWD" >"$out/built-in"
    tar -C target -cJf "$archive" device-tests
    echo "packed $(du -h "$archive" | cut -f1) into $archive: carry it, then run"
    echo "  .ci/device-tests.sh run"
}

run() {
    [ -f "$archive" ] || { echo "device-tests.sh: no $archive (stage it, and carry it)" >&2; exit 2; }
    tar -C target -xJf "$archive"
    dir=target/device-tests
    built=$(cat "$dir/built-in")
    if [ "$built" != "$PWD" ] && [ ! -e "$built" ]; then
        mkdir -p "$(dirname "$built")"
        ln -s "$PWD" "$built"
    fi
    # The binaries look for wgcloth where it was built.
    mkdir -p "$built/target/release"
    [ -x "$built/target/release/wgcloth" ] || cp "$dir/bin/wgcloth" "$built/target/release/wgcloth"
    if [ -n "${POLICY:-}" ]; then
        export WGCLOTH_AGREEMENT="$POLICY"
    fi
    limit=${TIMEOUT:-300}
    nvidia-smi -L 2>/dev/null || true
    "$dir/bin/agreement" the_policy_follows --nocapture 2>&1 | grep '^agreement:' || true
    rows=""
    failed=0
    for t in ${TESTS:-$gpu_tests}; do
        start=$(date +%s)
        log="$dir/$t.log"
        if timeout "$limit" "$dir/bin/$t" >"$log" 2>&1; then status=pass; else status=FAIL; failed=$((failed + 1)); fi
        summary=$(grep '^test result' "$log" | tail -1 | sed 's/^test result: //; s/; finished.*//')
        rows="$rows| $t | $status | ${summary:-no summary (see $log)} | $(( $(date +%s) - start )) s |
"
        if [ "$status" = FAIL ]; then
            grep -E 'panicked|^---- ' "$log" | head -6 >&2 || true
        fi
    done
    echo
    echo "| binary | result | tests | time |"
    echo "| --- | --- | --- | ---: |"
    printf '%s' "$rows"
    echo "$failed failed"
    [ "$failed" -eq 0 ]
}

bench() {
    dir=target/device-tests
    [ -x "$dir/bin/gpu_step" ] || tar -C target -xJf "$archive"
    nvidia-smi -L 2>/dev/null || true
    # The printed tables only: criterion's own timing is filtered out.
    WGCLOTH_BENCH_QUICK=1 WGCLOTH_BENCH_SIZES="${SIZES:-33,65,257,513}" \
        "$dir/bin/gpu_step" --bench no-criterion-benchmark-matches-this
}

case "${1:-}" in
    stage) stage ;;
    run) run ;;
    bench) bench ;;
    *) echo "usage: .ci/device-tests.sh stage|run|bench" >&2; exit 2 ;;
esac
