//! Wavefront OBJ: `v` and `f` lines, with line numbers in every message.
//!
//! `v x y z` gives a vertex (a fourth `w` or three colour numbers after the
//! position are allowed and ignored); `f a b c` a triangle and `f a b c d`
//! a quad, each corner `v`, `v/vt`, `v//vn` or `v/vt/vn` with each index
//! 1-based or negative (counted back from the last one so far). `vn x y z`
//! and `vt u v [w]` give the normals and texture coordinates the corners
//! name (a render mesh draws with them; a cloth ignores them). Groups,
//! objects, smoothing groups, materials, lines and points are ignored; any
//! other statement is refused, so a file in another format is not read as
//! an empty mesh.

use glam::DVec3;

use super::{too_many_vertices, Attributes, Face, FacePlace, Mesh};
use crate::model::MAX_PARTICLES;

/// Statements that carry nothing a cloth uses.
const IGNORED: &[&str] = &["vp", "o", "g", "s", "usemtl", "mtllib", "l", "p"];

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
    let mut attributes = Attributes::default();
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
            "vn" => {
                let n = numbers::<3>(&rest, "a normal is `vn x y z`").map_err(at)?;
                attributes.normals.push(DVec3::from_array(n));
            }
            "vt" => {
                let t = numbers::<2>(&rest, "a texture coordinate is `vt u v [w]`").map_err(at)?;
                attributes.uvs.push(t);
            }
            "f" => {
                let pools = [attributes.uvs.len(), attributes.normals.len()];
                let (f, corner_attributes) =
                    face(&rest, positions.len(), pools, line).map_err(at)?;
                faces.push(f);
                attributes.corners.push(corner_attributes);
            }
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
    if attributes
        .corners
        .iter()
        .flatten()
        .all(|c| *c == [Attributes::NONE; 2])
    {
        attributes.corners.clear();
    }
    Ok(Mesh {
        positions,
        faces,
        attributes,
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

/// The first `N` of `words` as finite numbers (`vn`, `vt`; a `vt`'s `w`
/// is ignored).
fn numbers<const N: usize>(words: &[&str], form: &str) -> Result<[f64; N], String> {
    if words.len() < N || words.len() > 3 {
        return Err(format!("{form}, got {} numbers", words.len()));
    }
    let mut out = [0.0; N];
    for (c, (slot, word)) in out.iter_mut().zip(words).enumerate() {
        *slot = word
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("number {c} `{word}` is not a finite number ({form})"))?;
    }
    Ok(out)
}

/// A corner's `vt` or `vn` index (`what`), 1-based or negative, of a pool
/// of `size` so far → 0-based.
fn pool_index(word: &str, size: usize, what: &str) -> Result<u32, String> {
    let i: i64 = word
        .parse()
        .map_err(|_| format!("face corner {what} index `{word}` is not a whole number"))?;
    resolve(i, size).ok_or_else(|| {
        format!(
            "face corner {what} index {word} is out of range: {size} `{what}` lines are \
             above this line"
        )
    })
}

/// An OBJ index `i` into a list of `size` so far, 0-based: 1-based from
/// the start, or negative from the last one; `None` out of range (0
/// included).
fn resolve(i: i64, size: usize) -> Option<u32> {
    let resolved = if i > 0 {
        i - 1
    } else {
        (size as i64).checked_add(i)?
    };
    (i != 0 && (0..size as i64).contains(&resolved)).then_some(resolved as u32)
}

/// `a b c [d]` corners (each `v[/vt][/vn]`) → the face, its indices 0-based,
/// and each corner's `[vt, vn]` (0-based into pools of `pools` = `[vt
/// lines, vn lines]` so far, or [`Attributes::NONE`]).
fn face(
    words: &[&str],
    vertices: usize,
    pools: [usize; 2],
    line: usize,
) -> Result<(Face, [[u32; 2]; 4]), String> {
    if !matches!(words.len(), 3 | 4) {
        return Err(format!(
            "a face is a triangle or a quad (3 or 4 corners), got {} corners; \
             split larger polygons into triangles or quads",
            words.len()
        ));
    }
    let mut corners = [0u32; 4];
    let mut attributes = [[Attributes::NONE; 2]; 4];
    for ((slot, extra), word) in corners.iter_mut().zip(&mut attributes).zip(words) {
        let mut parts = word.split('/');
        let index = parts.next().unwrap_or("");
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
        *slot = resolve(i, vertices).ok_or_else(out_of_range)?;
        for ((k, what), part) in [(0, "vt"), (1, "vn")].into_iter().zip(parts) {
            if !part.is_empty() {
                extra[k] = pool_index(part, pools[k], what)?;
            }
        }
    }
    Ok((
        Face {
            corners,
            quad: words.len() == 4,
            at: line,
        },
        attributes,
    ))
}
