//! Writes the built-in scenes' mesh files: `scenes/tablecloth.obj` (a round
//! cloth, an irregular triangulation in rings), `scenes/banner.gltf` (a
//! banner with a round hole, triangles graded towards the hole, its buffer
//! embedded) and `scenes/table.obj` (a closed table, top and four legs: a
//! mesh collider) and `scenes/cape_detail.obj` (the `cape` scene's render
//! mesh: a slab of fabric 3 mm thick over its 15 × 25 cloth, four times
//! finer, with a hem of double thickness along its bottom) and
//! `scenes/skirt_front.obj`, `scenes/skirt_back.obj` (the `skirt` scene's
//! two panels, halves of a cone around a waist). Deterministic:
//! the same files on every run and machine.
//!
//! `cargo run --release --example make_meshes [OUT_DIR]` (default `scenes`)

use std::f64::consts::TAU;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Context as _;
use base64::Engine as _;

/// The `cape` scene's cloth (`scenes/cape.toml`): a vertical grid whose
/// top-left corner is `CAPE_ORIGIN`, `CAPE_SIZE` wide and tall \[m\], x to
/// the right and y down its rows, facing +z; `CAPE_CELLS` cells across and
/// down.
const CAPE_ORIGIN: [f64; 3] = [-0.28, 1.42, -0.2];
const CAPE_SIZE: [f64; 2] = [0.56, 0.95];
const CAPE_CELLS: [usize; 2] = [14, 24];
/// Render vertices per cloth cell along each side.
const CAPE_FINE: usize = 4;
/// Half the fabric's thickness \[m\], and the hem's (folded: double) along
/// the bottom `CAPE_HEM` metres.
const CAPE_HALF_THICKNESS: f64 = 0.0015;
const CAPE_HEM: f64 = 0.03;

/// The `skirt` scene's two panels: halves of a cone around the waist of
/// the `cape` character (y up, facing +z), from `SKIRT_WAIST` (height and
/// radius \[m\]) down to `SKIRT_HEM`; `SKIRT_CELLS` cells around each half
/// and down. The halves meet at their sides (x = ±radius, z = 0), where
/// the scene's seams join them.
const SKIRT_WAIST: [f64; 2] = [0.95, 0.2];
const SKIRT_HEM: [f64; 2] = [0.45, 0.32];
const SKIRT_CELLS: [usize; 2] = [12, 10];

/// Rings of the tablecloth around its centre vertex.
const TABLECLOTH_RINGS: usize = 14;
/// The tablecloth's radius \[m\].
const TABLECLOTH_RADIUS: f64 = 0.7;

/// The banner's width and height \[m\] (x to the right, y up, its top-left
/// corner at the origin).
const BANNER_SIZE: [f64; 2] = [1.6, 1.0];
/// The hole's centre (from the top-left corner) and radius \[m\].
const HOLE: ([f64; 2], f64) = ([1.0, -0.5], 0.2);
/// Vertices around the hole, and rings from the hole out to the border:
/// cells of at least ~2.5 cm, so the explicit integrator stays stable at
/// the built-in scenes' 1 ms step.
const BANNER_AROUND: usize = 48;
const BANNER_RINGS: usize = 8;

/// A number in `[-0.5, 0.5)` from `seed`: a fixed hash (splitmix64), so the
/// meshes are irregular yet the same on every run.
fn jitter(seed: u64) -> f64 {
    let mut z = seed.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64 - 0.5
}

/// Triangles between two closed rings of vertex indices (angles
/// increasing), walking both and always advancing the one whose next
/// vertex comes first: triangles of uneven size where the counts differ.
fn stitch(inner: &[(u32, f64)], outer: &[(u32, f64)], out: &mut Vec<[u32; 3]>) {
    let (m, n) = (inner.len(), outer.len());
    let (mut i, mut o) = (0, 0);
    // Angles unwrapped past 2π for the last wrap-around step.
    let angle =
        |ring: &[(u32, f64)], k: usize| ring[k % ring.len()].1 + TAU * (k / ring.len()) as f64;
    while i < m || o < n {
        let advance_inner = o == n || (i < m && angle(inner, i + 1) < angle(outer, o + 1));
        if advance_inner {
            out.push([inner[i % m].0, inner[(i + 1) % m].0, outer[o % n].0]);
            i += 1;
        } else {
            out.push([inner[i % m].0, outer[(o + 1) % n].0, outer[o % n].0]);
            o += 1;
        }
    }
}

/// Flips triangles so each faces `+axis` (1: +y, 2: +z).
fn orient(positions: &[[f64; 3]], triangles: &mut [[u32; 3]], axis: usize) {
    for t in triangles.iter_mut() {
        let [a, b, c] = t.map(|p| positions[p as usize]);
        let (u, v) = (
            [0, 1, 2].map(|k| b[k] - a[k]),
            [0, 1, 2].map(|k| c[k] - a[k]),
        );
        let normal = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        if normal[axis] < 0.0 {
            t.swap(1, 2);
        }
    }
}

/// The round tablecloth in the xz-plane, centred on the origin: a centre
/// vertex and rings of 6k vertices at jittered angles and radii.
fn tablecloth() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let mut positions = vec![[0.0; 3]];
    let mut rings: Vec<Vec<(u32, f64)>> = vec![vec![(0, 0.0)]];
    for k in 1..=TABLECLOTH_RINGS {
        let count = 6 * k;
        let border = k == TABLECLOTH_RINGS;
        let mut ring = Vec::new();
        for j in 0..count {
            let seed = (k * 1000 + j) as u64;
            let angle = (j as f64 + 0.35 * jitter(seed)) / count as f64 * TAU;
            // The border stays a circle; inside, radii wander by a third
            // of a ring.
            let dr = if border { 0.0 } else { 0.33 * jitter(seed + 7) };
            let r = TABLECLOTH_RADIUS * (k as f64 + dr) / TABLECLOTH_RINGS as f64;
            ring.push((positions.len() as u32, angle));
            positions.push([r * angle.cos(), 0.0, r * angle.sin()]);
        }
        rings.push(ring);
    }
    let mut triangles = Vec::new();
    // The centre's fan, then ring to ring.
    let first = &rings[1];
    for j in 0..first.len() {
        triangles.push([0, first[j].0, first[(j + 1) % first.len()].0]);
    }
    for k in 1..TABLECLOTH_RINGS {
        stitch(&rings[k], &rings[k + 1], &mut triangles);
    }
    orient(&positions, &mut triangles, 1);
    (positions, triangles)
}

/// The banner in the xy-plane (top-left corner at the origin, hanging to
/// −y) with a round hole: rings from the hole's rim out to the rectangle,
/// evenly spaced along each ray, so triangles are small at the rim and
/// large towards the far corners.
fn banner() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let ([cx, cy], radius) = HOLE;
    let [w, h] = BANNER_SIZE;
    let mut positions = Vec::new();
    for ring in 0..=BANNER_RINGS {
        let s = ring as f64 / BANNER_RINGS as f64;
        for j in 0..BANNER_AROUND {
            let angle = j as f64 / BANNER_AROUND as f64 * TAU;
            let (dx, dy) = (angle.cos(), angle.sin());
            // Where the ray from the centre leaves the rectangle.
            let tx = if dx > 0.0 {
                (w - cx) / dx
            } else if dx < 0.0 {
                -cx / dx
            } else {
                f64::INFINITY
            };
            let ty = if dy > 0.0 {
                -cy / dy
            } else if dy < 0.0 {
                (-h - cy) / dy
            } else {
                f64::INFINITY
            };
            let t = tx.min(ty);
            let r = radius + s * (t - radius);
            positions.push([cx + r * dx, cy + r * dy, 0.0]);
        }
    }
    let id = |ring: usize, j: usize| (ring * BANNER_AROUND + j % BANNER_AROUND) as u32;
    let mut triangles = Vec::new();
    for ring in 0..BANNER_RINGS {
        for j in 0..BANNER_AROUND {
            let (a, b) = (id(ring, j), id(ring, j + 1));
            let (c, d) = (id(ring + 1, j), id(ring + 1, j + 1));
            // Alternate the diagonal so the triangulation has no bias.
            if (ring + j) % 2 == 0 {
                triangles.push([a, b, d]);
                triangles.push([a, d, c]);
            } else {
                triangles.push([a, b, c]);
                triangles.push([b, d, c]);
            }
        }
    }
    orient(&positions, &mut triangles, 2);
    (positions, triangles)
}

fn obj(positions: &[[f64; 3]], triangles: &[[u32; 3]], what: &str) -> String {
    let mut out = format!(
        "# {what}\n# Generated by examples/make_meshes.rs; do not edit.\n# {} vertices, {} triangles\n",
        positions.len(),
        triangles.len()
    );
    for p in positions {
        let _ = writeln!(out, "v {} {} {}", p[0], p[1], p[2]);
    }
    for t in triangles {
        let _ = writeln!(out, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    out
}

/// A glTF 2.0 file with one mesh `name` of one triangle primitive, its
/// buffer (positions as f32, then indices as u32) embedded as base64.
fn gltf(positions: &[[f64; 3]], triangles: &[[u32; 3]], name: &str) -> String {
    let mut bytes = Vec::new();
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in positions {
        for k in 0..3 {
            let x = p[k] as f32;
            lo[k] = lo[k].min(x);
            hi[k] = hi[k].max(x);
            bytes.extend_from_slice(&x.to_le_bytes());
        }
    }
    let position_bytes = bytes.len();
    for i in triangles.iter().flatten() {
        bytes.extend_from_slice(&i.to_le_bytes());
    }
    let index_bytes = bytes.len() - position_bytes;
    let data = base64::engine::general_purpose::STANDARD.encode(&bytes);
    format!(
        r#"{{
  "asset": {{ "version": "2.0", "generator": "wgcloth examples/make_meshes.rs" }},
  "scene": 0,
  "scenes": [{{ "nodes": [0] }}],
  "nodes": [{{ "mesh": 0 }}],
  "meshes": [{{ "name": "{name}", "primitives": [{{ "attributes": {{ "POSITION": 0 }}, "indices": 1, "mode": 4 }}] }}],
  "accessors": [
    {{ "bufferView": 0, "componentType": 5126, "count": {}, "type": "VEC3", "min": {lo:?}, "max": {hi:?} }},
    {{ "bufferView": 1, "componentType": 5125, "count": {}, "type": "SCALAR" }}
  ],
  "bufferViews": [
    {{ "buffer": 0, "byteOffset": 0, "byteLength": {position_bytes}, "target": 34962 }},
    {{ "buffer": 0, "byteOffset": {position_bytes}, "byteLength": {index_bytes}, "target": 34963 }}
  ],
  "buffers": [{{ "byteLength": {}, "uri": "data:application/octet-stream;base64,{data}" }}]
}}
"#,
        positions.len(),
        3 * triangles.len(),
        bytes.len()
    )
}

/// The table's box lines \[m\] along x, y and z: a 1.2 × 0.8 m top 4 cm
/// thick at 0.72–0.76 m on four 6 cm legs.
const TABLE_X: [f64; 4] = [-0.6, -0.54, 0.54, 0.6];
const TABLE_Y: [f64; 3] = [0.0, 0.72, 0.76];
const TABLE_Z: [f64; 4] = [-0.4, -0.34, 0.34, 0.4];

/// The table: the boundary of a union of boxes of the grid the lines
/// above make (the top layer whole, the lower layer at its corners), each
/// face two triangles wound outward; boxes that touch share whole faces,
/// so the mesh is closed and every edge has two faces.
fn table() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let lines = [&TABLE_X[..], &TABLE_Y[..], &TABLE_Z[..]];
    let n = [3i32, 2, 3];
    let filled = |c: [i32; 3]| {
        (0..3).all(|a| (0..n[a]).contains(&c[a])) && (c[1] == 1 || (c[0] != 1 && c[2] != 1))
    };
    let mut index = std::collections::BTreeMap::new();
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    let mut vertex = |c: [i32; 3]| {
        *index.entry(c).or_insert_with(|| {
            positions.push([0, 1, 2].map(|a| lines[a][c[a] as usize]));
            (positions.len() - 1) as u32
        })
    };
    for i in 0..n[0] {
        for j in 0..n[1] {
            for k in 0..n[2] {
                let cell = [i, j, k];
                if !filled(cell) {
                    continue;
                }
                for d in 0..3 {
                    let (u, v) = ((d + 1) % 3, (d + 2) % 3);
                    let step = |mut c: [i32; 3], a: usize| {
                        c[a] += 1;
                        c
                    };
                    for outward in [true, false] {
                        let mut next = cell;
                        next[d] += if outward { 1 } else { -1 };
                        if filled(next) {
                            continue;
                        }
                        let p = if outward { step(cell, d) } else { cell };
                        let ring = if outward {
                            [p, step(p, u), step(step(p, u), v), step(p, v)]
                        } else {
                            [p, step(p, v), step(step(p, u), v), step(p, u)]
                        };
                        let q = ring.map(&mut vertex);
                        triangles.push([q[0], q[1], q[2]]);
                        triangles.push([q[0], q[2], q[3]]);
                    }
                }
            }
        }
    }
    (positions, triangles)
}

/// The cape's render mesh: a front and a back layer over the cloth's rest
/// rectangle, `CAPE_HALF_THICKNESS` either side of it (twice that in the
/// hem), joined along their border into a closed slab.
fn cape_detail() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let (nx, ny) = (CAPE_CELLS[0] * CAPE_FINE + 1, CAPE_CELLS[1] * CAPE_FINE + 1);
    let mut positions = Vec::with_capacity(2 * nx * ny);
    let mut triangles = Vec::new();
    for side in [1.0, -1.0] {
        for j in 0..ny {
            for i in 0..nx {
                let down = j as f64 / (ny - 1) as f64 * CAPE_SIZE[1];
                let hem = if CAPE_SIZE[1] - down <= CAPE_HEM {
                    2.0
                } else {
                    1.0
                };
                positions.push([
                    CAPE_ORIGIN[0] + i as f64 / (nx - 1) as f64 * CAPE_SIZE[0],
                    CAPE_ORIGIN[1] - down,
                    CAPE_ORIGIN[2] + side * hem * CAPE_HALF_THICKNESS,
                ]);
            }
        }
    }
    let at = |layer: usize, i: usize, j: usize| (layer * nx * ny + j * nx + i) as u32;
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            // The front faces +z (as the cloth's triangles do), the back -z.
            let cell =
                |layer| [(0, 0), (1, 0), (0, 1), (1, 1)].map(|(di, dj)| at(layer, i + di, j + dj));
            let [a, b, c, d] = cell(0);
            triangles.extend([[a, c, b], [b, c, d]]);
            let [a, b, c, d] = cell(1);
            triangles.extend([[a, b, c], [b, d, c]]);
        }
    }
    // The border, once around (clockwise seen from the front), each edge
    // joined to its twin on the back by a quad facing outwards.
    let mut border = Vec::new();
    border.extend((0..nx - 1).map(|i| (i, 0)));
    border.extend((0..ny - 1).map(|j| (nx - 1, j)));
    border.extend((1..nx).rev().map(|i| (i, ny - 1)));
    border.extend((1..ny).rev().map(|j| (0, j)));
    for k in 0..border.len() {
        let ((i0, j0), (i1, j1)) = (border[k], border[(k + 1) % border.len()]);
        let [f0, f1, b0, b1] = [at(0, i0, j0), at(0, i1, j1), at(1, i0, j0), at(1, i1, j1)];
        triangles.extend([[f0, b0, f1], [f1, b0, b1]]);
    }
    (positions, triangles)
}

/// One panel of the skirt: the half of the cone in front of the waist
/// (`front`: z > 0) or behind it, a grid of quads around and down, each
/// split into two triangles facing outwards.
fn skirt_panel(front: bool) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let [around, down] = SKIRT_CELLS;
    let start = if front { 0.0 } else { TAU / 2.0 };
    let mut positions = Vec::with_capacity((around + 1) * (down + 1));
    for j in 0..=down {
        let f = j as f64 / down as f64;
        let y = SKIRT_WAIST[0] + f * (SKIRT_HEM[0] - SKIRT_WAIST[0]);
        let r = SKIRT_WAIST[1] + f * (SKIRT_HEM[1] - SKIRT_WAIST[1]);
        for i in 0..=around {
            let a = start + i as f64 / around as f64 * (TAU / 2.0);
            positions.push([r * a.cos(), y, r * a.sin()]);
        }
    }
    let at = |i: usize, j: usize| (j * (around + 1) + i) as u32;
    let mut triangles = Vec::with_capacity(2 * around * down);
    for j in 0..down {
        for i in 0..around {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1));
            triangles.extend([[a, b, c], [b, d, c]]);
        }
    }
    (positions, triangles)
}

/// Writes a mesh file and says what it holds.
fn write(
    path: &Path,
    text: &str,
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
) -> anyhow::Result<()> {
    std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))?;
    println!(
        "{}: {} vertices, {} triangles",
        path.display(),
        positions.len(),
        triangles.len()
    );
    Ok(())
}

fn main() -> anyhow::Result<()> {
    let dir = PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "scenes".to_string()),
    );
    let (p, t) = tablecloth();
    let text = obj(&p, &t, "A round tablecloth, 1.4 m across, in the xz-plane.");
    write(&dir.join("tablecloth.obj"), &text, &p, &t)?;
    let (p, t) = table();
    let text = obj(
        &p,
        &t,
        "A table, 1.2 × 0.8 m, 0.76 m high: a closed mesh (a collider).",
    );
    write(&dir.join("table.obj"), &text, &p, &t)?;
    let (p, t) = cape_detail();
    let text = obj(
        &p,
        &t,
        "The cape scene's render mesh: its cloth as a slab 3 mm thick, with a hem.",
    );
    write(&dir.join("cape_detail.obj"), &text, &p, &t)?;
    for (front, name, what) in [
        (true, "skirt_front.obj", "front"),
        (false, "skirt_back.obj", "back"),
    ] {
        let (p, t) = skirt_panel(front);
        let text = obj(
            &p,
            &t,
            &format!("The skirt scene's {what} panel: half a cone around the waist."),
        );
        write(&dir.join(name), &text, &p, &t)?;
    }
    let (p, t) = banner();
    write(&dir.join("banner.gltf"), &gltf(&p, &t, "banner"), &p, &t)
}
