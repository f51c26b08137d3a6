//! Offscreen rendering on the test adapter (lavapipe in CI): frames decode
//! at the asked size and count, the cloth lands where the camera projects
//! its particles, and the sky stays the background colour. No golden
//! images: the checks follow from the camera and the colours, and the
//! same frame on two colour formats.

mod gpu_common;

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};

use wgcloth::glam::Vec3;
use wgcloth::gpu::GpuSolver;
use wgcloth::render::{self, Camera, FrameOptions, FrameTarget, Renderer, RendererFormats};
use wgcloth::Scene;

/// A 9 × 9 cloth held by two corners above the ground, beside a ball:
/// every kind of object the renderer draws, small enough for lavapipe.
const SCENE: &str = r#"
[simulation]
integrator = "explicit"
dt = 0.002
duration = 1.0

[cloth]
resolution = [9, 9]
size = [1.0, 1.0]
origin = [-0.5, 1.0, -0.5]
orientation = "horizontal"
pins = ["top-left", "top-right"]

[ground]
height = 0.0

[[sphere]]
center = [0.8, 0.3, 0.0]
radius = 0.2
"#;

const WIDTH: u32 = 160;
const HEIGHT: u32 = 120;
const FRAMES: u32 = 5;

/// A pixel counts as cloth when its red channel exceeds green and blue by
/// this much: the cloth is red (front) or orange (back); the ground is
/// grey, the ball blue, the sky blue-grey.
const CLOTH_RED_MARGIN: i32 = 30;

/// A fresh directory under the system temp directory; kept on failure so
/// the frames can be looked at.
fn temp_dir(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wgcloth-render-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create the test directory");
    dir
}

fn pixel(rgba: &[u8], x: u32, y: u32) -> [u8; 4] {
    let at = ((y * WIDTH + x) * 4) as usize;
    [rgba[at], rgba[at + 1], rgba[at + 2], rgba[at + 3]]
}

/// The colour of `rgba`'s pixel under `x` as `camera` sees it.
fn colour_at(rgba: &[u8], camera: &Camera, x: Vec3) -> [u8; 4] {
    let [px, py] = camera
        .project(x, WIDTH, HEIGHT)
        .expect("in front of the camera")
        .to_array();
    pixel(rgba, px as u32, py as u32)
}

/// Whether `c` is the cloth's red or orange (see [`CLOTH_RED_MARGIN`]).
fn is_cloth(c: [u8; 4]) -> bool {
    i32::from(c[0]) - i32::from(c[1]).max(i32::from(c[2])) > CLOTH_RED_MARGIN
}

/// Checks that `positions` (interior particles of the cloth) land on
/// cloth-coloured pixels of `frame`, and the top-left corner is sky.
fn assert_cloth_at(frame: &Path, camera: &Camera, positions: &[Vec3]) {
    let (w, h, rgba) = gpu_common::decode_png(frame);
    assert_eq!((w, h), (WIDTH, HEIGHT), "{}", frame.display());
    assert_eq!(
        pixel(&rgba, 0, 0),
        render::BACKGROUND,
        "{}: corner",
        frame.display()
    );
    for (p, x) in positions.iter().enumerate() {
        let [px, py] = camera
            .project(*x, WIDTH, HEIGHT)
            .map(|q| q.to_array())
            .unwrap_or_else(|| panic!("particle {p} at {x:?} is behind the camera"));
        assert!(
            (0.0..WIDTH as f32).contains(&px) && (0.0..HEIGHT as f32).contains(&py),
            "particle {p} at {x:?} projects outside the image, to ({px}, {py})"
        );
        let c = pixel(&rgba, px as u32, py as u32);
        assert!(
            c != render::BACKGROUND && is_cloth(c),
            "{}: particle {p} at {x:?} projects to ({px:.1}, {py:.1}), colour {c:?}: not cloth",
            frame.display()
        );
    }
}

/// The particles of the 9 × 9 grid at least two rows and columns from
/// every edge: a pixel there is covered by the cloth whole.
fn interior(x: &[Vec3]) -> Vec<Vec3> {
    (0..81)
        .filter(|p| (2..7).contains(&(p % 9)) && (2..7).contains(&(p / 9)))
        .map(|p| x[p])
        .collect()
}

#[test]
fn frames_show_the_cloth_where_its_particles_project() {
    let ctx = gpu_common::gpu();
    let scene = Scene::from_toml(SCENE, Path::new("render-test.toml")).expect("the test scene");
    let model = scene.model().expect("the model");
    let mut solver = GpuSolver::new(&ctx.device, &ctx.queue, &model, &scene.params)
        .unwrap_or_else(|e| panic!("GPU solver: {e}"));
    let camera = Camera::framing(&model, &scene.params, WIDTH as f32 / HEIGHT as f32);
    let renderer = Renderer::new(&ctx.device, &ctx.queue, &scene.params, &camera);
    let dir = temp_dir("frames");
    let options = FrameOptions {
        width: WIDTH,
        height: HEIGHT,
        frames: FRAMES,
        steps_per_frame: render::steps_per_frame(30.0, scene.params.dt).expect("fps"),
        dir: dir.clone(),
        strain: false,
    };
    let mut seen = Vec::new();
    let written = render::render_frames(&ctx.device, &mut solver, &renderer, &options, |done| {
        seen.push(done);
        ControlFlow::Continue(())
    })
    .unwrap_or_else(|e| panic!("rendering: {e}"));
    assert_eq!(written, FRAMES);
    assert_eq!(seen, (1..=FRAMES).collect::<Vec<_>>(), "progress reports");
    let names: Vec<String> = render::existing_frames(&dir)
        .expect("list the frames")
        .iter()
        .map(|p| {
            p.file_name()
                .expect("a name")
                .to_string_lossy()
                .into_owned()
        })
        .collect();
    let expected: Vec<String> = (0..FRAMES).map(render::frame_name).collect();
    assert_eq!(names, expected);

    // Frame 0 is the rest state; the last frame the solver's state now.
    let rest: Vec<Vec3> = model.rest_positions.iter().map(|p| p.as_vec3()).collect();
    assert_cloth_at(&dir.join(render::frame_name(0)), &camera, &interior(&rest));
    let now = solver.read_state().expect("read back").x;
    let last = dir.join(render::frame_name(FRAMES - 1));
    assert_cloth_at(&last, &camera, &interior(&now));
    std::fs::remove_dir_all(&dir).expect("remove the test directory");
}

#[test]
fn a_size_beyond_the_device_is_refused() {
    let ctx = gpu_common::gpu();
    let scene = Scene::from_toml(SCENE, Path::new("render-test.toml")).expect("the test scene");
    let options = FrameOptions {
        width: ctx.device.limits().max_texture_dimension_2d + 1,
        height: 4,
        frames: 1,
        steps_per_frame: 1,
        dir: std::env::temp_dir(),
        strain: false,
    };
    let err = render::render_scene(&ctx.device, &ctx.queue, &scene, &options, |_| {
        ControlFlow::Continue(())
    })
    .expect_err("too wide");
    assert!(matches!(err, wgcloth::Error::DeviceLimit { .. }), "{err}");
}

/// The strain view at rest: every triangle at zero strain, so the pixels
/// where the particles project are the ramp's blue.
/// `scene`'s first frame after one step (by strain where `strain`), in a
/// fresh directory named for `test`: the directory, the frame's path and
/// its RGBA bytes.
fn first_frame(scene: &Scene, test: &str, strain: bool) -> (PathBuf, PathBuf, Vec<u8>) {
    let ctx = gpu_common::gpu();
    let dir = temp_dir(test);
    let options = FrameOptions {
        width: WIDTH,
        height: HEIGHT,
        frames: 1,
        steps_per_frame: 1,
        dir: dir.clone(),
        strain,
    };
    render::render_scene(&ctx.device, &ctx.queue, scene, &options, |_| {
        ControlFlow::Continue(())
    })
    .unwrap_or_else(|e| panic!("rendering: {e}"));
    let frame = dir.join(render::frame_name(0));
    let (_, _, rgba) = gpu_common::decode_png(&frame);
    (dir, frame, rgba)
}

#[test]
fn strain_view_at_rest_is_blue() {
    let scene = Scene::from_toml(SCENE, Path::new("render-test.toml")).expect("the test scene");
    let model = scene.model().expect("the model");
    let (dir, frame, rgba) = first_frame(&scene, "strain", true);
    let camera = Camera::framing(&model, &scene.params, WIDTH as f32 / HEIGHT as f32);
    let rest: Vec<Vec3> = model.rest_positions.iter().map(|p| p.as_vec3()).collect();
    for x in interior(&rest) {
        let c = colour_at(&rgba, &camera, x);
        assert!(
            i32::from(c[2]) > i32::from(c[0]).max(i32::from(c[1])) + CLOTH_RED_MARGIN,
            "{}: particle at {x:?}: colour {c:?}: not blue",
            frame.display()
        );
    }
    std::fs::remove_dir_all(&dir).expect("remove the test directory");
}

/// Most an 8-bit channel of the `Bgra8UnormSrgb` frame may differ from the
/// `Rgba8Unorm` one \[levels of 255\]: the sRGB target stores the
/// hardware's sRGB encoding of the shader's decoded value, rounded to
/// 8 bits, where the plain target stores the shader's value rounded; the
/// f32 decode and the encode (which Vulkan lets a device approximate) can
/// move that rounding by a level. Formats mishandled (the encoded value
/// written unchanged to the sRGB target, or the clear colour not decoded)
/// brighten the dark background (30, 34, 44) by over 60 levels.
const SRGB_ROUNDING_LEVELS: i32 = 1;

/// Steps before the compared frame: the cloth has swung and folded, so
/// both of its sides, the ground and the ball are in the picture.
const SRGB_STEPS: u32 = 150;

/// The same frame drawn into an `Rgba8Unorm` target (the PNG path) and a
/// `Bgra8UnormSrgb` one (a game's swap chain) shows the same colours, with
/// the cloth lit and with the strain view.
#[test]
fn an_srgb_target_shows_the_png_colours() {
    let ctx = gpu_common::gpu();
    let scene = Scene::from_toml(SCENE, Path::new("render-test.toml")).expect("the test scene");
    let model = scene.model().expect("the model");
    let mut solver = GpuSolver::new(&ctx.device, &ctx.queue, &model, &scene.params)
        .unwrap_or_else(|e| panic!("GPU solver: {e}"));
    solver
        .step(SRGB_STEPS)
        .unwrap_or_else(|e| panic!("stepping: {e}"));
    let camera = Camera::framing(&model, &scene.params, WIDTH as f32 / HEIGHT as f32);
    let srgb = RendererFormats {
        color: wgpu::TextureFormat::Bgra8UnormSrgb,
        ..RendererFormats::default()
    };
    for strain in [false, true] {
        let frame = |formats: RendererFormats| {
            let mut renderer =
                Renderer::with_formats(&ctx.device, &ctx.queue, &scene.params, &camera, formats)
                    .unwrap_or_else(|e| panic!("renderer for {formats:?}: {e}"));
            if strain {
                renderer.show_strain(&ctx.device, &model, &solver);
            }
            let target = FrameTarget::with_formats(&ctx.device, WIDTH, HEIGHT, formats);
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            solver.encode_normals(&mut encoder);
            renderer.encode_frame(&mut encoder, &solver, &target);
            ctx.queue.submit([encoder.finish()]);
            render::read_rgba(&ctx.device, &ctx.queue, &target.color)
                .unwrap_or_else(|e| panic!("reading {formats:?} back: {e}"))
        };
        let plain = frame(RendererFormats::default());
        let bgra = frame(srgb);
        assert_eq!(plain.len(), bgra.len());
        let (mut worst, mut at, mut drawn) = (0, 0, 0);
        for (p, (a, b)) in plain.chunks(4).zip(bgra.chunks(4)).enumerate() {
            let swizzled = [b[2], b[1], b[0], b[3]];
            let d = a
                .iter()
                .zip(swizzled)
                .map(|(x, y)| (i32::from(*x) - i32::from(y)).abs())
                .max()
                .unwrap_or(0);
            if d > worst {
                (worst, at) = (d, p);
            }
            drawn += usize::from(a != render::BACKGROUND);
        }
        let pixel = |rgba: &[u8]| rgba[at * 4..at * 4 + 4].to_vec();
        eprintln!("strain view {strain}: worst channel difference {worst} levels");
        assert!(
            worst <= SRGB_ROUNDING_LEVELS,
            "strain view {strain}: pixel ({}, {}) is {:?} on Rgba8Unorm but {:?} (BGRA) on \
             Bgra8UnormSrgb: {worst} levels apart, more than {SRGB_ROUNDING_LEVELS}",
            at as u32 % WIDTH,
            at as u32 / WIDTH,
            pixel(&plain),
            pixel(&bgra)
        );
        // The comparison means something only if the scene was drawn.
        assert!(
            drawn > plain.len() / 4 / 10,
            "strain view {strain}: only {drawn} pixels differ from the background"
        );
    }
}

/// A render mesh over the left half of [`SCENE`]'s cloth (x < 0), a
/// millimetre above it, as two triangles.
fn left_half() -> wgcloth::mesh::Mesh {
    let at = |x: f64, z: f64| wgcloth::glam::DVec3::new(x, 1.001, z);
    let positions = vec![at(-0.5, -0.5), at(0.0, -0.5), at(0.0, 0.5), at(-0.5, 0.5)];
    wgcloth::mesh::Mesh::from_triangles("left half", positions, &[[0, 3, 2], [0, 2, 1]])
        .expect("a valid mesh")
}

/// The first frame of `scene` (`model` its model) as `camera` sees it,
/// each cloth in its colour, with `mesh` drawn as a render mesh embedded
/// on cloth `cloth` of the world (`None`: on the whole model): its RGBA
/// bytes.
fn frame_with_render_mesh(
    scene: &Scene,
    model: &wgcloth::Model,
    mesh: &wgcloth::mesh::Mesh,
    cloth: Option<usize>,
    camera: &Camera,
) -> Vec<u8> {
    use wgcloth::gpu::{GpuRenderMesh, SkinLayout};
    use wgcloth::render_mesh::{Embedding, RenderMesh};
    let ctx = gpu_common::gpu();
    let solver = GpuSolver::new(&ctx.device, &ctx.queue, model, &scene.params)
        .unwrap_or_else(|e| panic!("GPU solver: {e}"));
    let render = RenderMesh::from_mesh(
        Path::new("render mesh"),
        mesh,
        1.0,
        wgcloth::glam::DVec3::ZERO,
    );
    let embedding = match cloth {
        Some(c) => Embedding::on_cloth(model, c, &render, 0.01),
        None => Embedding::new(model, &render, 0.01),
    }
    .expect("embeds");
    let mesh =
        GpuRenderMesh::new(&solver, &embedding, SkinLayout::POSITION_NORMAL).expect("render mesh");
    let mut renderer = Renderer::new(&ctx.device, &ctx.queue, &scene.params, camera);
    renderer.set_cloth_colors(&ctx.device, model, &scene.cloth_colors());
    renderer.set_render_meshes(vec![mesh]).expect("its layout");
    let target = FrameTarget::new(&ctx.device, WIDTH, HEIGHT);
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    solver.encode_normals(&mut encoder);
    renderer.encode_frame(&mut encoder, &solver, &target);
    ctx.queue.submit([encoder.finish()]);
    render::read_rgba(&ctx.device, &ctx.queue, &target.color).expect("read back")
}

#[test]
fn a_render_mesh_is_drawn_in_place_of_the_cloth() {
    let scene = Scene::from_toml(SCENE, Path::new("render-test.toml")).expect("the test scene");
    let model = scene.model().expect("the model");
    let camera = Camera::framing(&model, &scene.params, WIDTH as f32 / HEIGHT as f32);
    let rgba = frame_with_render_mesh(&scene, &model, &left_half(), None, &camera);
    // The interior particles: cloth where the render mesh lies (x ≤ −0.2),
    // none where only the cloth would be (x ≥ 0.2).
    let rest: Vec<Vec3> = model.rest_positions.iter().map(|p| p.as_vec3()).collect();
    let (mut left, mut right) = (0, 0);
    for x in interior(&rest) {
        let c = colour_at(&rgba, &camera, x);
        let cloth = is_cloth(c);
        if x.x <= -0.2 {
            assert!(cloth, "{x:?}: the render mesh is not drawn there ({c:?})");
            left += 1;
        } else if x.x >= 0.2 {
            assert!(
                !cloth,
                "{x:?}: the cloth is drawn beside its render mesh ({c:?})"
            );
            right += 1;
        }
    }
    assert!(
        left > 0 && right > 0,
        "{left} and {right} particles checked"
    );
}

/// Two 9 × 9 cloths side by side, one green and one blue: a world
/// (`[[cloth]]`) whose cloths each take their `color`.
const WORLD: &str = r#"
[simulation]
integrator = "explicit"
dt = 0.002

[[cloth]]
resolution = [9, 9]
size = [0.8, 0.8]
origin = [-0.9, 1.0, -0.4]
pins = ["top-left", "top-right"]
color = [0.1, 0.7, 0.1]

[[cloth]]
resolution = [9, 9]
size = [0.8, 0.8]
origin = [0.1, 1.0, -0.4]
pins = ["top-left", "top-right"]
color = [0.1, 0.1, 0.8]
"#;

/// Index of the channel of `c` that exceeds the other two by more than
/// [`CLOTH_RED_MARGIN`], if one does.
fn dominant(c: [u8; 4]) -> Option<usize> {
    (0..3).find(|&k| {
        (0..3)
            .filter(|&j| j != k)
            .all(|j| i32::from(c[k]) - i32::from(c[j]) > CLOTH_RED_MARGIN)
    })
}

#[test]
fn each_cloth_of_a_world_is_drawn_in_its_colour() {
    let scene = Scene::from_toml(WORLD, Path::new("world.toml")).expect("the world");
    let model = scene.model().expect("the model");
    let (dir, frame, rgba) = first_frame(&scene, "world", false);
    let camera = Camera::for_scene(&scene, &model, WIDTH as f32 / HEIGHT as f32);
    let rest: Vec<Vec3> = model.rest_positions.iter().map(|p| p.as_vec3()).collect();
    for (cloth, channel) in [(0, 1), (1, 2)] {
        let x = &rest[81 * cloth..81 * (cloth + 1)];
        for p in interior(x) {
            let c = colour_at(&rgba, &camera, p);
            assert_eq!(
                dominant(c),
                Some(channel),
                "{}: cloth {cloth} at {p:?}: colour {c:?}",
                frame.display()
            );
        }
    }
    std::fs::remove_dir_all(&dir).expect("remove the test directory");
}

/// A render mesh over the left half of [`WORLD`]'s second cloth
/// (0.1 ≤ x ≤ 0.5), a millimetre above it, as two triangles.
fn second_cloth_left_half() -> wgcloth::mesh::Mesh {
    let at = |x: f64, z: f64| wgcloth::glam::DVec3::new(x, 1.001, z);
    let positions = vec![at(0.1, -0.4), at(0.5, -0.4), at(0.5, 0.4), at(0.1, 0.4)];
    wgcloth::mesh::Mesh::from_triangles(
        "second cloth's left half",
        positions,
        &[[0, 3, 2], [0, 2, 1]],
    )
    .expect("a valid mesh")
}

/// A render mesh on one cloth of a world is drawn in place of that cloth
/// alone, in its colour: the first cloth green everywhere, the second blue
/// where its render mesh lies and not drawn where only it would be (a
/// mesh drawn in place of every cloth leaves the first undrawn; one in the
/// first's colour draws the second's half green).
#[test]
fn a_render_mesh_on_one_cloth_of_a_world_replaces_that_cloth_alone() {
    use wgcloth::render_mesh::{Embedding, RenderMesh};
    let scene = Scene::from_toml(WORLD, Path::new("world.toml")).expect("the world");
    let model = scene.model().expect("the model");
    let half = second_cloth_left_half();
    let render = RenderMesh::from_mesh(Path::new("half"), &half, 1.0, wgcloth::glam::DVec3::ZERO);
    assert!(
        Embedding::on_cloth(&model, 0, &render, 0.01).is_err(),
        "the mesh lies on the second cloth, not the first"
    );
    let camera = Camera::for_scene(&scene, &model, WIDTH as f32 / HEIGHT as f32);
    let rgba = frame_with_render_mesh(&scene, &model, &half, Some(1), &camera);
    let rest: Vec<Vec3> = model.rest_positions.iter().map(|p| p.as_vec3()).collect();
    let mut checked = [0; 3];
    for p in interior(&rest[..81]) {
        let c = colour_at(&rgba, &camera, p);
        assert_eq!(dominant(c), Some(1), "first cloth at {p:?}: colour {c:?}");
        checked[0] += 1;
    }
    for p in interior(&rest[81..]) {
        let c = colour_at(&rgba, &camera, p);
        if p.x <= 0.4 {
            assert_eq!(
                dominant(c),
                Some(2),
                "second cloth's render mesh at {p:?}: colour {c:?}"
            );
            checked[1] += 1;
        } else if p.x >= 0.6 {
            assert_eq!(
                c,
                render::BACKGROUND,
                "{p:?}: the second cloth is drawn beside its render mesh"
            );
            checked[2] += 1;
        }
    }
    assert!(
        checked.iter().all(|&n| n > 0),
        "{checked:?} particles checked"
    );
}
