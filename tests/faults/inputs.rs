//! Fault rows: scene and mesh inputs. A mesh reads only its own files (a
//! glTF buffer's `uri` stays in the mesh's folder, links followed), and a
//! scene or mesh the solvers could not hold is refused when it loads, in
//! the file's own terms: the scene's pin syntax, the key, what is allowed,
//! never a Rust type or a NaN found later. Each row writes its files into a
//! fresh directory, runs `wgcloth run scene.toml` there with its outputs
//! named into it, and checks the status, the message and what is on disk.

use std::path::Path;
use std::process::{Command, Output};

use crate::cli_common::{stderr, TempDir, BIN};
use crate::{refusal_faults, CUBE_OBJ};

/// A file of a row's directory.
#[derive(Clone)]
enum Entry {
    /// A file with these bytes.
    File(&'static str, Vec<u8>),
    /// A symbolic link to the target.
    Link(&'static str, &'static str),
    /// A folder.
    Folder(&'static str),
}

use Entry::{File, Folder, Link};

struct Row {
    what: &'static str,
    files: Vec<Entry>,
    /// What the message must contain: the file, the key or place, what is
    /// allowed.
    expect: &'static [&'static str],
    /// What it must not contain.
    absent: &'static [&'static str],
}

/// The outputs every row names, so that a refusal that still wrote
/// something shows up in its directory.
const RUN_OUT: [&str; 4] = [
    "--positions-out",
    "positions.txt",
    "--trace-out",
    "trace.csv",
];

/// Rust's words for a value's type, which no message may show.
const RUST_WORDS: [&str; 6] = [
    "i128",
    "u128",
    "struct",
    "expected unit",
    "Corner(",
    "Region(",
];

/// A right triangle of side 1 m: the vertices of the rows' meshes, as
/// `f32` little-endian bytes (the glTF buffer).
fn triangle_bytes() -> Vec<u8> {
    [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
        .iter()
        .flatten()
        .flat_map(|x| x.to_le_bytes())
        .collect()
}

/// The glTF JSON of that triangle, its buffer read from `uri` (none: the
/// GLB binary chunk), `extras` (a JSON value, or nothing) on the asset,
/// the mesh, the primitive, the accessor and the buffer.
fn gltf_json(uri: Option<&str>, extras: Option<&str>) -> String {
    let extras = extras.map_or(String::new(), |e| format!(", \"extras\": {e}"));
    let uri = uri.map_or(String::new(), |u| format!(", \"uri\": \"{u}\""));
    format!(
        r#"{{"asset": {{"version": "2.0"{extras}}},
 "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "mode": 4{extras}}}]{extras}}}],
 "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
   "min": [0, 0, 0], "max": [1, 1, 0]{extras}}}],
 "bufferViews": [{{"buffer": 0, "byteLength": 36}}],
 "buffers": [{{"byteLength": 36{uri}{extras}}}]}}"#
    )
}

/// A GLB file of the triangle: header, JSON chunk, binary chunk.
fn glb() -> Vec<u8> {
    let mut json = gltf_json(None, None).into_bytes();
    json.resize(json.len().next_multiple_of(4), b' ');
    let bin = triangle_bytes();
    let length = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::new();
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((length as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(json);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(bin);
    out
}

/// The scene of a mesh cloth read from `mesh`, then `more` lines.
fn mesh_scene(mesh: &str, more: &str) -> Entry {
    File(
        "scene.toml",
        format!("[cloth]\nmesh = \"{mesh}\"\n{more}").into_bytes(),
    )
}

/// A scene file of this text.
fn scene(text: &str) -> Entry {
    File("scene.toml", text.as_bytes().to_vec())
}

/// `mesh/m.gltf` reading its buffer from `uri`, beside a valid buffer in
/// `outside/` that a confined mesh must not reach (were it read, the run
/// would succeed and write its outputs).
fn confined(uri: &str) -> Vec<Entry> {
    vec![
        Folder("mesh"),
        Folder("outside"),
        File("outside/secret.bin", triangle_bytes()),
        File("mesh/m.gltf", gltf_json(Some(uri), None).into_bytes()),
        mesh_scene("mesh/m.gltf", ""),
    ]
}

/// A GLB `mesh/m.glb` of these bytes.
fn glb_file(bytes: Vec<u8>) -> Vec<Entry> {
    vec![
        Folder("mesh"),
        File("mesh/m.glb", bytes),
        mesh_scene("mesh/m.glb", ""),
    ]
}

/// An OBJ `mesh/m.obj` of this text, the scene adding `more`.
fn obj(text: &str, more: &str) -> Vec<Entry> {
    vec![
        Folder("mesh"),
        File("mesh/m.obj", text.as_bytes().to_vec()),
        mesh_scene("mesh/m.obj", more),
    ]
}

/// The triangle as an OBJ.
const TRIANGLE_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

/// Cubes of half-side `half` about `centre` as one OBJ, each wound
/// outward or, where `inward`, inside out.
fn cubes(pieces: &[([f64; 3], f64, bool)]) -> String {
    let mut obj = String::new();
    let mut faces = String::new();
    for (n, &(c, half, inward)) in pieces.iter().enumerate() {
        for k in 0..8 {
            let at = |bit: usize, axis: usize| c[axis] + if k & bit == 0 { -half } else { half };
            obj.push_str(&format!("v {} {} {}\n", at(1, 0), at(2, 1), at(4, 2)));
        }
        for q in [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ] {
            let mut q = q.map(|i| i + 8 * n + 1);
            if inward {
                q.reverse();
            }
            faces.push_str(&format!("f {} {} {} {}\n", q[0], q[1], q[2], q[3]));
        }
    }
    obj + &faces
}

/// A scene of a 5 × 5 cloth over the collider `mesh/m.obj` of this text,
/// its `[[collider]]` table adding `more` lines.
fn collider(text: &str, more: &str) -> Vec<Entry> {
    vec![
        Folder("mesh"),
        File("mesh/m.obj", text.as_bytes().to_vec()),
        scene(&format!(
            "[cloth]\nresolution = [5, 5]\n\n[[collider]]\nmesh = \"mesh/m.obj\"\n{more}"
        )),
    ]
}

/// A right triangle with legs of 1e200 (file units).
const HUGE_OBJ: &str = "v 0 0 0\nv 1e200 0 0\nv 0 1e200 0\nf 1 2 3\n";

/// A character with one capsule, then `more` lines.
fn character(capsule_more: &str, second_key: &str) -> Entry {
    File(
        "scene.toml",
        format!(
            "[cloth]\nresolution = [5, 5]\n\n[character]\n\n[[character.capsule]]\n\
             a = [0, 0, 0]\nb = [0, 1, 0]\nradius = 0.1\n{capsule_more}\n\
             [[character.key]]\ntime = 0\nposition = [0, 0, 0]\n\n\
             [[character.key]]\ntime = 1\nposition = {second_key}\n"
        )
        .into_bytes(),
    )
}

fn refused_rows() -> Vec<Row> {
    let truncated = {
        let mut g = glb();
        g.truncate(40);
        g
    };
    let long_json_chunk = {
        let mut g = glb();
        g[12..16].copy_from_slice(&1_000_000u32.to_le_bytes());
        g
    };
    let long_header = {
        let mut g = glb();
        let length = g.len() as u32 + 4;
        g[8..12].copy_from_slice(&length.to_le_bytes());
        g
    };
    let short_header = b"glTF\x02\x00\x00\x00".to_vec();
    vec![
        Row {
            what: "an absolute buffer uri",
            files: confined("/etc/passwd"),
            expect: &[
                "mesh file mesh/m.gltf",
                "`buffers[0].uri`",
                "`/etc/passwd` is an absolute path",
                "its own folder",
            ],
            absent: &[],
        },
        Row {
            what: "a buffer uri whose .. leaves the folder",
            files: confined("../outside/secret.bin"),
            expect: &[
                "mesh file mesh/m.gltf",
                "`buffers[0].uri`",
                "`..` leads out of the mesh's folder",
            ],
            absent: &[],
        },
        Row {
            what: "a percent-encoded .. that leaves the folder",
            files: confined("%2E%2E/outside/secret.bin"),
            expect: &["`../outside/secret.bin`", "leads out of the mesh's folder"],
            absent: &[],
        },
        Row {
            what: "a buffer behind a link out of the folder",
            files: [
                confined("link.bin"),
                vec![Link("mesh/link.bin", "../outside/secret.bin")],
            ]
            .concat(),
            expect: &[
                "`buffers[0].uri`",
                "`link.bin` is (or goes through) a symbolic link",
                "outside/secret.bin",
                "outside the mesh's folder",
            ],
            absent: &[],
        },
        Row {
            what: "a buffer through a linked folder out of the folder",
            files: [
                confined("sub/secret.bin"),
                vec![Link("mesh/sub", "../outside")],
            ]
            .concat(),
            expect: &["`sub/secret.bin` is (or goes through) a symbolic link"],
            absent: &[],
        },
        Row {
            what: "a file: URI",
            files: confined("file:///etc/passwd"),
            expect: &["`file:///etc/passwd` is a `file:` URI", "its own folder"],
            absent: &[],
        },
        Row {
            what: "a broken percent escape",
            files: confined("m%zz.bin"),
            expect: &["`m%zz.bin`", "two hexadecimal digits", "%20"],
            absent: &[],
        },
        Row {
            what: "a GLB cut short inside its JSON chunk",
            files: glb_file(truncated),
            expect: &["mesh file mesh/m.glb", "is truncated", "header says", "40"],
            absent: &["slice"],
        },
        Row {
            what: "a GLB whose JSON chunk claims more than the file holds",
            files: glb_file(long_json_chunk),
            expect: &[
                "mesh file mesh/m.glb",
                "JSON chunk at byte 12 says it holds 1000000 bytes",
                "the chunk's length field is wrong",
            ],
            absent: &["slice", "truncated"],
        },
        Row {
            what: "a whole GLB whose header alone overstates its length",
            files: glb_file(long_header),
            expect: &[
                "mesh file mesh/m.glb",
                "its GLB header says the file has",
                "which its chunks fill exactly",
                "the header's length field is wrong",
            ],
            absent: &["truncated"],
        },
        Row {
            what: "a collider thickness whose lattice count once wrapped past u64",
            files: collider(CUBE_OBJ, "thickness = 1e30\n"),
            expect: &[
                "mesh file mesh/m.obj",
                "`collider[0]`",
                "more than the 16777216 a collider may have",
                "`collider[0].thickness` at most 1.46 m",
            ],
            absent: &["resolution` at most"],
        },
        Row {
            what: "a 1 µm collider under the default thickness",
            files: collider(CUBE_OBJ, "scale = 1e-6\n"),
            expect: &[
                "`collider[0]`",
                "thickness 0.005 m",
                "`collider[0].thickness` at most 1.46e-6 m",
                "the padding, not the mesh, fills the grid",
            ],
            absent: &["resolution` at most", "lower `collider[0].resolution`"],
        },
        Row {
            what: "a collider scale whose cells underflow f32",
            files: collider(CUBE_OBJ, "scale = 1e-40\n"),
            expect: &[
                "scene file scene.toml",
                "`collider[0].scale`",
                "at least 1e-18 m",
                "got 1e-40",
            ],
            absent: &["lattice points"],
        },
        Row {
            what: "a collider scale whose grid is beyond f32",
            files: collider(CUBE_OBJ, "scale = 1e39\n"),
            expect: &[
                "scene file scene.toml",
                "`collider[0].scale`",
                "within ±1e18 m",
                "got 1e39",
            ],
            absent: &[],
        },
        Row {
            what: "a collider resolution beyond u32",
            files: collider(CUBE_OBJ, "resolution = 5000000000\n"),
            expect: &["`collider[0].resolution`", "4 to 512", "got 5000000000"],
            absent: &["4294967295"],
        },
        Row {
            what: "a collider rotation of an infinite angle",
            files: collider(CUBE_OBJ, "rotation = [0, 1, 0, inf]\n"),
            expect: &[
                "`collider[0].rotation[3]`",
                "the angle in degrees",
                "got inf",
            ],
            absent: &[],
        },
        Row {
            what: "a collider rotation of a zero axis",
            files: collider(CUBE_OBJ, "rotation = [0, 0, 0, 90]\n"),
            expect: &[
                "`collider[0].rotation`",
                "an axis other than [0, 0, 0]",
                "got [0, 0, 0, 90]",
            ],
            absent: &[],
        },
        Row {
            what: "a collider mesh with one part wound inside out beside another",
            files: collider(
                &cubes(&[([0.0; 3], 0.5, false), ([2.0, 0.0, 0.0], 0.25, true)]),
                "",
            ),
            expect: &[
                "mesh file mesh/m.obj",
                "part 2 of its 2 parts",
                "first face is on line 23",
                "wound inward",
                "inside no other part",
                "wind that part's faces the other way",
            ],
            absent: &[],
        },
        Row {
            what: "a GLB shorter than its header",
            files: glb_file(short_header),
            expect: &["mesh file mesh/m.glb", "12-byte header", "has 8 bytes"],
            absent: &["could not completely read"],
        },
        Row {
            what: "an OBJ face index beyond 64 bits",
            files: obj(
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999\n",
                "",
            ),
            expect: &[
                "mesh file mesh/m.obj",
                "line 4",
                "face corner 99999999999999999999 is out of range",
                "1..=3",
            ],
            absent: &["does not start with a vertex number"],
        },
        Row {
            what: "a right triangle at 1e200 is too far, not in a line",
            files: obj(HUGE_OBJ, ""),
            expect: &["scene.toml", "`cloth.scale`", "within ±1e18 m", "got 1"],
            absent: &["in a line", "degenerate"],
        },
        Row {
            what: "a mesh scale that overflows",
            files: obj(TRIANGLE_OBJ, "scale = 1e308\n"),
            expect: &[
                "scene file scene.toml",
                "`cloth.scale`",
                "within ±1e18 m",
                "got 1e308",
            ],
            absent: &["NaN"],
        },
        Row {
            what: "a mesh scale that shrinks sides to nothing",
            files: obj(TRIANGLE_OBJ, "scale = 1e-300\n"),
            expect: &[
                "scene file scene.toml",
                "`cloth.scale`",
                "at least 1e-18 m",
                "line 4: vertices 0 and 1",
                "got 1e-300",
            ],
            absent: &["NaN"],
        },
        Row {
            what: "a mesh triangle whose area is no normal f32",
            files: obj("v 0 0 0\nv 1e-13 0 0\nv 5e-14 2.2e-25 0\nf 1 2 3\n", ""),
            expect: &["`cloth.scale`", "smallest normal f32", "line 4"],
            absent: &["NaN"],
        },
        Row {
            what: "a grid too large for f32",
            files: vec![scene(
                "[cloth]\nresolution = [9, 9]\nsize = [1e300, 1e300]\n",
            )],
            expect: &[
                "scene file scene.toml",
                "`cloth.size`",
                "within ±1e18 m",
                "got [1e300, 1e300]",
            ],
            absent: &["NaN", "blew up"],
        },
        Row {
            what: "a grid whose cells vanish beside its origin",
            files: vec![scene(
                "[cloth]\nresolution = [5, 5]\nsize = [1e-300, 1e-300]\n",
            )],
            expect: &[
                "scene file scene.toml",
                "`cloth.size`",
                "f32 spacing",
                "got [1e-300, 1e-300]",
            ],
            absent: &["n/a"],
        },
        Row {
            what: "a corner pin on a mesh",
            files: obj(TRIANGLE_OBJ, "pins = [\"top-left\"]\n"),
            expect: &[
                "`cloth.pins[0]`",
                "a vertex index below 3",
                "got \"top-left\"",
            ],
            absent: &[],
        },
        Row {
            what: "an empty box pin",
            files: vec![scene(
                "[cloth]\npins = [{ box = [[5, 5, 5], [6, 6.5, 6]] }]\n",
            )],
            expect: &[
                "`cloth.pins[0]`",
                "got { box = [[5, 5, 5], [6, 6.5, 6]] }, which holds none",
            ],
            absent: &[],
        },
        Row {
            what: "a boolean written as an integer beyond 64 bits",
            files: vec![scene("[implicit]\ncoarse_levels = 99999999999999999999\n")],
            expect: &[
                "`implicit.coarse_levels`",
                "integer `99999999999999999999`, expected a boolean",
            ],
            absent: &[],
        },
        Row {
            what: "a count beyond 64 bits",
            files: vec![scene("[fixup]\niterations = 99999999999999999999\n")],
            expect: &["`fixup.iterations`", "is too large", "≤ 4294967295"],
            absent: &[],
        },
        Row {
            what: "a pin index beyond 64 bits",
            files: vec![scene("[cloth]\npins = [99999999999999999999]\n")],
            expect: &[
                "`cloth.pins[0]`",
                "pin index 99999999999999999999 is too large",
            ],
            absent: &[],
        },
        Row {
            what: "an integer beyond 128 bits",
            files: vec![scene(
                "[cloth]\nmass = 999999999999999999999999999999999999999999999\n",
            )],
            expect: &["`cloth.mass`", "too large to read", "a float such as 1e40"],
            absent: &["overflowed"],
        },
        Row {
            what: "a character capsule's velocity",
            files: vec![character("velocity = [1, 0, 0]\n", "[1, 0, 0]")],
            expect: &[
                "scene file scene.toml",
                "`character.capsule[0].velocity`",
                "unknown key `velocity`",
                "`a`, `b`, `radius`, `friction`",
            ],
            absent: &[],
        },
        Row {
            what: "a character key beyond f32",
            files: vec![character("", "[1e300, 0, 0]")],
            expect: &[
                "scene file scene.toml",
                "`character.key[1].position[0]`",
                "within ±1e18 m",
                "got 1e300",
            ],
            absent: &["pin target"],
        },
    ]
}

/// Writes a row's files into `dir`.
fn make(dir: &Path, files: &[Entry]) {
    for entry in files {
        match entry {
            File(name, bytes) => std::fs::write(dir.join(name), bytes).expect("write a file"),
            Link(name, target) => {
                std::os::unix::fs::symlink(target, dir.join(name)).expect("make a link");
            }
            Folder(name) => std::fs::create_dir(dir.join(name)).expect("make a folder"),
        }
    }
}

/// `wgcloth run scene.toml --steps 1` in `dir`, its outputs into `dir`.
fn run_in(dir: &Path) -> Output {
    Command::new(BIN)
        .current_dir(dir)
        .args(["run", "scene.toml", "--steps", "1"])
        .args(RUN_OUT)
        .output()
        .expect("run the wgcloth binary")
}

#[test]
fn bad_scenes_and_meshes_are_refused_in_their_own_terms_and_write_nothing() {
    let rows = refused_rows();
    let mut failures = Vec::new();
    for (k, row) in rows.iter().enumerate() {
        let dir = TempDir::new(&format!("inputs-{k}"));
        make(&dir.0, &row.files);
        let before = dir.files();
        let out = run_in(&dir.0);
        let absent = [row.absent, &RUST_WORDS].concat();
        let wrong = refusal_faults(&out, row.expect, &absent, &before, &dir.files());
        if !wrong.is_empty() {
            failures.push(format!(
                "{}: {}\n    stderr: {}",
                row.what,
                wrong.join("; "),
                stderr(&out)
            ));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} rows failed:\n{}",
        failures.len(),
        rows.len(),
        failures.join("\n")
    );
}

/// What glTF 2.0 allows that must load: every JSON type of `extras`,
/// percent-encoded names, `..` and links that stay in the folder, and a
/// mesh far from 1 m that `scale` brings back.
fn accepted_rows() -> Vec<(&'static str, Vec<Entry>)> {
    let mut rows = Vec::new();
    for extras in [
        "{\"a\": 1}",
        "[1, \"two\"]",
        "\"text\"",
        "3.5",
        "true",
        "null",
    ] {
        rows.push((
            extras,
            vec![
                File("tri.bin", triangle_bytes()),
                File(
                    "m.gltf",
                    gltf_json(Some("tri.bin"), Some(extras)).into_bytes(),
                ),
                mesh_scene("m.gltf", ""),
            ],
        ));
    }
    rows.push((
        "a percent-encoded space",
        vec![
            File("mesh sp.bin", triangle_bytes()),
            File(
                "m.gltf",
                gltf_json(Some("mesh%20sp.bin"), None).into_bytes(),
            ),
            mesh_scene("m.gltf", ""),
        ],
    ));
    rows.push((
        "a .. that stays inside and a link inside",
        vec![
            Folder("mesh"),
            Folder("mesh/sub"),
            File("mesh/sub/tri.bin", triangle_bytes()),
            Link("mesh/link", "sub"),
            File(
                "mesh/m.gltf",
                gltf_json(Some("sub/../link/tri.bin"), None).into_bytes(),
            ),
            mesh_scene("mesh/m.gltf", ""),
        ],
    ));
    rows.push(("a GLB", glb_file(glb())));
    rows.push((
        "a right triangle at 1e200 scaled by 1e-200",
        obj(HUGE_OBJ, "scale = 1e-200\n"),
    ));
    rows.push((
        "a hollow collider: a part wound inward inside an outward one",
        collider(
            &cubes(&[([0.0; 3], 0.5, false), ([0.0; 3], 0.25, true)]),
            "",
        ),
    ));
    rows.push((
        "a collider wound inside out throughout",
        collider(&cubes(&[([0.0; 3], 0.5, true)]), ""),
    ));
    rows.push((
        "a collider rotation about a finite, huge axis",
        collider(CUBE_OBJ, "rotation = [1e300, 0, 0, 90]\n"),
    ));
    rows.push((
        "a collider rotation about a tiny, non-zero axis",
        collider(CUBE_OBJ, "rotation = [1e-300, 0, 0, 90]\n"),
    ));
    rows
}

#[test]
fn what_gltf_and_a_scale_allow_loads_and_runs() {
    let mut failures = Vec::new();
    for (k, (what, files)) in accepted_rows().iter().enumerate() {
        let dir = TempDir::new(&format!("inputs-ok-{k}"));
        make(&dir.0, files);
        let out = run_in(&dir.0);
        let written = ["positions.txt", "trace.csv"]
            .iter()
            .all(|f| dir.join(f).is_file());
        if out.status.code() != Some(0) || !written {
            failures.push(format!(
                "{what}: exit status {:?}, outputs written: {written}\n    stderr: {}",
                out.status.code(),
                stderr(&out)
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
