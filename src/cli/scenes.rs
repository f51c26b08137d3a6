//! `wgcloth scenes`: the built-in scenes, one line each.

use anyhow::Context as _;
use wgcloth::Scene;

/// Prints every built-in scene with its size, integrator, time step and
/// duration.
pub fn list() -> anyhow::Result<()> {
    let names = Scene::builtin_names();
    let width = names.iter().map(|n| n.len()).max().unwrap_or(0);
    for name in names {
        // A built-in that does not load is a bug in the crate, not the
        // user's input: say which one.
        let scene = Scene::builtin(name).with_context(|| format!("built-in scene `{name}`"))?;
        outln!(
            "{name:<width$}  {}, {}, dt = {}, {} s",
            scene.cloth_summary(),
            scene.params.integrator,
            super::summary::time_step(scene.params.dt),
            scene.duration
        )?;
    }
    Ok(())
}
