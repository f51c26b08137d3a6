//! WGSL sources: one kernel per file under `shaders/` ([`Kernel`]), shared
//! code under `shaders/common/`.
//!
//! Sharing goes through exactly one mechanism: a line
//! `#include "common/NAME.wgsl"` is replaced by that file's text, itself
//! composed the same way, before the source reaches wgpu or naga. Each
//! file is included once per kernel (a later include of it is dropped),
//! and an include cycle is an error. Two includes are generated rather
//! than stored: `generated/config.wgsl`, the shared numbers of
//! [`crate::kernel_config`] (see [`kernel_config::wgsl`]), and
//! `generated/grid_block.wgsl`, the block gather of the grid kernels for
//! the solver's [`GridBlock`] (see [`GridBlock::wgsl`]). One file stands in
//! for another (`STANDS_IN`): `common/cloth_bindings.wgsl`, the
//! workgroup kernels' bind group, for `common/bindings.wgsl`, so the
//! common files that include the latter serve both kinds of kernel. Everything is
//! embedded with `include_str!`, so the crate needs no files at run time,
//! and `tests/shaders.rs` validates every composed kernel and every common
//! file with naga on any machine.

use super::grid::GridBlock;
use super::kernel::Kernel;
use crate::kernel_config;

/// The include that [`GridBlock::wgsl`] generates.
const GRID_BLOCK: &str = "generated/grid_block";
/// The include that [`kernel_config::wgsl`] generates.
const CONFIG: &str = "generated/config";

/// `(name, source)` of `shaders/NAME.wgsl`, embedded at compile time.
macro_rules! wgsl {
    ($name:literal) => {
        (
            $name,
            include_str!(concat!("../../shaders/", $name, ".wgsl")),
        )
    };
}

/// `(file, the file it stands in for)`: once the first is included, an
/// include of the second is already satisfied; the first included after
/// the second is an error (both declare `params`).
const STANDS_IN: &[(&str, &str)] = &[("common/cloth_bindings", "common/bindings")];

/// Shared files an `#include` may name.
pub const COMMON: &[(&str, &str)] = &[
    wgsl!("common/vector"),
    wgsl!("common/layout"),
    wgsl!("common/bindings"),
    wgsl!("common/cloth_bindings"),
    wgsl!("common/step"),
    wgsl!("common/fixup"),
    wgsl!("common/cloth_step"),
    wgsl!("common/semi"),
    wgsl!("common/physics"),
    wgsl!("common/bending"),
    wgsl!("common/cg"),
    wgsl!("common/coarse_layout"),
    wgsl!("common/coarse"),
    wgsl!("common/implicit"),
    wgsl!("common/apply_block"),
    wgsl!("common/no_spring_data"),
    wgsl!("common/torque"),
    wgsl!("common/self_collision"),
    wgsl!("common/cloth_self_collision"),
    wgsl!("common/skin"),
];

/// A composed source (its grid gather generated for `block`), or what is
/// wrong with its includes: a file that does not exist, or a cycle.
pub fn compose(source: &str, block: GridBlock) -> Result<String, String> {
    compose_with(source, block, COMMON)
}

/// [`compose`] with the shared files `common` (for tests of the mechanism).
pub fn compose_with(
    source: &str,
    block: GridBlock,
    common: &[(&'static str, &'static str)],
) -> Result<String, String> {
    let mut out = String::with_capacity(source.len() * 4);
    let mut done = Vec::new();
    let mut open = Vec::new();
    include_into(source, block, common, &mut out, &mut done, &mut open)?;
    Ok(out)
}

/// Appends `source` to `out` with its includes resolved; `done` are the
/// files already included, `open` the chain of files being included.
fn include_into(
    source: &str,
    block: GridBlock,
    common: &[(&'static str, &'static str)],
    out: &mut String,
    done: &mut Vec<&'static str>,
    open: &mut Vec<&'static str>,
) -> Result<(), String> {
    for line in source.lines() {
        let Some(rest) = line.trim().strip_prefix("#include") else {
            out.push_str(line);
            out.push('\n');
            continue;
        };
        let name = rest.trim().trim_matches('"');
        let stem = name.strip_suffix(".wgsl").unwrap_or(name);
        if let Some(k) = open.iter().position(|&o| o == stem) {
            let mut chain = open[k..].to_vec();
            chain.push(open[k]);
            return Err(format!("include cycle: {}", chain.join(" → ")));
        }
        if done.contains(&stem) {
            continue;
        }
        if let Some(&(_, replaced)) = STANDS_IN.iter().find(|(by, _)| *by == stem) {
            if done.contains(&replaced) {
                return Err(format!(
                    "`{stem}` is included after `{replaced}`, which it stands in for: \
                     include it first"
                ));
            }
            done.push(replaced);
        }
        if stem == GRID_BLOCK {
            done.push(GRID_BLOCK);
            out.push_str(&block.wgsl());
            continue;
        }
        if stem == CONFIG {
            done.push(CONFIG);
            out.push_str(&kernel_config::wgsl());
            continue;
        }
        let Some(&(name, text)) = common.iter().find(|(n, _)| *n == stem) else {
            return Err(format!("unknown include `{name}`"));
        };
        open.push(name);
        include_into(text, block, common, out, done, open)?;
        open.pop();
        done.push(name);
        out.push('\n');
    }
    Ok(())
}

/// The composed source of `kernel` for grid blocks of `block`.
pub fn kernel_source(kernel: Kernel, block: GridBlock) -> Result<String, String> {
    compose(kernel.source(), block).map_err(|e| format!("shaders/{kernel}.wgsl: {e}"))
}
