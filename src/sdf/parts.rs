//! Which way each connected part of a closed mesh is wound.
//!
//! A part (faces joined through shared vertices) wound outward encloses a
//! positive volume; one wound inward, a negative one. An inward part is
//! meant only as a cavity: the hollow inside a solid part, which the
//! other parts' winding number at it says (1 inside one solid, 0 outside
//! every part). An inward part anywhere else is a part turned inside out
//! by mistake: a cloth meeting it would fall into it and rest inside, so
//! it is refused, naming the part. A mesh whose total volume is negative
//! is wound inside out throughout and is turned over as a whole first.

use glam::DVec3;

/// A part's winding number below which a point counts as outside it: the
/// generalised winding number of a closed surface is 0 outside and ±1
/// inside, exactly up to rounding, so halfway decides.
const INSIDE_WINDING: f64 = 0.5;

/// The connected parts of `index` (triangles' corners, `vertices`
/// vertices): each triangle's part number, and how many parts there are.
pub(super) fn parts(index: &[[u32; 3]], vertices: usize) -> (Vec<usize>, usize) {
    let mut parent: Vec<usize> = (0..vertices).collect();
    fn root(parent: &mut [usize], mut v: usize) -> usize {
        while parent[v] != v {
            parent[v] = parent[parent[v]];
            v = parent[v];
        }
        v
    }
    for t in index {
        for k in 1..3 {
            let (a, b) = (
                root(&mut parent, t[0] as usize),
                root(&mut parent, t[k] as usize),
            );
            parent[a.max(b)] = a.min(b);
        }
    }
    let mut number = vec![usize::MAX; vertices];
    let mut count = 0;
    let of: Vec<usize> = index
        .iter()
        .map(|t| {
            let r = root(&mut parent, t[0] as usize);
            if number[r] == usize::MAX {
                number[r] = count;
                count += 1;
            }
            number[r]
        })
        .collect();
    (of, count)
}

/// Six times the signed volume of each of `count` parts (`part` of each
/// triangle of `tris`) \[m³\].
pub(super) fn volumes(tris: &[[DVec3; 3]], part: &[usize], count: usize) -> Vec<f64> {
    let mut v = vec![0.0; count];
    for ([a, b, c], &p) in tris.iter().zip(part) {
        v[p] += a.dot(b.cross(*c));
    }
    v
}

/// The winding number at `x` of the triangles of `tris` outside part
/// `skip` (Van Oosterom and Strackee's solid angle, summed over 4π).
fn winding_without(tris: &[[DVec3; 3]], part: &[usize], skip: usize, x: DVec3) -> f64 {
    let mut sum = 0.0;
    for ([a, b, c], &p) in tris.iter().zip(part) {
        if p == skip {
            continue;
        }
        let (a, b, c) = (*a - x, *b - x, *c - x);
        let (la, lb, lc) = (a.length(), b.length(), c.length());
        let det = a.dot(b.cross(c));
        let den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
        sum += 2.0 * det.atan2(den);
    }
    sum / (4.0 * std::f64::consts::PI)
}

/// The first part wound inward (negative volume, `volume`: six times it)
/// that lies inside no other part, if any: its number and its first
/// triangle.
pub(super) fn stray_inward_part(
    tris: &[[DVec3; 3]],
    part: &[usize],
    volume: &[f64],
) -> Option<(usize, usize)> {
    (0..volume.len())
        .filter(|&p| volume[p] < 0.0)
        .find_map(|p| {
            let first = part.iter().position(|&q| q == p)?;
            let inside = winding_without(tris, part, p, tris[first][0]) > INSIDE_WINDING;
            (!inside).then_some((p, first))
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 12 outward triangles of the axis-aligned cube `centre ± h`.
    fn cube(centre: DVec3, h: f64, first: u32) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let v: Vec<DVec3> = (0..8)
            .map(|k| {
                centre
                    + h * DVec3::new(
                        if k & 1 == 0 { -1.0 } else { 1.0 },
                        if k & 2 == 0 { -1.0 } else { 1.0 },
                        if k & 4 == 0 { -1.0 } else { 1.0 },
                    )
            })
            .collect();
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let t = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .map(|t: [u32; 3]| t.map(|i| i + first))
            .collect();
        (v, t)
    }

    fn check(pieces: &[(DVec3, f64, bool)]) -> Option<usize> {
        let (mut v, mut index) = (Vec::new(), Vec::new());
        for &(c, h, inward) in pieces {
            let (cv, mut ct) = cube(c, h, v.len() as u32);
            if inward {
                ct.iter_mut().for_each(|t| t.swap(1, 2));
            }
            v.extend(cv);
            index.extend(ct);
        }
        let tris: Vec<[DVec3; 3]> = index.iter().map(|t| t.map(|i| v[i as usize])).collect();
        let (part, count) = parts(&index, v.len());
        assert_eq!(count, pieces.len());
        let volume = volumes(&tris, &part, count);
        stray_inward_part(&tris, &part, &volume).map(|(p, _)| p)
    }

    #[test]
    fn an_inward_part_is_a_cavity_inside_a_solid_and_stray_elsewhere() {
        assert!(
            volumes(
                &{
                    let (v, t) = cube(DVec3::ZERO, 1.0, 0);
                    t.iter()
                        .map(|t| t.map(|i| v[i as usize]))
                        .collect::<Vec<_>>()
                },
                &[0; 12],
                1
            )[0] > 0.0
        );
        // A hollow box: a cavity inside the solid.
        assert_eq!(
            check(&[(DVec3::ZERO, 1.0, false), (DVec3::ZERO, 0.5, true)]),
            None
        );
        // Two solids side by side, one inside out.
        assert_eq!(
            check(&[(DVec3::ZERO, 1.0, false), (DVec3::X * 3.0, 0.5, true)]),
            Some(1)
        );
        assert_eq!(
            check(&[(DVec3::ZERO, 1.0, false), (DVec3::X * 3.0, 0.5, false)]),
            None
        );
    }
}
