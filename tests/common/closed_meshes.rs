//! Closed meshes as OBJ text for the mesh collider tests and benches
//! (`tests/mesh_colliders.rs`, `benches/mesh_collider.rs`, which include
//! this file by path): unions of voxels and UV spheres.

use std::collections::HashMap;
use std::fmt::Write as _;

/// A closed mesh's OBJ text: the boundary of a union of unit voxels
/// (`filled(i, j, k)` over `0..n`), each face a quad wound outward.
#[allow(dead_code, reason = "the bench bakes spheres only")]
pub fn voxels(n: [i32; 3], filled: impl Fn(i32, i32, i32) -> bool) -> String {
    let inside =
        |p: [i32; 3]| (0..3).all(|a| (0..n[a]).contains(&p[a])) && filled(p[0], p[1], p[2]);
    let mut index: HashMap<[i32; 3], usize> = HashMap::new();
    let mut verts = String::new();
    let mut faces = String::new();
    let mut vertex = |p: [i32; 3], verts: &mut String| {
        let next = index.len() + 1;
        *index.entry(p).or_insert_with(|| {
            let _ = writeln!(verts, "v {} {} {}", p[0], p[1], p[2]);
            next
        })
    };
    for i in 0..n[0] {
        for j in 0..n[1] {
            for k in 0..n[2] {
                if !inside([i, j, k]) {
                    continue;
                }
                for d in 0..3 {
                    let (u, v) = ((d + 1) % 3, (d + 2) % 3);
                    let unit = |a: usize| {
                        let mut e = [0; 3];
                        e[a] = 1;
                        e
                    };
                    let add = |p: [i32; 3], q: [i32; 3]| [p[0] + q[0], p[1] + q[1], p[2] + q[2]];
                    for positive in [true, false] {
                        let mut nb = [i, j, k];
                        nb[d] += if positive { 1 } else { -1 };
                        if inside(nb) {
                            continue;
                        }
                        let p = if positive {
                            add([i, j, k], unit(d))
                        } else {
                            [i, j, k]
                        };
                        let (eu, ev) = (unit(u), unit(v));
                        let ring = if positive {
                            [p, add(p, eu), add(add(p, eu), ev), add(p, ev)]
                        } else {
                            [p, add(p, ev), add(add(p, eu), ev), add(p, eu)]
                        };
                        let ids = ring.map(|c| vertex(c, &mut verts));
                        let _ = writeln!(faces, "f {} {} {} {}", ids[0], ids[1], ids[2], ids[3]);
                    }
                }
            }
        }
    }
    verts + &faces
}

/// A UV sphere of unit radius, `rings` × `segments`, as OBJ text.
pub fn uv_sphere(rings: usize, segments: usize) -> String {
    let mut s = String::from("v 0 1 0\n");
    for i in 1..rings {
        let theta = std::f64::consts::PI * i as f64 / rings as f64;
        for j in 0..segments {
            let phi = std::f64::consts::TAU * j as f64 / segments as f64;
            let _ = writeln!(
                s,
                "v {} {} {}",
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin()
            );
        }
    }
    s += "v 0 -1 0\n";
    let ring = |i: usize, j: usize| 2 + (i - 1) * segments + j % segments;
    let south = 2 + (rings - 1) * segments;
    for j in 0..segments {
        let _ = writeln!(s, "f 1 {} {}", ring(1, j + 1), ring(1, j));
        for i in 1..rings - 1 {
            let (a, b, c, d) = (
                ring(i, j),
                ring(i, j + 1),
                ring(i + 1, j + 1),
                ring(i + 1, j),
            );
            let _ = writeln!(s, "f {a} {b} {c}\nf {a} {c} {d}");
        }
        let _ = writeln!(
            s,
            "f {south} {} {}",
            ring(rings - 1, j),
            ring(rings - 1, j + 1)
        );
    }
    s
}
