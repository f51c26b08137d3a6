//! Wavefront OBJ: `v` and `f` lines, with line numbers in every message.
//!
//! `v x y z` gives a vertex (a fourth `w` or three colour numbers after the
//! position are allowed and ignored); `f a b c` a triangle and `f a b c d`
//! a quad, each corner `v`, `v/vt`, `v//vn` or `v/vt/vn` with `v` 1-based
//! or negative (counted back from the last vertex so far). Texture
//! coordinates, normals, groups, objects, smoothing groups, materials,
//! lines and points are ignored; any other statement is refused, so a
//! file in another format is not read as an empty mesh.

use glam::DVec3;

use super::{too_many_vertices, Face, FacePlace, Mesh};
use crate::model::MAX_PARTICLES;

/// Statements that carry nothing a cloth uses.
const IGNORED: &[&str] = &[
    "vt", "vn", "vp", "o", "g", "s", "usemtl", "mtllib", "l", "p",
];

/// Parses an OBJ file's bytes into vertices and faces, checking each line.
pub(super) fn parse(bytes: &[u8]) -> Result<Mesh, String> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        format!(
            "is not UTF-8 text (byte {} is not valid), so not an OBJ file",
            e.valid_up_to()
        )
    })?;
    let mut positions = Vec::new();
    let mut faces = Vec::new();
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        let at = |message: String| format!("line {line}: {message}");
        let content = raw.split('#').next().unwrap_or("");
        let mut words = content.split_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        let rest: Vec<&str> = words.collect();
        match keyword {
            "v" => {
                if positions.len() >= MAX_PARTICLES {
                    return Err(at(too_many_vertices(format!("more than {MAX_PARTICLES}"))));
                }
                positions.push(DVec3::from_array(vertex(&rest).map_err(at)?));
            }
            "f" => faces.push(face(&rest, positions.len(), line).map_err(at)?),
            _ if IGNORED.contains(&keyword) => {}
            _ => {
                return Err(at(format!(
                    "unknown statement `{keyword}`: an OBJ mesh has `v` and `f` lines \
                     (and {} ones, which are ignored)",
                    IGNORED.join(", ")
                )))
            }
        }
    }
    Ok(Mesh {
        positions,
        faces,
        place: FacePlace::Obj,
    })
}

/// `x y z [w | r g b]` → the position.
fn vertex(words: &[&str]) -> Result<[f64; 3], String> {
    if !matches!(words.len(), 3 | 4 | 6) {
        return Err(format!(
            "a vertex is `v x y z` (optionally followed by w, or by r g b), got {} numbers",
            words.len()
        ));
    }
    let mut p = [0.0; 3];
    for (c, (slot, word)) in p.iter_mut().zip(words).enumerate() {
        let x: f64 = word
            .parse()
            .map_err(|_| format!("vertex coordinate {c} `{word}` is not a number"))?;
        if !x.is_finite() {
            return Err(format!(
                "vertex coordinate {c} is `{word}`: coordinates must be finite numbers"
            ));
        }
        *slot = x;
    }
    Ok(p)
}

/// `a b c [d]` corners (each `v[/vt][/vn]`) → the face, its indices 0-based.
fn face(words: &[&str], vertices: usize, line: usize) -> Result<Face, String> {
    if !matches!(words.len(), 3 | 4) {
        return Err(format!(
            "a face is a triangle or a quad (3 or 4 corners), got {} corners; \
             split larger polygons into triangles or quads",
            words.len()
        ));
    }
    let mut corners = [0u32; 4];
    for (slot, word) in corners.iter_mut().zip(words) {
        let index = word.split('/').next().unwrap_or("");
        let out_of_range = || {
            format!(
                "face corner {index} is out of range: {vertices} vertices are defined above \
                 this line, so a corner must be 1..={vertices} or -{vertices}..=-1"
            )
        };
        let i: i64 = index.parse().map_err(|_| {
            // A whole number too long for i64 is a vertex number far out
            // of range, not a word that is no number.
            let digits = index.strip_prefix(['-', '+']).unwrap_or(index);
            if !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit()) {
                out_of_range()
            } else {
                format!("face corner `{word}` does not start with a vertex number")
            }
        })?;
        // 1-based from the start, or negative from the last vertex so far.
        let resolved = if i > 0 { i - 1 } else { vertices as i64 + i };
        if i == 0 || resolved < 0 || resolved >= vertices as i64 {
            return Err(out_of_range());
        }
        *slot = resolved as u32;
    }
    Ok(Face {
        corners,
        quad: words.len() == 4,
        at: line,
    })
}
