//! glTF 2.0 (`.gltf` JSON with embedded or external buffers, `.glb`): one
//! triangle primitive's positions and indices.
//!
//! The `gltf` crate parses and validates the JSON (its errors name the JSON
//! path; `extras` of any JSON type are accepted and ignored); a GLB's
//! chunks are split here and the accessors read here, with every offset
//! and length checked against the file or the buffer, so a file that lies
//! about its sizes is an error that names the length, never a panic. Only the chosen primitive's `POSITION` accessor and its
//! indices are read: materials, textures, images, normals and every other
//! attribute, skins, animations, cameras, node transforms and the other
//! meshes and primitives are ignored.

use base64::Engine as _;
use glam::DVec3;
use gltf::accessor::{DataType, Dimensions};
use gltf::buffer::Source;
use gltf::mesh::{Mode, Semantic};

use super::Attributes;
use super::{too_many_vertices, Face, FacePlace, Mesh};
use crate::model::MAX_PARTICLES;

/// Parses a glTF or GLB file's bytes; `mesh_name` picks a mesh (else the
/// first), whose first triangle primitive is the cloth.
pub(super) fn parse(
    bytes: &[u8],
    mesh_name: Option<&str>,
    external: &dyn Fn(&str) -> Result<Vec<u8>, String>,
) -> Result<Mesh, String> {
    let (json, blob) = if bytes.starts_with(b"glTF") {
        split_glb(bytes)?
    } else {
        (bytes, None)
    };
    let root =
        gltf::json::Root::from_slice(json).map_err(|e| describe(gltf::Error::Deserialize(e)))?;
    let file = gltf::Gltf {
        document: gltf::Document::from_json(root).map_err(describe)?,
        blob: blob.map(<[u8]>::to_vec),
    };
    let mesh = match mesh_name {
        Some(name) => file
            .meshes()
            .find(|m| m.name() == Some(name))
            .ok_or_else(|| {
                let names: Vec<String> = file
                    .meshes()
                    .map(|m| match m.name() {
                        Some(n) => format!("`{n}`"),
                        None => format!("meshes[{}] (no name)", m.index()),
                    })
                    .collect();
                format!(
                    "`cloth.mesh_name`: no mesh named `{name}`; the file's meshes are: {}",
                    if names.is_empty() {
                        "none".to_string()
                    } else {
                        names.join(", ")
                    }
                )
            })?,
        None => file
            .meshes()
            .next()
            .ok_or("`meshes`: the file has no mesh; a cloth needs one with triangles")?,
    };
    let primitive = mesh
        .primitives()
        .find(|p| p.mode() == Mode::Triangles)
        .ok_or_else(|| {
            format!(
                "`meshes[{}].primitives`: no primitive of mode 4 (triangles); strips, fans, \
                 lines and points are not read",
                mesh.index()
            )
        })?;
    let place = format!("meshes[{}].primitives[{}]", mesh.index(), primitive.index());
    let buffers = load_buffers(&file, external)?;
    let positions = primitive
        .get(&Semantic::Positions)
        .ok_or_else(|| format!("`{place}.attributes`: no POSITION attribute, so no vertices"))?;
    let count = positions.count();
    if count > MAX_PARTICLES {
        return Err(format!(
            "`accessors[{}]` (POSITION) {}",
            positions.index(),
            too_many_vertices(count)
        ));
    }
    let raw = read(&positions, &buffers, DataType::F32, Dimensions::Vec3)?;
    let positions_path = format!("accessors[{}]", positions.index());
    let mut xyz = Vec::with_capacity(count);
    for (v, p) in raw.chunks_exact(3).enumerate() {
        let p = [p[0], p[1], p[2]].map(|w| f64::from(f32::from_bits(w)));
        if !p.iter().all(|c| c.is_finite()) {
            return Err(format!(
                "`{positions_path}`: vertex {v} is {p:?}: coordinates must be finite numbers"
            ));
        }
        xyz.push(DVec3::from_array(p));
    }
    let indices = match primitive.indices() {
        Some(accessor) => {
            let data_type = accessor.data_type();
            if !matches!(data_type, DataType::U8 | DataType::U16 | DataType::U32) {
                return Err(format!(
                    "`accessors[{}]` (indices): component type {data_type:?}; indices are \
                     unsigned bytes, shorts or ints",
                    accessor.index()
                ));
            }
            read(&accessor, &buffers, data_type, Dimensions::Scalar)?
        }
        // Without indices, the vertices in order make the triangles.
        None => (0..count as u32).collect(),
    };
    if indices.len() % 3 != 0 {
        return Err(format!(
            "`{place}.indices`: {} indices is not a whole number of triangles",
            indices.len()
        ));
    }
    let mut faces = Vec::with_capacity(indices.len() / 3);
    for (t, tri) in indices.chunks_exact(3).enumerate() {
        if let Some(&bad) = tri.iter().find(|&&i| i as usize >= count) {
            return Err(format!(
                "`{place}.indices`, triangle {t}: vertex index {bad} is out of range: the \
                 POSITION accessor has {count} vertices"
            ));
        }
        faces.push(Face {
            corners: [tri[0], tri[1], tri[2], 0],
            quad: false,
            at: t,
        });
    }
    let attributes = attributes(&primitive, &buffers, count, &faces)?;
    Ok(Mesh {
        positions: xyz,
        faces,
        attributes,
        place: FacePlace::Gltf(place),
    })
}

/// The primitive's `NORMAL` and `TEXCOORD_0` (float), one per vertex, if
/// it has them: each corner takes its vertex's.
fn attributes(
    primitive: &gltf::Primitive,
    buffers: &[Vec<u8>],
    count: usize,
    faces: &[Face],
) -> Result<Attributes, String> {
    let mut out = Attributes::default();
    let floats = |semantic: Semantic, dimensions: Dimensions| -> Result<Option<Vec<f64>>, String> {
        // Only floats are read: normalised integer coordinates (which glTF
        // allows for TEXCOORD_0) are left out, so a cloth's file that has
        // them still loads.
        let Some(accessor) = primitive
            .get(&semantic)
            .filter(|a| a.data_type() == DataType::F32 && a.dimensions() == dimensions)
        else {
            return Ok(None);
        };
        if accessor.count() != count {
            return Err(format!(
                "`accessors[{}]` ({semantic:?}): {} elements for {count} vertices",
                accessor.index(),
                accessor.count()
            ));
        }
        let words = read(&accessor, buffers, DataType::F32, dimensions)?;
        let values: Vec<f64> = words
            .iter()
            .map(|&w| f64::from(f32::from_bits(w)))
            .collect();
        if let Some(k) = values.iter().position(|v| !v.is_finite()) {
            return Err(format!(
                "`accessors[{}]` ({semantic:?}): element {} is not finite",
                accessor.index(),
                k / dimensions.multiplicity()
            ));
        }
        Ok(Some(values))
    };
    let normals = floats(Semantic::Normals, Dimensions::Vec3)?;
    let uvs = floats(Semantic::TexCoords(0), Dimensions::Vec2)?;
    let has = [uvs.is_some(), normals.is_some()];
    if let Some(n) = normals {
        out.normals = n
            .chunks_exact(3)
            .map(|n| DVec3::new(n[0], n[1], n[2]))
            .collect();
    }
    if let Some(t) = uvs {
        out.uvs = t.chunks_exact(2).map(|t| [t[0], t[1]]).collect();
    }
    if has.iter().any(|&h| h) {
        out.corners = faces
            .iter()
            .map(|f| {
                f.corners
                    .map(|v| has.map(|h| if h { v } else { Attributes::NONE }))
            })
            .collect();
    }
    Ok(out)
}

/// Where a walk over a GLB file's chunks ran past the end.
enum Overrun {
    /// A chunk header starting at byte `at` does not fit.
    Header { at: usize },
    /// The chunk at byte `at`, of type `name`, says it holds `size` bytes,
    /// more than follow.
    Data {
        at: usize,
        name: String,
        size: usize,
    },
}

/// A chunk type for a message: `JSON`, `BIN`, or the four bytes quoted.
fn chunk_name(kind: &[u8]) -> String {
    match kind {
        b"JSON" => "JSON".to_string(),
        b"BIN\0" => "BIN".to_string(),
        other => format!("{:?}", String::from_utf8_lossy(other)),
    }
}

/// A GLB chunk: its offset in the file, its type and its data.
type Chunk<'a> = (usize, &'a [u8], &'a [u8]);

/// The chunks of a GLB file `bytes` from byte 12 to byte `end`.
fn chunks(bytes: &[u8], end: usize) -> Result<Vec<Chunk<'_>>, Overrun> {
    let data = &bytes[..end];
    let mut out = Vec::new();
    let mut at = 12;
    while at < data.len() {
        let (Some(size), Some(kind)) = (glb_word(data, at), data.get(at + 4..at + 8)) else {
            return Err(Overrun::Header { at });
        };
        let start = at + 8;
        let stop = start.saturating_add(size);
        if stop > data.len() {
            return Err(Overrun::Data {
                at,
                name: chunk_name(kind),
                size,
            });
        }
        out.push((at, kind, &data[start..stop]));
        at = stop;
    }
    Ok(out)
}

/// The little-endian `u32` at byte `at` of `data`, if it is there.
fn glb_word(data: &[u8], at: usize) -> Option<usize> {
    data.get(at..at.checked_add(4)?)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
}

/// A GLB file's JSON chunk and its binary chunk, if it has one, every
/// length checked against the file (glTF 2.0 §4.4: a 12-byte header —
/// `glTF`, version 2, the file's length — then chunks, each its length,
/// its type and its data; the first is `JSON`, a `BIN\0` may follow, and
/// chunks of other types are skipped, as the format asks).
fn split_glb(bytes: &[u8]) -> Result<(&[u8], Option<&[u8]>), String> {
    let (Some(version), Some(length)) = (glb_word(bytes, 4), glb_word(bytes, 8)) else {
        return Err(format!(
            "is truncated: a GLB file starts with a 12-byte header (`glTF`, version, length), \
             but this one has {} bytes",
            bytes.len()
        ));
    };
    if version != 2 {
        return Err(format!(
            "is GLB version {version}: only version 2 (glTF 2.0) is read"
        ));
    }
    if length < 20 {
        return Err(format!(
            "its GLB header says the file has {length} bytes, too few for the 12-byte header \
             and a JSON chunk's 8-byte header"
        ));
    }
    if length > bytes.len() {
        // Whole chunks up to the file's end are a whole file whose
        // header's length alone is wrong; anything else was cut short.
        let whole = matches!(chunks(bytes, bytes.len()), Ok(c) if !c.is_empty());
        return Err(if whole {
            format!(
                "its GLB header says the file has {length} bytes, but it has {}, which its \
                 chunks fill exactly: the header's length field is wrong (it must be the \
                 file's length)",
                bytes.len()
            )
        } else {
            format!(
                "is truncated: its GLB header says the file has {length} bytes, but it has {}",
                bytes.len()
            )
        });
    }
    let (mut json, mut bin) = (None, None);
    // The file is at least as long as its header says: a chunk that runs
    // past that end has a wrong length field, not a missing part.
    let found = chunks(bytes, length).map_err(|overrun| match overrun {
        Overrun::Header { at } => format!(
            "a GLB chunk header (length and type, 8 bytes) starts at byte {at}, but the \
             file's header puts its end at byte {length}: a chunk's length field or the \
             header's is wrong"
        ),
        Overrun::Data { at, name, size } => format!(
            "its {name} chunk at byte {at} says it holds {size} bytes, but only {} follow \
             its header before the file's end at byte {length} (as its GLB header says): \
             the chunk's length field is wrong",
            length - (at + 8)
        ),
    })?;
    for (at, kind, chunk) in found {
        match kind {
            b"JSON" if json.is_none() => json = Some(chunk),
            _ if json.is_none() => {
                return Err(format!(
                    "its first GLB chunk (at byte {at}) is {}; it must be the JSON chunk",
                    chunk_name(kind)
                ))
            }
            b"BIN\0" if bin.is_none() => bin = Some(chunk),
            _ => {}
        }
    }
    let json = json.ok_or("is a GLB file without a JSON chunk")?;
    Ok((json, bin))
}

/// A `gltf` error as a message: JSON syntax with its line and column,
/// validation with the JSON path. serde's words for a JSON value of the
/// wrong kind (`expected struct Mesh`) become JSON's.
fn describe(e: gltf::Error) -> String {
    match e {
        gltf::Error::Deserialize(e) => format!(
            "line {}, column {}: not valid glTF JSON: {}",
            e.line(),
            e.column(),
            json_words(&e.to_string())
        ),
        gltf::Error::Validation(errors) => {
            let all: Vec<String> = errors
                .iter()
                .map(|(path, error)| format!("`{path}`: {error}"))
                .collect();
            format!("not valid glTF: {}", all.join("; "))
        }
        other => format!("not a valid glTF file: {other}"),
    }
}

/// serde_json's message in JSON's words: its position (given before it)
/// dropped, and each Rust type it names (`expected struct Mesh`,
/// `expected u32`) replaced by the JSON value that was wanted.
fn json_words(message: &str) -> String {
    let message = message
        .rfind(" at line ")
        .map_or(message, |i| &message[..i]);
    let mut out = message
        .replace("invalid type: map", "invalid type: an object")
        .replace("invalid type: sequence", "invalid type: an array")
        .replace("expected a sequence", "expected an array");
    const RUST_TYPES: &[(&str, &str)] = &[
        ("expected struct ", "expected a JSON object"),
        ("expected usize", "expected a whole number ≥ 0"),
        ("expected u64", "expected a whole number ≥ 0"),
        ("expected u32", "expected a whole number ≥ 0"),
        ("expected u16", "expected a whole number ≥ 0"),
        ("expected u8", "expected a whole number ≥ 0"),
        ("expected f32", "expected a number"),
        ("expected f64", "expected a number"),
        ("expected unit", "expected null"),
    ];
    for (rust, json) in RUST_TYPES {
        let mut from = 0;
        while let Some(i) = out[from..].find(rust).map(|i| i + from) {
            // The type name runs to the next character that cannot be in
            // one (`struct Mesh` takes its name along).
            let tail = &out[i + rust.len()..];
            let name = if rust.ends_with(' ') {
                tail.find(|c: char| !(c.is_alphanumeric() || c == '_'))
                    .unwrap_or(tail.len())
            } else if tail.starts_with(|c: char| c.is_alphanumeric()) {
                from = i + rust.len();
                continue;
            } else {
                0
            };
            out.replace_range(i..i + rust.len() + name, json);
            from = i + json.len();
        }
    }
    out
}

/// Every buffer's bytes: the GLB's binary chunk, a `data:` URI's base64, or
/// an external file; each at least its declared `byteLength`.
fn load_buffers(
    file: &gltf::Gltf,
    external: &dyn Fn(&str) -> Result<Vec<u8>, String>,
) -> Result<Vec<Vec<u8>>, String> {
    let mut buffers = Vec::new();
    for buffer in file.buffers() {
        let at = format!("buffers[{}]", buffer.index());
        let bytes = match buffer.source() {
            Source::Bin => file.blob.clone().ok_or_else(|| {
                format!("`{at}`: refers to the GLB binary chunk, which the file does not have")
            })?,
            Source::Uri(uri) if uri.starts_with("data:") => {
                let (_, data) = uri.split_once(";base64,").ok_or_else(|| {
                    format!("`{at}.uri`: a data URI must be base64 (`data:…;base64,…`)")
                })?;
                base64::engine::general_purpose::STANDARD
                    .decode(data)
                    .map_err(|e| format!("`{at}.uri`: the base64 data is not valid: {e}"))?
            }
            Source::Uri(uri) => external(uri).map_err(|e| format!("`{at}.uri`: {e}"))?,
        };
        if bytes.len() < buffer.length() {
            return Err(format!(
                "`{at}`: byteLength is {} but the data has only {} bytes",
                buffer.length(),
                bytes.len()
            ));
        }
        buffers.push(bytes);
    }
    Ok(buffers)
}

/// An accessor's elements as little-endian 32-bit words, indices widened
/// to `u32`: checked to be of `data_type` × `dimensions`, dense (not
/// sparse) and inside its view and buffer.
fn read(
    accessor: &gltf::Accessor,
    buffers: &[Vec<u8>],
    data_type: DataType,
    dimensions: Dimensions,
) -> Result<Vec<u32>, String> {
    let at = format!("accessors[{}]", accessor.index());
    if accessor.data_type() != data_type || accessor.dimensions() != dimensions {
        return Err(format!(
            "`{at}`: is {:?} {:?}, expected {data_type:?} {dimensions:?}",
            accessor.data_type(),
            accessor.dimensions()
        ));
    }
    if accessor.sparse().is_some() {
        return Err(format!("`{at}.sparse`: sparse accessors are not read"));
    }
    let view = accessor
        .view()
        .ok_or_else(|| format!("`{at}`: has no bufferView (all zeros), so no data"))?;
    let component = data_type.size();
    let element = component * dimensions.multiplicity();
    let stride = view.stride().unwrap_or(element);
    let count = accessor.count();
    let data = &buffers[view.buffer().index()];
    // The last element ends at offset + stride·(count − 1) + element.
    let end = count
        .checked_sub(1)
        .and_then(|last| last.checked_mul(stride))
        .and_then(|x| x.checked_add(accessor.offset()))
        .and_then(|x| x.checked_add(element));
    let view_end = view.offset().checked_add(view.length());
    let fits = matches!((end, view_end), (Some(end), Some(view_end))
        if stride >= element && end <= view.length() && view_end <= data.len());
    if count == 0 || !fits {
        return Err(format!(
            "`{at}`: {count} elements of {element} bytes every {stride} from byte {} do not \
             fit bufferView {} ({} bytes at byte {} of a {}-byte buffer)",
            accessor.offset(),
            view.index(),
            view.length(),
            view.offset(),
            data.len()
        ));
    }
    let bytes = &data[view.offset()..view.offset() + view.length()];
    let mut words = Vec::with_capacity(count * dimensions.multiplicity());
    for k in 0..count {
        let start = accessor.offset() + k * stride;
        for c in 0..dimensions.multiplicity() {
            let b = &bytes[start + c * component..start + (c + 1) * component];
            // The types allowed above have 1, 2 or 4 bytes.
            words.push(match component {
                1 => u32::from(b[0]),
                2 => u32::from(u16::from_le_bytes([b[0], b[1]])),
                _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            });
        }
    }
    Ok(words)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A GLB of `json` and, if given, a binary chunk.
    fn glb(json: &[u8], bin: Option<&[u8]>) -> Vec<u8> {
        let chunk = |kind: &[u8], data: &[u8]| {
            let mut c = (data.len() as u32).to_le_bytes().to_vec();
            c.extend(kind);
            c.extend(data);
            c
        };
        let mut body = chunk(b"JSON", json);
        if let Some(bin) = bin {
            body.extend(chunk(b"BIN\0", bin));
        }
        let mut out = b"glTF".to_vec();
        out.extend(2u32.to_le_bytes());
        out.extend(((12 + body.len()) as u32).to_le_bytes());
        out.extend(body);
        out
    }

    #[test]
    fn a_glb_splits_into_its_chunks_and_skips_unknown_ones() {
        let file = glb(b"{}  ", Some(b"abcd"));
        assert_eq!(split_glb(&file), Ok((&b"{}  "[..], Some(&b"abcd"[..]))));
        // An unknown chunk before BIN is skipped, as glTF 2.0 asks.
        let mut odd = glb(b"{}  ", None);
        odd.extend(4u32.to_le_bytes());
        odd.extend(b"XTRA1234");
        odd.extend(4u32.to_le_bytes());
        odd.extend(b"BIN\0wxyz");
        let length = (odd.len() as u32).to_le_bytes();
        odd[8..12].copy_from_slice(&length);
        assert_eq!(split_glb(&odd), Ok((&b"{}  "[..], Some(&b"wxyz"[..]))));
    }

    #[test]
    fn a_glb_that_lies_about_a_length_is_refused_naming_it() {
        let file = glb(b"{}  ", Some(b"abcd"));
        let error = |bytes: &[u8]| split_glb(bytes).err().unwrap_or_default();
        assert!(
            error(&file[..8]).contains("12-byte header"),
            "{}",
            error(&file[..8])
        );
        let cut = error(&file[..30]);
        assert!(
            cut.contains("is truncated") && cut.contains("header says"),
            "{cut}"
        );
        let mut long_bin = file.clone();
        long_bin[24..28].copy_from_slice(&9u32.to_le_bytes());
        let e = error(&long_bin);
        assert!(
            e.contains("BIN chunk at byte 24 says it holds 9 bytes"),
            "{e}"
        );
        assert!(!e.contains("truncated"), "{e}");
        // A whole file whose header alone overstates its length.
        let mut long_header = file.clone();
        long_header[8..12].copy_from_slice(&(file.len() as u32 + 4).to_le_bytes());
        let e = error(&long_header);
        assert!(
            e.contains("header's length field is wrong") && !e.contains("truncated"),
            "{e}"
        );
        let mut bin_first = file.clone();
        bin_first[16..20].copy_from_slice(b"BIN\0");
        let e = error(&bin_first);
        assert!(e.contains("first GLB chunk (at byte 12) is BIN"), "{e}");
        let mut version = file;
        version[4] = 1;
        assert!(error(&version).contains("version 1"), "{}", error(&version));
    }

    #[test]
    fn json_errors_name_json_values_not_rust_types() {
        for (serde, json) in [
            (
                "invalid type: integer `5`, expected struct Mesh at line 1 column 9",
                "invalid type: integer `5`, expected a JSON object",
            ),
            (
                "invalid type: map, expected u32",
                "invalid type: an object, expected a whole number ≥ 0",
            ),
            (
                "invalid type: string \"x\", expected f32 or u8 here",
                "invalid type: string \"x\", expected a number or u8 here",
            ),
        ] {
            assert_eq!(json_words(serde), json);
        }
    }
}
