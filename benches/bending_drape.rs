//! Resolution independence of the linear bending model: the same
//! `[material]` plate, clamped along one edge and sagging under its own
//! weight (`wgcloth::evidence::cantilever::plate_drop`), as grids of 17²,
//! 33² and 65² particles and as irregular triangle meshes of 17, 33 and 65
//! rows; its free edge's mean drop over the overhang, the differences
//! between successive resolutions and the order they fall at
//! (`log2` of their ratio). CPU `f64`, implicit, settled to rest.
//! `WGCLOTH_BENCH_SIZES=17,33` picks resolutions.

mod common;

use wgcloth::evidence::cantilever::{plate_drop, PlateMesh};

fn main() {
    let sizes = common::sizes(&[17, 33, 65]);
    println!("clamped plate, drop of the free edge over the overhang (CPU f64, implicit)");
    for (name, make) in [
        ("grid", PlateMesh::Grid as fn(usize) -> PlateMesh),
        (
            "irregular mesh",
            PlateMesh::Irregular as fn(usize) -> PlateMesh,
        ),
    ] {
        let mut previous: Option<(f64, f64)> = None;
        for &n in &sizes {
            let (drop, settled) = plate_drop(make(n)).unwrap_or_else(|e| panic!("{name} {n}: {e}"));
            let difference = previous.map(|(d, _)| drop - d);
            let order = match (previous.map(|(_, diff)| diff), difference) {
                (Some(a), Some(b)) if a != 0.0 && b != 0.0 => {
                    format!("{:.2}", (a / b).abs().log2())
                }
                _ => "-".to_string(),
            };
            println!(
                "{name:<15} {n:>3}: drop {drop:.6}{}  difference {}  order {order}",
                if settled { "" } else { " (not settled)" },
                difference.map_or("-".to_string(), |d| format!("{d:+.6}"))
            );
            previous = Some((drop, difference.unwrap_or(0.0)));
        }
    }
}
