#!/usr/bin/env bash
# Builds the web page into DIR: `bash web/build.sh DIR` (from anywhere).
# DIR gets index.html, main.js and pkg/ (the wasm module and its
# JavaScript glue); serve it over HTTP (see docs/web.md).
#
# Tool chain: cargo for the wasm module, then wasm-bindgen-cli for its
# glue. wasm-bindgen's CLI must be exactly the version of the
# `wasm-bindgen` crate the module was built with (the glue and the
# module's custom section are one format, checked at generation): the
# version is read from Cargo.lock and installed if missing. Plain
# wasm-bindgen rather than trunk or wasm-pack: one small tool pinned by
# the lock file, no bundler and no download of its own.
set -euo pipefail

if [ $# -ne 1 ]; then
    echo "usage: bash web/build.sh DIR" >&2
    exit 2
fi
out=$1
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"

# The version of the `wasm-bindgen` crate in the lock file.
version=$(awk '/^name = "wasm-bindgen"$/ { getline; gsub(/"/, "", $3); print $3; exit }' Cargo.lock)
if [ -z "$version" ]; then
    echo "error: Cargo.lock names no wasm-bindgen version" >&2
    exit 1
fi

rustup target list --installed 2>/dev/null | grep -qx wasm32-unknown-unknown ||
    rustup target add wasm32-unknown-unknown

have=$(wasm-bindgen --version 2>/dev/null | awk '{ print $2 }' || true)
if [ "$have" != "$version" ]; then
    echo "installing wasm-bindgen-cli $version (found: ${have:-none})"
    # --locked takes the CLI's own lock file; if the registry lacks one of
    # its pinned versions, the newest compatible ones are taken instead.
    # No default features: they are the TLS stack (rustls, ring) that only
    # wasm-bindgen-test-runner uses to download browser drivers, and a
    # good part of the install's compile time.
    cargo install wasm-bindgen-cli --version "$version" --locked --no-default-features ||
        cargo install wasm-bindgen-cli --version "$version" --no-default-features
fi

cargo build --release --target wasm32-unknown-unknown -p wgcloth-web
target_dir=$(cargo metadata --format-version 1 --no-deps |
    sed -n 's/.*"target_directory":"\([^"]*\)".*/\1/p')
mkdir -p "$out/pkg"
wasm-bindgen --target web --no-typescript --out-dir "$out/pkg" \
    "$target_dir/wasm32-unknown-unknown/release/wgcloth_web.wasm"
cp web/index.html web/main.js "$out/"
echo "built the page into $out ($(du -sh "$out" | cut -f1)); serve it, e.g.:"
echo "  python3 -m http.server --directory $out 8000   # then open http://localhost:8000/"
