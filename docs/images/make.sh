#!/usr/bin/env bash
# Regenerates every picture in docs/images from the code, on the adapter the
# tests use (lavapipe here): `bash docs/images/make.sh` from anywhere.
# tests/cli.rs checks that the quick start's last frame still is
# hanging.png, and tests/docs.rs that every picture in docs/images is made
# here. The viewer's screenshot needs an X server: Xvfb (xvfb-run).
set -euo pipefail

cd "$(dirname "$0")/../.."
images=docs/images
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

cargo build --release --bin wgcloth --examples
wgcloth=target/release/wgcloth

# last_frame SCENE: renders the built-in SCENE over its duration and copies
# its last frame to docs/images/SCENE.png.
last_frame() {
    "$wgcloth" render "$1" --out "$work/$1"
    cp "$(ls "$work/$1"/frame_*.png | tail -n 1)" "$images/$1.png"
}

last_frame hanging     # the README's top picture: the quick start's last frame
last_frame tablecloth # a mesh cloth (OBJ)
last_frame banner     # a mesh cloth (glTF) with a hole
last_frame heap       # self-collision: a cloth folded onto itself
last_frame table      # a mesh collider: a tablecloth on a table
last_frame layers     # a world of three cloths, resting on one another
# Seams: the skirt of two sewn panels on the running character, 3 s in.
"$wgcloth" render skirt --seconds 3 --out "$work/skirt"
cp "$(ls "$work/skirt"/frame_*.png | tail -n 1)" "$images/skirt.png"
# A render mesh: the cape's detailed slab over its 15 × 25 cloth, 2 s in.
"$wgcloth" render cape --seconds 2 --out "$work/cape-detail"
cp "$(ls "$work/cape-detail"/frame_*.png | tail -n 1)" "$images/cape-detail.png"

# Warp and weft (docs/materials.md): its woven scene as written there, then
# with warp and weft swapped.
awk '/<!-- the woven scene/ { found = 1 } found && /^```toml/ { inside = 1; next }
     inside && /^```/ { exit } inside' docs/materials.md > "$work/woven-warp.toml"
sed 's/warp = 2.0e-2, weft = 5.0e-3/warp = 5.0e-3, weft = 2.0e-2/' \
    "$work/woven-warp.toml" > "$work/woven-weft.toml"
"$wgcloth" render "$work/woven-warp.toml" --out "$work/woven-warp"
cp "$(ls "$work/woven-warp"/frame_*.png | tail -n 1)" "$images/woven-warp.png"
"$wgcloth" render "$work/woven-weft.toml" --out "$work/woven-weft"
cp "$(ls "$work/woven-weft"/frame_*.png | tail -n 1)" "$images/woven-weft.png"

target/release/examples/cape "$images/cape.png"
target/release/examples/batch "$images/batch.png"
xvfb-run -a target/release/examples/viewer --frames 60 --drag 400,153:620,43 \
    --screenshot "$images/viewer.png"

"$wgcloth" bench accuracy hanging --out "$work/accuracy"
cp "$work/accuracy/accuracy.svg" "$images/accuracy-hanging.svg"
"$wgcloth" bench cantilever --chart "$images/cantilever.svg"
"$wgcloth" bench drape --sizes 9,17,33,65 --chart "$images/drape.svg"  # ~10 min

echo "regenerated: $(ls "$images" | grep -v make.sh | tr '\n' ' ')"
