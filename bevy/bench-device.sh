#!/bin/sh
# Times the `flags` example headless (no window, no display) on this
# machine's GPU: 1, 16 and 64 flags, each in Bevy with the plugin, in Bevy
# paused (drawing only) and stepped by wgcloth's standalone batch, one
# line each as the example prints it, then one Markdown row per count for
# docs/performance.md. Each run is capped (FRAMES frames, TIMEOUT seconds):
# on a fast GPU the whole script takes about a minute, most of it Bevy's
# start-up.
#
#   bevy/bench-device.sh [FLAGS_BINARY]
#
# FLAGS_BINARY defaults to target/release/examples/flags (built with
# `cargo +nightly build --release -p wgcloth-bevy --ignore-rust-version
# --example flags`; it needs no asset files and no X libraries headless,
# only a Vulkan driver). FRAMES (default 200; the first ten are left out
# of each median), TIMEOUT (default 60 s a run) and COUNTS (default
# "1 16 64") may be set.
set -eu
flags=${1:-target/release/examples/flags}
frames=${FRAMES:-200}
limit=${TIMEOUT:-60}
counts=${COUNTS:-1 16 64}
if [ ! -x "$flags" ]; then
    echo "bench-device.sh: no flags binary at $flags (build it, or name it)" >&2
    exit 2
fi
# The median in ms from a run's timing line, or "-" if it printed none
# (failed or timed out: its output is shown).
median() {
    out=$(timeout "$limit" "$flags" --frames "$frames" "$@" 2>&1) || true
    line=$(printf '%s\n' "$out" | grep 'median frame' || true)
    if [ -z "$line" ]; then
        printf '%s\n' "$out" | tail -5 >&2
        echo "-"
        return
    fi
    echo "$line" >&2
    echo "$line" | sed 's/.*median frame \([0-9.]*\) ms.*/\1/'
}
rows=""
for n in $counts; do
    bevy=$(median --headless --count "$n")
    paused=$(median --headless --paused --count "$n")
    alone=$(median --standalone --count "$n")
    row=$(awk -v n="$n" -v b="$bevy" -v p="$paused" -v s="$alone" 'BEGIN {
        if (b == "-" || p == "-" || s == "-" || s == 0) { r = "-"; q = "-" }
        else { r = sprintf("%.2f", b / s); q = sprintf("%.2f", (b - p) / s) }
        printf "| %d | %s ms | %s ms | %s ms | %s | %s |", n, b, p, s, r, q
    }')
    rows="$rows$row
"
done
echo
echo "| flags | Bevy + plugin | Bevy, paused (drawing only) | standalone batch | ratio Bevy / standalone | stepping in Bevy / standalone |"
echo "| ---: | ---: | ---: | ---: | ---: | ---: |"
printf '%s' "$rows"
