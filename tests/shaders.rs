//! Every WGSL kernel parses and validates with naga (no GPU needed), and
//! every Pod twin matches its WGSL struct field by field.

use naga::valid::{Capabilities, ValidationFlags, Validator};
use wgcloth::gpu::layout::{GpuCapsule, GpuMeshCollider, GpuParams, GpuSphere, GpuSpring};
use wgcloth::gpu::shaders;
use wgcloth::gpu::{GridBlock, Kernel};

fn parse(kernel: Kernel) -> naga::Module {
    parse_for(kernel, GridBlock::ONE)
}

fn parse_for(kernel: Kernel, block: GridBlock) -> naga::Module {
    let source = shaders::kernel_source(kernel, block).unwrap_or_else(|e| panic!("{e}"));
    validate(kernel.name(), &source)
}

/// The module `source` (named `name` in a failure), parsed and validated.
fn validate(name: &str, source: &str) -> naga::Module {
    let module = naga::front::wgsl::parse_str(source)
        .unwrap_or_else(|e| panic!("{name} does not parse:\n{}", e.emit_to_string(source)));
    Validator::new(ValidationFlags::all(), Capabilities::all())
        .validate(&module)
        .unwrap_or_else(|e| panic!("{name} does not validate:\n{}", e.emit_to_string(source)));
    module
}

/// The agreement probe the GPU tests run (`tests/gpu_common/probe.wgsl`)
/// validates too, so a machine without a GPU checks it.
#[test]
fn the_agreement_probe_parses_and_validates() {
    let module = validate(
        "tests/gpu_common/probe.wgsl",
        include_str!("gpu_common/probe.wgsl"),
    );
    assert!(
        module.entry_points.iter().any(|e| e.name == "probe"),
        "the probe's entry point"
    );
}

#[test]
fn every_kernel_parses_and_validates() {
    for kernel in Kernel::ALL {
        let module = parse(kernel);
        let name = kernel.name();
        assert!(
            module.entry_points.iter().any(|e| e.name == name),
            "{name}.wgsl must define the entry point `{name}`"
        );
    }
}

/// Storage buffers per shader stage that every WebGPU device grants
/// (`maxStorageBuffersPerShaderStage`, `wgpu::Limits::default()`).
const WEBGPU_STORAGE_BUFFERS: usize = 8;

/// The `(group, binding)` of each storage buffer `kernel`'s pipeline
/// layout binds, from naga's analysis of the composed module: every
/// storage buffer of group 0, which one layout shared by the kernels binds
/// whole (`src/gpu/kernels.rs`), and those of the later groups that the
/// entry point uses (each kernel's own group 1 binds only those).
fn storage_bindings(kernel: Kernel, block: GridBlock) -> Vec<(u32, u32)> {
    let source = shaders::kernel_source(kernel, block).unwrap_or_else(|e| panic!("{e}"));
    let module = naga::front::wgsl::parse_str(&source)
        .unwrap_or_else(|e| panic!("{kernel} does not parse:\n{}", e.emit_to_string(&source)));
    let info = Validator::new(ValidationFlags::all(), Capabilities::all())
        .validate(&module)
        .unwrap_or_else(|e| panic!("{kernel} does not validate:\n{}", e.emit_to_string(&source)));
    let entry = module
        .entry_points
        .iter()
        .position(|e| e.name == kernel.name())
        .unwrap_or_else(|| panic!("{kernel} has no entry point"));
    let used = info.get_entry_point(entry);
    module
        .global_variables
        .iter()
        .filter(|(_, g)| matches!(g.space, naga::AddressSpace::Storage { .. }))
        .filter_map(|(h, g)| {
            let b = g.binding.as_ref()?;
            (b.group == 0 || !used[h].is_empty()).then_some((b.group, b.binding))
        })
        .collect()
}

/// No kernel uses more storage buffers than WebGPU grants every device,
/// for every grid block shape (the pipeline layouts are checked against
/// the same limit on a device by `tests/default_limits.rs`).
#[test]
fn every_kernel_binds_at_most_webgpu_s_storage_buffers() {
    let mut widest = 0;
    for kernel in Kernel::ALL {
        for block in [GridBlock::ONE, GridBlock { cols: 2, rows: 2 }] {
            let used = storage_bindings(kernel, block);
            assert!(
                used.len() <= WEBGPU_STORAGE_BUFFERS,
                "{kernel} uses {} storage buffers, more than WebGPU's \
                 {WEBGPU_STORAGE_BUFFERS}: {used:?}",
                used.len()
            );
            widest = widest.max(used.len());
        }
    }
    // The count is of something: cg_init binds group 0's six and both
    // argument buffers, cg_apply one of them, a workgroup kernel group
    // 0's six and its cloth table.
    let count = |k: Kernel| storage_bindings(k, GridBlock::ONE).len();
    assert_eq!(count(Kernel::CgInit), 8);
    assert_eq!(count(Kernel::CgApply), 7);
    assert_eq!(count(Kernel::ClothImplicit), 7);
    assert_eq!(widest, 8);
}

/// `Kernel::ALL` names every file of `shaders/` (the render shader's
/// folder aside), so no kernel is left out of these tests.
#[test]
fn every_kernel_file_has_a_kernel() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let mut files: Vec<String> = std::fs::read_dir(&dir)
        .expect("shaders/")
        .filter_map(|e| {
            let name = e.ok()?.file_name().into_string().ok()?;
            Some(name.strip_suffix(".wgsl")?.to_string())
        })
        .collect();
    files.sort();
    let mut kernels: Vec<String> = Kernel::ALL.iter().map(|k| k.name().to_string()).collect();
    kernels.sort();
    assert_eq!(files, kernels);
}

/// The generated grid gather validates for every block shape the solver
/// accepts, in every kernel that includes it.
#[test]
fn every_grid_block_shape_validates() {
    for cols in 1..=GridBlock::MAX {
        for rows in 1..=GridBlock::MAX {
            let block = GridBlock { cols, rows };
            for kernel in Kernel::ALL {
                if kernel.source().contains("generated/grid_block") {
                    parse_for(kernel, block);
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
    let module = parse(Kernel::ExplicitIntegrate);
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
            particle_base,
            spring_base,
            topo_base,
            work_base,
            spring_work_base,
            partial_base,
            status_base,
            dense_base,
            integrator,
            fixup_iterations,
            cg_max_iterations,
            features,
            grid,
            grid_rest_a,
            grid_rest_b,
            grid_max_a,
            grid_max_b,
            kind_k,
            kind_kd,
            kind_a,
            coarse,
            coarse_world,
            coarse_pieces,
            motion,
            self_collision,
            self_grid,
            spheres,
            capsules,
            mesh,
            meshes,
            bending,
            bending_rows
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
            velocity,
            friction
        }),
        std::mem::size_of::<GpuSphere>(),
    );
    check(
        "Capsule",
        offsets!(GpuCapsule {
            a,
            radius,
            b,
            friction,
            velocity
        }),
        std::mem::size_of::<GpuCapsule>(),
    );
    check(
        "MeshCollider",
        offsets!(GpuMeshCollider {
            rotation,
            position,
            friction,
            velocity,
            thickness,
            angular_velocity,
            grid
        }),
        std::mem::size_of::<GpuMeshCollider>(),
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

/// What a kernel that includes a hook file of the grid gather defines
/// itself (see the files' heads): a stub of each, in the kernel's types.
const HOOKS: [(&str, &str); 3] = [
    // Binding 0 comes from common/bindings.wgsl or cloth_bindings.wgsl.
    ("common/layout", "var<private> params: Params;\n"),
    (
        "common/apply_block",
        "const APPLY_SEC: u32 = W_S;\n\
         fn apply_value(pt: GridPoint, stored: vec4<f32>) -> vec3<f32> { return stored.xyz; }\n\
         fn apply_end(p: u32, s: vec4<f32>, as_p: vec3<f32>) {}\n",
    ),
    (
        "common/no_spring_data",
        "struct BlockData { x: vec4<f32> }\n",
    ),
];

/// Each common file includes what it uses: composed on its own (a hook
/// file with stubs of what its including kernel defines), it parses and
/// validates.
#[test]
fn every_common_file_validates_on_its_own() {
    for (name, _) in shaders::COMMON {
        let hooks = HOOKS.iter().find(|(h, _)| h == name).map_or("", |h| h.1);
        let source = shaders::compose(
            &format!("#include \"{name}.wgsl\"\n{hooks}"),
            GridBlock::ONE,
        )
        .unwrap_or_else(|e| panic!("{name}: {e}"));
        validate(name, &source);
    }
}

#[test]
fn an_include_cycle_is_an_error() {
    let err = shaders::compose_with(
        "#include \"common/a.wgsl\"",
        GridBlock::ONE,
        &[
            ("common/a", "#include \"common/b.wgsl\"\n"),
            ("common/b", "#include \"common/a.wgsl\"\n"),
        ],
    )
    .expect_err("a cycle");
    assert!(err.contains("common/a → common/b → common/a"), "{err}");
}

/// The generated constants hold the values of `wgcloth::kernel_config`,
/// read back through naga from a composed kernel.
#[test]
fn the_shared_constants_reach_the_kernels() {
    let module = parse(Kernel::CgUpdate);
    let value = |name: &str| -> Option<f64> {
        let init = module
            .constants
            .iter()
            .find(|(_, c)| c.name.as_deref() == Some(name))
            .map(|(_, c)| c.init)
            .or_else(|| {
                module
                    .overrides
                    .iter()
                    .find(|(_, o)| o.name.as_deref() == Some(name))
                    .and_then(|(_, o)| o.init)
            })?;
        match module.global_expressions[init] {
            naga::Expression::Literal(naga::Literal::U32(v)) => Some(f64::from(v)),
            naga::Expression::Literal(naga::Literal::F32(v)) => Some(f64::from(v)),
            _ => None,
        }
    };
    let values = wgcloth::kernel_config::wgsl_values();
    assert!(values.len() > 40, "{values:?}");
    for (name, expected) in values {
        assert_eq!(value(&name), Some(expected), "{name}");
    }
}
