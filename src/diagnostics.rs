//! Energy and strain measures, the same for every backend: they take
//! positions and velocities in any precision and accumulate in `f64`.

use crate::model::Model;
use crate::params::Params;
use crate::real::{Real, Vec3};

/// Energy of a state \[J\], split by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Energy {
    /// `Σ ½ m |v|²` over free particles.
    pub kinetic: f64,
    /// `−Σ m g·x` (zero at the origin).
    pub gravitational: f64,
    /// `Σ ½ k (l − L)²` over all springs.
    pub elastic: f64,
}

impl Energy {
    /// Total mechanical energy \[J\].
    pub fn total(&self) -> f64 {
        self.kinetic + self.gravitational + self.elastic
    }
}

/// Energy of positions `x` and velocities `v`.
pub fn energy<R: Real>(model: &Model, params: &Params, x: &[Vec3<R>], v: &[Vec3<R>]) -> Energy {
    let g = params.gravity;
    let mut e = Energy::default();
    for p in 0..model.particle_count() {
        let m = model.mass[p];
        let [px, py, pz] = x[p].to_f64();
        e.gravitational -= m * (g[0] * px + g[1] * py + g[2] * pz);
        if !model.pinned[p] {
            let [vx, vy, vz] = v[p].to_f64();
            e.kinetic += 0.5 * m * (vx * vx + vy * vy + vz * vz);
        }
    }
    for s in &model.springs {
        let k = params.spring(s.kind).stiffness;
        let c = length(x, s.i, s.j) - s.rest;
        e.elastic += 0.5 * k * c * c;
    }
    e
}

fn length<R: Real>(x: &[Vec3<R>], i: u32, j: u32) -> f64 {
    let [ax, ay, az] = x[i as usize].to_f64();
    let [bx, by, bz] = x[j as usize].to_f64();
    ((ax - bx).powi(2) + (ay - by).powi(2) + (az - bz).powi(2)).sqrt()
}

/// Largest strain `(l − L) / L` over the springs of the kinds selected by
/// `kinds` (indexed by [`crate::params::SpringKind::index`]); zero-length
/// rest springs are skipped. Negative when everything is compressed.
pub fn max_strain<R: Real>(model: &Model, x: &[Vec3<R>], kinds: [bool; 3]) -> f64 {
    model
        .springs
        .iter()
        .filter(|s| kinds[s.kind.index()] && s.rest > 0.0)
        .map(|s| (length(x, s.i, s.j) - s.rest) / s.rest)
        .fold(f64::NEG_INFINITY, f64::max)
}

/// Largest stretch-spring strain: the number a user means by "how far did
/// the cloth stretch".
pub fn max_stretch_strain<R: Real>(model: &Model, x: &[Vec3<R>]) -> f64 {
    max_strain(model, x, [true, false, false])
}
