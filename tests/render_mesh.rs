//! Render meshes embedded in a cloth: where they are at rest, how they
//! follow a rigid motion and a deformation, the GPU's `skin` pass against
//! its CPU twin, and what is refused.

mod gpu_common;

use std::path::Path;

use gpu_common::layers::{embedded, layers, LINING, MAX_DISTANCE, SHELL};
use gpu_common::*;
use wgcloth::cpu::skin;
use wgcloth::glam::{DQuat, DVec3};
use wgcloth::gpu::{GpuRenderMesh, GpuSolver, SkinLayout};
use wgcloth::params::Integrator;
use wgcloth::real::Vec3;
use wgcloth::render_mesh::{Embedding, RenderMesh};
use wgcloth::{CpuSolver, Model};

/// Where a vertex embedded at rest comes back at rest: `u`, `v` and `h`
/// are stored as `f32`, each within half an `f32` ulp (≤ 2⁻²⁴ relative for
/// coordinates below 2) of the `f64` solve's, moving the point by at most
/// that times an edge or the offset (≤ 1 m on these cloths): three such
/// terms stay under 4 ε₃₂ · 1 m. The `f64` arithmetic adds ~1e-16.
const REST: f64 = 4.0 * f32::EPSILON as f64;

/// A horizontal 13 × 9 cloth (1 m square) pinned at two corners.
fn cloth() -> (Model, wgcloth::Params) {
    let params = busy_params(Integrator::Explicit);
    (grid(13, 9, corners(), &params), params)
}

fn to_real(v: &[DVec3]) -> Vec<Vec3<f64>> {
    v.iter().map(|&p| Vec3::from_f64(p)).collect()
}

fn from_real(v: &[Vec3<f64>]) -> Vec<DVec3> {
    v.iter().map(|p| DVec3::from_array(p.to_f64())).collect()
}

/// Largest distance between two lists of points, with its index.
fn furthest(a: &[DVec3], b: &[DVec3]) -> (f64, usize) {
    a.iter()
        .zip(b)
        .map(|(p, q)| (*p - *q).length())
        .enumerate()
        .fold((0.0, 0), |m, (i, d)| if d > m.0 { (d, i) } else { m })
}

#[test]
fn at_rest_every_vertex_is_where_the_file_put_it() {
    let (model, _) = cloth();
    let (mesh, embedding) = embedded(&model);
    let (p, n) = skin::skin(&model, &to_real(&model.rest_positions), &embedding);
    let (d, i) = furthest(&from_real(&p), &mesh.positions);
    assert!(
        d <= REST,
        "vertex {i} is {d:e} m from where the file put it"
    );
    let (d, i) = furthest(&from_real(&n), &mesh.normals);
    assert!(d <= REST, "vertex {i}'s normal is {d:e} from the file's");
    // The lining faces down, the shell up: the layers kept their normals.
    assert!(n[0].y > 0.99 && n.last().map(|n| n.y) < Some(-0.99));
}

#[test]
fn a_rigid_motion_moves_the_mesh_rigidly() {
    let (model, _) = cloth();
    let (mesh, embedding) = embedded(&model);
    let turn = DQuat::from_axis_angle(DVec3::new(1.0, 2.0, -0.5).normalize(), 1.1);
    let shift = DVec3::new(0.3, -2.0, 5.0);
    let moved: Vec<DVec3> = model
        .rest_positions
        .iter()
        .map(|&x| turn * x + shift)
        .collect();
    let (p, n) = skin::skin(&model, &to_real(&moved), &embedding);
    let want: Vec<DVec3> = mesh.positions.iter().map(|&x| turn * x + shift).collect();
    // The moved points are up to ~6 m out: their own f64 rounding is far
    // below REST, which the stored f32 coordinates dominate.
    let (d, i) = furthest(&from_real(&p), &want);
    assert!(d <= REST, "vertex {i} is {d:e} m off the rigid motion");
    let want: Vec<DVec3> = mesh.normals.iter().map(|&x| turn * x).collect();
    let (d, i) = furthest(&from_real(&n), &want);
    assert!(d <= REST, "vertex {i}'s normal is {d:e} off the turned one");
}

#[test]
fn a_deformed_cloth_carries_the_layers_apart_along_its_normals() {
    let (model, params) = cloth();
    let (mesh, embedding) = embedded(&model);
    let mut cpu = CpuSolver::<f64>::new(&model, &params).expect("CPU solver");
    cpu.step_n(300).expect("steps");
    let x: Vec<Vec3<f64>> = to_real(&cpu.positions());
    let normals = skin::normals(&model, &x);
    let (p, n) = skin::skin(&model, &x, &embedding);
    // The cloth moved and bent: the mesh with it.
    let (moved, _) = furthest(&from_real(&p), &mesh.positions);
    assert!(moved > 0.05, "the render mesh moved only {moved} m");
    let half = p.len() / 2;
    for (k, e) in embedding.vertices.iter().enumerate() {
        let [a, b, c] = model.triangles[e.triangle as usize].map(|i| i as usize);
        let (u, v) = (f64::from(e.uv[0]), f64::from(e.uv[1]));
        let on = x[a] * (1.0 - u - v) + x[b] * u + x[c] * v;
        let nh = normals[a] * (1.0 - u - v) + normals[b] * u + normals[c] * v;
        let nh = nh / nh.length();
        // Each layer keeps its offset along the cloth's normal there, and
        // its normal (the cloth's, up or down) follows the cloth's.
        let h = if k < half { SHELL } else { LINING };
        let off = (p[k] - on).dot(nh);
        assert!((off - h).abs() < 1e-6, "vertex {k}: offset {off}, want {h}");
        let facing = n[k].dot(nh) * h.signum();
        assert!(
            facing > 0.999_99,
            "vertex {k}: its normal is {facing} along the cloth's"
        );
    }
}

#[test]
fn a_vertex_far_from_the_cloth_is_refused_by_name() {
    let (model, _) = cloth();
    let mut mesh = RenderMesh::from_mesh(Path::new("cape.obj"), &layers(&model), 1.0, DVec3::ZERO);
    mesh.positions[7].y += 0.5;
    let e = Embedding::new(&model, &mesh, MAX_DISTANCE).expect_err("refused");
    let text = e.to_string();
    assert!(
        text.contains("cape.obj") && text.contains("vertex 7 ") && text.contains("max_distance"),
        "{text}"
    );
    let e = Embedding::new(&model, &mesh, f64::NAN).expect_err("refused");
    assert!(e.to_string().contains("max_distance"), "{e}");
    // A host's mesh whose lists disagree.
    let mut short = mesh.clone();
    short.normals.pop();
    let e = Embedding::new(&model, &short, MAX_DISTANCE).expect_err("refused");
    assert!(e.to_string().contains("normals"), "{e}");
    let mut past = mesh.clone();
    past.triangles[3][1] = past.positions.len() as u32;
    let e = Embedding::new(&model, &past, MAX_DISTANCE).expect_err("refused");
    assert!(e.to_string().contains("triangle 3"), "{e}");
}

#[test]
fn a_render_mesh_of_another_cloth_or_a_bad_layout_is_refused() {
    let (model, params) = cloth();
    let (_, embedding) = embedded(&model);
    let ctx = gpu();
    let small = grid(3, 3, corners(), &params);
    let solver =
        GpuSolver::with_kernels(ctx.kernels(), &ctx.queue, &small, &params).expect("GPU solver");
    let e = GpuRenderMesh::new(&solver, &embedding, SkinLayout::POSITION_NORMAL)
        .expect_err("another cloth's");
    assert!(e.to_string().contains("triangle"), "{e}");
    let solver =
        GpuSolver::with_kernels(ctx.kernels(), &ctx.queue, &model, &params).expect("GPU solver");
    for layout in [
        SkinLayout {
            stride: 5,
            position: 0,
            normal: Some(3),
            uv: None,
        },
        SkinLayout {
            stride: 6,
            position: 0,
            normal: Some(2),
            uv: None,
        },
        SkinLayout {
            stride: 2,
            position: 0,
            normal: None,
            uv: None,
        },
    ] {
        let e = GpuRenderMesh::new(&solver, &embedding, layout).expect_err("a bad layout");
        assert!(e.to_string().contains("SkinLayout"), "{layout:?}: {e}");
    }
    GpuRenderMesh::new(&solver, &embedding, SkinLayout::POSITION_NORMAL).expect("fits");
}

/// A square of two triangles over the 13 × 9 cloth's middle, a millimetre
/// above it: its file normals tilted (normalised when read), its texture
/// coordinates with a seam at vertex 2 (two `vt`s), so that vertex is two
/// render vertices.
const SEAMED_OBJ: &str = "\
v -0.2 1.001 -0.2\nv 0.2 1.001 -0.2\nv 0.2 1.001 0.2\nv -0.2 1.001 0.2\n\
vt 0 0\nvt 1 0\nvt 1 1\nvt 0.5 0.5\nvt 0 1\n\
vn 0 2 0\nvn 0 1 1\n\
f 1/1/1 4/5/1 3/3/2\nf 1/1/1 3/4/2 2/2/1\n";

#[test]
fn a_file_s_normals_and_texture_coordinates_are_kept_and_a_seam_splits_its_vertex() {
    let (model, params) = cloth();
    let mesh =
        wgcloth::mesh::Mesh::parse(SEAMED_OBJ.as_bytes(), Path::new("seam.obj"), None, &|_| {
            Err("no buffers".into())
        })
        .expect("a valid OBJ");
    let render = RenderMesh::from_mesh(Path::new("seam.obj"), &mesh, 1.0, DVec3::ZERO);
    // Vertex 2 (0-based) has two texture coordinates: two render vertices,
    // next to each other in the file's order.
    assert_eq!(render.source, vec![0, 1, 2, 2, 3]);
    let uvs = render.uvs.clone().expect("every corner has a vt");
    assert_eq!(
        uvs,
        vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.5, 0.5], [0.0, 1.0]]
    );
    assert_eq!(render.normals[0], DVec3::Y);
    let tilted = DVec3::new(0.0, 1.0, 1.0).normalize();
    assert!(
        (render.normals[2] - tilted).length() < 1e-15,
        "{:?}",
        render.normals[2]
    );
    assert_eq!(render.triangles, vec![[0, 4, 2], [0, 3, 1]]);
    // On the device the coordinates sit where the layout puts them, and
    // the skin pass leaves them there.
    let embedding = Embedding::new(&model, &render, MAX_DISTANCE).expect("embeds");
    let ctx = gpu();
    let solver =
        GpuSolver::with_kernels(ctx.kernels(), &ctx.queue, &model, &params).expect("GPU solver");
    let layout = SkinLayout::POSITION_NORMAL_UV;
    let gpu_mesh = GpuRenderMesh::new(&solver, &embedding, layout).expect("render mesh");
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    solver.encode_normals(&mut encoder);
    gpu_mesh.encode(&mut encoder);
    ctx.queue.submit([encoder.finish()]);
    let words = gpu_mesh.read_vertices().expect("read-back");
    for (k, uv) in uvs.iter().enumerate() {
        assert_eq!(&words[k * 8 + 6..k * 8 + 8], uv, "vertex {k}");
        // At rest, where the file put it.
        let p = DVec3::new(
            words[k * 8].into(),
            words[k * 8 + 1].into(),
            words[k * 8 + 2].into(),
        );
        assert!(
            (p - render.positions[k]).length() < 1e-6,
            "vertex {k} at {p}"
        );
    }
    // A mesh without texture coordinates cannot fill a layout that has them.
    let (_, plain) = embedded(&model);
    let e = GpuRenderMesh::new(&solver, &plain, layout).expect_err("no uvs");
    assert!(e.to_string().contains("SkinLayout::uv"), "{e}");
}

#[test]
fn a_bad_normal_or_texture_coordinate_index_is_refused_by_line() {
    for (text, want) in [
        (
            "v 0 0 0\nv 1 0 0\nv 0 0 1\nvt 0 0\nf 1/2 2/1 3/1\n",
            "line 5: face corner vt index 2 is out of range",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 0 1\nvn 0 1\nf 1 2 3\n",
            "line 4: a normal is `vn x y z`",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 0 1\nvn 0 1 nan\nf 1 2 3\n",
            "line 4: number 2 `nan`",
        ),
    ] {
        let e = wgcloth::mesh::Mesh::parse(text.as_bytes(), Path::new("bad.obj"), None, &|_| {
            Err("no buffers".into())
        })
        .expect_err("refused");
        assert!(e.to_string().contains(want), "{e}\nwanted: {want}");
    }
}

/// A glTF square of two triangles whose primitive has `NORMAL` and
/// `TEXCOORD_0` (float), its buffer embedded; `uv_type` the texture
/// coordinates' component type (5126 float; 5123 unsigned short, which is
/// not read).
fn gltf_square(uv_type: u32) -> String {
    use base64::Engine as _;
    let positions: [[f32; 3]; 4] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 0.0, 1.0],
        [0.0, 0.0, 1.0],
    ];
    let normals: [[f32; 3]; 4] = [
        [0.0, 3.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
    ];
    let uvs: [[f32; 2]; 4] = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    let indices: [u32; 6] = [0, 2, 1, 0, 3, 2];
    let mut bytes: Vec<u8> = Vec::new();
    bytes.extend(positions.iter().flatten().flat_map(|x| x.to_le_bytes()));
    bytes.extend(normals.iter().flatten().flat_map(|x| x.to_le_bytes()));
    bytes.extend(uvs.iter().flatten().flat_map(|x| x.to_le_bytes()));
    bytes.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    let data = base64::engine::general_purpose::STANDARD.encode(&bytes);
    format!(
        r#"{{
  "asset": {{ "version": "2.0" }},
  "meshes": [{{ "primitives": [{{ "attributes": {{ "POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2 }}, "indices": 3 }}] }}],
  "accessors": [
    {{ "bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 0, 1] }},
    {{ "bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3" }},
    {{ "bufferView": 2, "componentType": {uv_type}, "normalized": true, "count": 4, "type": "VEC2" }},
    {{ "bufferView": 3, "componentType": 5125, "count": 6, "type": "SCALAR" }}
  ],
  "bufferViews": [
    {{ "buffer": 0, "byteOffset": 0, "byteLength": 48 }},
    {{ "buffer": 0, "byteOffset": 48, "byteLength": 48 }},
    {{ "buffer": 0, "byteOffset": 96, "byteLength": 32 }},
    {{ "buffer": 0, "byteOffset": 128, "byteLength": 24 }}
  ],
  "buffers": [{{ "byteLength": 152, "uri": "data:application/octet-stream;base64,{data}" }}]
}}"#
    )
}

#[test]
fn a_gltf_s_normals_and_texture_coordinates_are_kept() {
    let read = |text: String| {
        let mesh =
            wgcloth::mesh::Mesh::parse(text.as_bytes(), Path::new("square.gltf"), None, &|_| {
                Err("no buffers".into())
            })
            .expect("a valid glTF");
        RenderMesh::from_mesh(Path::new("square.gltf"), &mesh, 1.0, DVec3::ZERO)
    };
    let render = read(gltf_square(5126));
    // One render vertex per glTF vertex, in its order.
    assert_eq!(render.source, vec![0, 1, 2, 3]);
    assert_eq!(render.normals[0], DVec3::Y);
    assert!((render.normals[3] - DVec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-15);
    assert_eq!(
        render.uvs,
        Some(vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    );
    // Normalised integer coordinates are left out (a cloth's file that
    // has them still loads); the normals are still the file's.
    let render = read(gltf_square(5123));
    assert_eq!(render.uvs, None);
    assert_eq!(render.normals[0], DVec3::Y);
}

#[test]
fn a_scene_s_render_mesh_is_read_as_its_cloth_s_mesh_would_be() {
    let dir = std::env::temp_dir().join(format!("wgcloth-render-mesh-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("meshes")).expect("a temp folder");
    let scene =
        |key: &str| format!("[cloth]\nresolution = [5, 5]\n\n[[render_mesh]]\nfile = \"{key}\"\n");
    let load = |name: &str, text: String| {
        let path = dir.join(name);
        std::fs::write(&path, text).expect("written");
        wgcloth::Scene::load(&path)
    };
    // A buffer outside the mesh's folder, as for a cloth's glTF.
    std::fs::write(
        dir.join("meshes/out.gltf"),
        gltf_square(5126).replace("data:application/octet-stream;base64,", "../secret.bin#"),
    )
    .expect("written");
    let e = load("out.toml", scene("meshes/out.gltf")).expect_err("refused");
    assert!(
        e.to_string().contains("out.gltf") && e.to_string().contains("folder"),
        "{e}"
    );
    // An empty file and a missing one.
    std::fs::write(dir.join("meshes/empty.obj"), "").expect("written");
    let e = load("empty.toml", scene("meshes/empty.obj")).expect_err("refused");
    assert!(
        e.to_string().contains("empty.obj") && e.to_string().contains("no faces"),
        "{e}"
    );
    let e = load("missing.toml", scene("meshes/missing.obj")).expect_err("refused");
    assert!(e.to_string().contains("missing.obj"), "{e}");
    // An unknown key of the table.
    let e = load("key.toml", scene("meshes/empty.obj") + "colour = 1\n").expect_err("refused");
    assert!(e.to_string().contains("colour"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// In a world, a cloth's own `render_mesh` follows that cloth and a
/// `[[render_mesh]]` the cloth its `cloth` key names: each is embedded on
/// its cloth's triangles alone (a mesh over the second cloth, given to the
/// first, lies farther than `max_distance` from every triangle it may use).
#[test]
fn a_world_s_render_meshes_follow_the_cloths_they_name() {
    let dir = std::env::temp_dir().join(format!("wgcloth-world-render-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("a temp folder");
    // A quad over each cloth, a millimetre above it.
    let quad = |x0: f64| {
        let x1 = x0 + 0.4;
        format!(
            "v {x0} 1.001 -0.2\nv {x1} 1.001 -0.2\nv {x1} 1.001 0.2\nv {x0} 1.001 0.2\n\
             f 1 4 3\nf 1 3 2\n"
        )
    };
    std::fs::write(dir.join("first.obj"), quad(-0.8)).expect("written");
    std::fs::write(dir.join("second.obj"), quad(0.2)).expect("written");
    let cloth = |x: f64, extra: &str| {
        format!(
            "[[cloth]]\nresolution = [5, 5]\nsize = [0.6, 0.6]\norigin = [{x}, 1.0, -0.3]\n{extra}"
        )
    };
    let text = |second_key: u32| {
        format!(
            "{}{}[[render_mesh]]\nfile = \"first.obj\"\ncloth = {second_key}\n",
            cloth(-0.9, ""),
            cloth(0.1, "render_mesh = \"second.obj\"\n")
        )
    };
    let path = dir.join("world.toml");
    std::fs::write(&path, text(0)).expect("written");
    let scene = wgcloth::Scene::load(&path).expect("the world");
    let model = scene.model().expect("its model");
    // The cloth's own first, then the table's.
    let follows: Vec<usize> = scene.render_meshes.iter().map(|r| r.cloth).collect();
    assert_eq!(follows, [1, 0]);
    let embeddings = scene.embeddings(&model).expect("embedded");
    let second_cloth_triangles = model.triangles.len() / 2;
    for (e, cloth) in embeddings.iter().zip([1, 0]) {
        assert_eq!(e.cloth, Some(cloth));
        assert!(
            e.vertices
                .iter()
                .all(|v| (v.triangle as usize >= second_cloth_triangles) == (cloth == 1)),
            "render mesh on cloth {cloth}: a vertex on the other cloth"
        );
    }
    // The first cloth's mesh given to the second: beyond its reach.
    std::fs::write(&path, text(1)).expect("written");
    let scene = wgcloth::Scene::load(&path).expect("the world");
    let e = scene.embeddings(&model).expect_err("refused");
    assert!(
        e.to_string().contains("first.obj")
            && e.to_string().contains("cloth 1")
            && e.to_string().contains("max_distance"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
