//! Every WGSL kernel parses and validates with naga (no GPU needed), and
//! every Pod twin matches its WGSL struct field by field.

use naga::valid::{Capabilities, ValidationFlags, Validator};
use wgcloth::gpu::layout::{GpuParams, GpuSphere, GpuSpring};
use wgcloth::gpu::shaders;
use wgcloth::gpu::GridBlock;

fn parse(name: &str) -> naga::Module {
    parse_for(name, GridBlock::ONE)
}

fn parse_for(name: &str, block: GridBlock) -> naga::Module {
    let source = shaders::kernel_source(name, block).unwrap_or_else(|e| panic!("{name}: {e}"));
    let module = naga::front::wgsl::parse_str(&source)
        .unwrap_or_else(|e| panic!("{name} does not parse:\n{}", e.emit_to_string(&source)));
    Validator::new(ValidationFlags::all(), Capabilities::all())
        .validate(&module)
        .unwrap_or_else(|e| panic!("{name} does not validate:\n{}", e.emit_to_string(&source)));
    module
}

#[test]
fn every_kernel_parses_and_validates() {
    assert!(!shaders::KERNELS.is_empty());
    for (name, _) in shaders::KERNELS {
        let module = parse(name);
        assert!(
            module.entry_points.iter().any(|e| e.name == *name),
            "{name}.wgsl must define the entry point `{name}`"
        );
    }
}

/// The generated grid gather validates for every block shape the solver
/// accepts, in every kernel that includes it.
#[test]
fn every_grid_block_shape_validates() {
    for cols in 1..=GridBlock::MAX {
        for rows in 1..=GridBlock::MAX {
            let block = GridBlock { cols, rows };
            for (name, source) in shaders::KERNELS {
                if source.contains("generated/grid_block") {
                    parse_for(name, block);
                }
            }
        }
    }
}

#[test]
fn an_unknown_include_is_an_error() {
    assert!(shaders::compose("#include \"common/missing.wgsl\"", GridBlock::ONE).is_err());
}

/// (field name, byte offset) of a WGSL struct, and its size.
fn wgsl_layout(module: &naga::Module, name: &str) -> (Vec<(String, u32)>, u32) {
    let ty = module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some(name))
        .map(|(_, t)| t)
        .unwrap_or_else(|| panic!("no WGSL struct {name}"));
    let naga::TypeInner::Struct { members, span } = &ty.inner else {
        panic!("{name} is not a struct");
    };
    let fields = members
        .iter()
        .map(|m| (m.name.clone().unwrap_or_default(), m.offset))
        .collect();
    (fields, *span)
}

macro_rules! offsets {
    ($ty:ty { $($field:ident),* $(,)? }) => {
        vec![$((stringify!($field).to_string(), std::mem::offset_of!($ty, $field) as u32)),*]
    };
}

#[test]
fn pod_twins_match_their_wgsl_structs() {
    let module = parse("explicit_integrate");
    let check = |name: &str, rust: Vec<(String, u32)>, size: usize| {
        let (wgsl, span) = wgsl_layout(&module, name);
        assert_eq!(
            span as usize, size,
            "{name}: WGSL size {span}, Rust size {size}"
        );
        // Rust pads with arrays named `_pad`; compare the named fields.
        for (field, offset) in &rust {
            let found = wgsl.iter().find(|(n, _)| n == field);
            assert_eq!(
                found.map(|f| f.1),
                Some(*offset),
                "{name}.{field}: Rust offset {offset}, WGSL {found:?}"
            );
        }
        let named = wgsl.iter().filter(|(n, _)| !n.starts_with("_pad")).count();
        assert_eq!(named, rust.len(), "{name}: WGSL fields {wgsl:?}");
    };
    check(
        "Params",
        offsets!(GpuParams {
            gravity,
            dt,
            wind_velocity,
            wind_drag,
            wind_lift,
            ground_height,
            ground_friction,
            fixup_omega,
            particle_count,
            spring_count,
            triangle_count,
            sphere_count,
            spring_adj_entries,
            tri_adj_offsets,
            tri_adj_entries,
            triangles,
            cg_tolerance_sq,
            partial_count,
            filter_count,
            torque_compensation,
            grid,
            grid_rest_a,
            grid_rest_b,
            grid_max_a,
            grid_max_b,
            kind_k,
            kind_kd,
            kind_a,
            coarse,
            spheres
        }),
        std::mem::size_of::<GpuParams>(),
    );
    check(
        "Spring",
        offsets!(GpuSpring {
            i,
            j,
            rest,
            k,
            kd,
            max_len
        }),
        std::mem::size_of::<GpuSpring>(),
    );
    check(
        "Sphere",
        offsets!(GpuSphere {
            center,
            radius,
            friction
        }),
        std::mem::size_of::<GpuSphere>(),
    );
}

/// The render shader (not a compute kernel, so not in `KERNELS`) parses,
/// validates, has the entry points the renderer names, and its `Globals`
/// has the size of the host's twin.
#[test]
fn render_shader_parses_and_validates() {
    let source = wgcloth::render::SHADER;
    let module = naga::front::wgsl::parse_str(source).unwrap_or_else(|e| {
        panic!(
            "shaders/render/mesh.wgsl does not parse:\n{}",
            e.emit_to_string(source)
        )
    });
    Validator::new(ValidationFlags::all(), Capabilities::all())
        .validate(&module)
        .unwrap_or_else(|e| {
            panic!(
                "shaders/render/mesh.wgsl does not validate:\n{}",
                e.emit_to_string(source)
            )
        });
    for entry in ["vs_cloth", "vs_cloth_strain", "vs_collider", "fs_main"] {
        assert!(
            module.entry_points.iter().any(|e| e.name == entry),
            "mesh.wgsl must define `{entry}`"
        );
    }
    let (_, size) = wgsl_layout(&module, "Globals");
    assert_eq!(size, wgcloth::render::GLOBALS_BYTES);
}
