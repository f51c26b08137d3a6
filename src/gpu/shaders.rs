//! WGSL sources: one kernel per file under `shaders/`, shared code under
//! `shaders/common/`.
//!
//! Sharing goes through exactly one mechanism: a line
//! `#include "common/NAME.wgsl"` is replaced by that file's text, once per
//! kernel (a second include of the same file is dropped), before the source
//! reaches wgpu or naga. One include is generated rather than stored:
//! `generated/grid_block.wgsl`, the block gather of the grid kernels for
//! the solver's [`GridBlock`] (see [`GridBlock::wgsl`]). Everything is embedded with `include_str!`, so the
//! crate needs no files at run time, and `tests/shaders.rs` validates every
//! composed kernel with naga on any machine.

use super::grid::GridBlock;

/// The include that [`GridBlock::wgsl`] generates.
const GRID_BLOCK: &str = "generated/grid_block";

/// `(name, source)` of `shaders/NAME.wgsl`, embedded at compile time.
macro_rules! wgsl {
    ($name:literal) => {
        (
            $name,
            include_str!(concat!("../../shaders/", $name, ".wgsl")),
        )
    };
}

/// Shared files an `#include` may name.
const COMMON: &[(&str, &str)] = &[
    wgsl!("common/bindings"),
    wgsl!("common/physics"),
    wgsl!("common/cg"),
    wgsl!("common/coarse"),
    wgsl!("common/apply_block"),
    wgsl!("common/no_spring_data"),
    wgsl!("common/torque"),
];

/// Every kernel: (entry point = file stem, source before composition).
pub const KERNELS: &[(&str, &str)] = &[
    wgsl!("spring_forces"),
    wgsl!("explicit_integrate"),
    wgsl!("explicit_seed"),
    wgsl!("fixup_jacobi"),
    wgsl!("finish_step"),
    wgsl!("normals"),
    wgsl!("implicit_springs"),
    wgsl!("implicit_prepare"),
    wgsl!("coarse_setup"),
    wgsl!("cg_prolong"),
    wgsl!("cg_init"),
    wgsl!("cg_start"),
    wgsl!("cg_apply"),
    wgsl!("cg_alpha"),
    wgsl!("cg_update"),
    wgsl!("cg_beta"),
    wgsl!("implicit_finish"),
    wgsl!("semi_rhs"),
    wgsl!("filter_dense"),
    wgsl!("torque_centre"),
    wgsl!("torque_moments"),
    wgsl!("torque_apply"),
    wgsl!("semi_integrate"),
    wgsl!("semi_cg_prepare"),
];

/// A composed kernel source (its grid gather generated for `block`), or
/// the name of the include it could not find.
pub fn compose(source: &str, block: GridBlock) -> Result<String, String> {
    let mut out = String::with_capacity(source.len() * 4);
    let mut seen: Vec<&str> = Vec::new();
    for line in source.lines() {
        let Some(rest) = line.trim().strip_prefix("#include") else {
            out.push_str(line);
            out.push('\n');
            continue;
        };
        let name = rest.trim().trim_matches('"');
        let stem = name.strip_suffix(".wgsl").unwrap_or(name);
        if seen.contains(&stem) {
            continue;
        }
        if stem == GRID_BLOCK {
            seen.push(GRID_BLOCK);
            out.push_str(&block.wgsl());
            continue;
        }
        let Some((name, text)) = COMMON.iter().find(|(n, _)| *n == stem) else {
            return Err(format!("unknown include `{name}`"));
        };
        seen.push(name);
        out.push_str(text);
        out.push('\n');
    }
    Ok(out)
}

/// The composed source of kernel `name` for grid blocks of `block`.
pub fn kernel_source(name: &str, block: GridBlock) -> Result<String, String> {
    let (_, src) = KERNELS
        .iter()
        .find(|(n, _)| *n == name)
        .ok_or_else(|| format!("no kernel `{name}`"))?;
    compose(src, block)
}
