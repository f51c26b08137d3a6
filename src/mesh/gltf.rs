//! glTF 2.0 (`.gltf` JSON with embedded or external buffers, `.glb`): one
//! triangle primitive's positions and indices.
//!
//! The `gltf` crate parses and validates the JSON (its errors name the JSON
//! path); the accessors are read here with every offset and length checked
//! against the buffer, so a file that lies about its sizes is an error,
//! never a panic. Only the chosen primitive's `POSITION` accessor and its
//! indices are read: materials, textures, images, normals and every other
//! attribute, skins, animations, cameras, node transforms and the other
//! meshes and primitives are ignored.

use base64::Engine as _;
use glam::DVec3;
use gltf::accessor::{DataType, Dimensions};
use gltf::buffer::Source;
use gltf::mesh::{Mode, Semantic};

use super::{too_many_vertices, Face, FacePlace, Mesh};
use crate::model::MAX_PARTICLES;

/// Parses a glTF or GLB file's bytes; `mesh_name` picks a mesh (else the
/// first), whose first triangle primitive is the cloth.
pub(super) fn parse(
    bytes: &[u8],
    mesh_name: Option<&str>,
    external: &dyn Fn(&str) -> Result<Vec<u8>, String>,
) -> Result<Mesh, String> {
    let file = gltf::Gltf::from_slice(bytes).map_err(describe)?;
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
    Ok(Mesh {
        positions: xyz,
        faces,
        place: FacePlace::Gltf(place),
    })
}

/// A `gltf` error as a message: JSON syntax with its line and column,
/// validation with the JSON path.
fn describe(e: gltf::Error) -> String {
    match e {
        gltf::Error::Deserialize(e) => format!(
            "line {}, column {}: not valid glTF JSON: {e}",
            e.line(),
            e.column()
        ),
        gltf::Error::Validation(errors) => {
            let all: Vec<String> = errors
                .iter()
                .map(|(path, error)| format!("`{path}`: {error}"))
                .collect();
            format!("not valid glTF: {}", all.join("; "))
        }
        gltf::Error::Binary(e) => format!("not a valid GLB file: {e}"),
        other => format!("not a valid glTF file: {other}"),
    }
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
