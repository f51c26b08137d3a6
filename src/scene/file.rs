//! The scene file's serde schema and its conversion to [`ClothSpec`] and
//! [`Params`].
//!
//! Every key is optional (except where a table makes no sense without it)
//! and every struct refuses unknown keys, so a typo is an error rather than a
//! silently ignored line. Missing keys take their values from
//! [`Params::default`] and [`ClothSpec::default`]; the few defaults that have
//! no counterpart there (ground, spheres, wind, duration) are the constants
//! below. Ranges are *not* checked here: that is `validate`'s job.

use std::fmt;
use std::marker::PhantomData;

use serde::de::{self, Deserializer, Visitor};
use serde::Deserialize;

use super::CameraSpec;
use crate::model::{ClothSpec, Orientation, Pin};
use crate::params::{
    FilterMethod, FixupMethod, Ground, Integrator, Params, Sphere, SpringKind, Wind,
};

/// `[simulation] duration` when absent \[s\].
pub(super) const DEFAULT_DURATION: f64 = 2.0;
/// Friction of a `[ground]` or `[[sphere]]` that does not give one: a plain
/// cloth-on-floor value, so a dropped cloth settles instead of sliding away.
pub(super) const DEFAULT_FRICTION: f64 = 0.5;
/// `[wind] drag` when absent [kg/m³]: `½ ρ_air C_d` with `ρ_air = 1.2` and
/// `C_d = 1` (a flat plate face-on).
pub(super) const DEFAULT_WIND_DRAG: f64 = 0.6;

/// The whole file.
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct SceneFile {
    #[serde(default)]
    simulation: SimulationTable,
    #[serde(default)]
    cloth: ClothTable,
    #[serde(default)]
    springs: SpringsTable,
    #[serde(default)]
    fixup: FixupTable,
    #[serde(default)]
    implicit: ImplicitTable,
    #[serde(default)]
    semi_implicit: SemiImplicitTable,
    ground: Option<GroundTable>,
    #[serde(default)]
    sphere: Vec<SphereTable>,
    wind: Option<WindTable>,
    #[serde(default)]
    camera: CameraTable,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct CameraTable {
    target: Option<[f64; 3]>,
    distance: Option<f64>,
    elevation: Option<f64>,
    azimuth: Option<f64>,
    fov: Option<f64>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct SimulationTable {
    integrator: Option<Choice<Integrator>>,
    dt: Option<f64>,
    gravity: Option<[f64; 3]>,
    duration: Option<f64>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct ClothTable {
    resolution: Option<[usize; 2]>,
    size: Option<[f64; 2]>,
    origin: Option<[f64; 3]>,
    orientation: Option<Choice<Orientation>>,
    mass: Option<f64>,
    pins: Option<Vec<PinEntry>>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct SpringsTable {
    stretch: Option<SpringTable>,
    shear: Option<SpringTable>,
    bend: Option<SpringTable>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SpringTable {
    stiffness: Option<f64>,
    damping: Option<f64>,
    max_stretch: Option<f64>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct FixupTable {
    iterations: Option<u32>,
    method: Option<Choice<FixupMethod>>,
    omega: Option<f64>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct ImplicitTable {
    tolerance: Option<f64>,
    max_iterations: Option<u32>,
    coarse_levels: Option<bool>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct SemiImplicitTable {
    filter: Option<Choice<FilterMethod>>,
    torque_compensation: Option<bool>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct GroundTable {
    height: Option<f64>,
    friction: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SphereTable {
    center: Option<[f64; 3]>,
    /// Required: no radius is a sensible default.
    radius: f64,
    friction: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct WindTable {
    /// Required: a `[wind]` table without a velocity is almost certainly a
    /// mistake; still air is written `velocity = [0, 0, 0]`.
    velocity: [f64; 3],
    drag: Option<f64>,
    lift: Option<f64>,
}

/// Overwrites `slot` when the file gave a value.
fn set<T>(slot: &mut T, value: Option<T>) {
    if let Some(v) = value {
        *slot = v;
    }
}

impl SceneFile {
    /// The cloth, the parameters, the duration \[s\] and the camera this file
    /// describes, not yet validated.
    pub(super) fn into_parts(self) -> (ClothSpec, Params, f64, CameraSpec) {
        let mut p = Params::default();
        let s = self.simulation;
        set(&mut p.integrator, s.integrator.map(|c| c.0));
        set(&mut p.dt, s.dt);
        set(&mut p.gravity, s.gravity);

        let mut cloth = ClothSpec::default();
        let c = self.cloth;
        if let Some([nx, ny]) = c.resolution {
            (cloth.nx, cloth.ny) = (nx, ny);
        }
        set(&mut cloth.size, c.size);
        set(&mut cloth.origin, c.origin);
        set(&mut cloth.orientation, c.orientation.map(|o| o.0));
        set(&mut cloth.mass, c.mass);
        set(
            &mut cloth.pins,
            c.pins.map(|v| v.into_iter().map(|e| e.0).collect()),
        );

        for kind in SpringKind::ALL {
            let table = match kind {
                SpringKind::Stretch => &self.springs.stretch,
                SpringKind::Shear => &self.springs.shear,
                SpringKind::Bend => &self.springs.bend,
            };
            if let Some(t) = table {
                // Missing keys keep the default of *this* kind.
                let spring = &mut p.springs[kind.index()];
                set(&mut spring.stiffness, t.stiffness);
                set(&mut spring.damping, t.damping);
                set(&mut spring.max_stretch, t.max_stretch.map(Some));
            }
        }

        set(&mut p.fixup.iterations, self.fixup.iterations);
        set(&mut p.fixup.method, self.fixup.method.map(|c| c.0));
        set(&mut p.fixup.omega, self.fixup.omega);
        set(&mut p.implicit.tolerance, self.implicit.tolerance);
        set(&mut p.implicit.max_iterations, self.implicit.max_iterations);
        set(&mut p.implicit.coarse_levels, self.implicit.coarse_levels);
        let si = self.semi_implicit;
        set(&mut p.semi_implicit.filter, si.filter.map(|c| c.0));
        set(
            &mut p.semi_implicit.torque_compensation,
            si.torque_compensation,
        );

        p.ground = self.ground.map(|g| Ground {
            height: g.height.unwrap_or(0.0),
            friction: g.friction.unwrap_or(DEFAULT_FRICTION),
        });
        p.spheres = self
            .sphere
            .into_iter()
            .map(|s| Sphere {
                center: s.center.unwrap_or([0.0; 3]),
                radius: s.radius,
                friction: s.friction.unwrap_or(DEFAULT_FRICTION),
            })
            .collect();
        p.wind = self.wind.map(|w| Wind {
            velocity: w.velocity,
            drag: w.drag.unwrap_or(DEFAULT_WIND_DRAG),
            lift: w.lift.unwrap_or(0.0),
        });
        let c = self.camera;
        let camera = CameraSpec {
            target: c.target,
            distance: c.distance,
            elevation: c.elevation,
            azimuth: c.azimuth,
            fov: c.fov,
        };
        (cloth, p, s.duration.unwrap_or(DEFAULT_DURATION), camera)
    }
}

/// A closed set of names a key may take (`integrator = "implicit"`).
trait Named: Copy + 'static {
    /// What the name selects, for the error message.
    const WHAT: &'static str;
    /// Every value, in the order the error message lists them.
    const ALL: &'static [Self];
    /// The scene-file spelling.
    fn name(self) -> &'static str;
}

impl Named for Integrator {
    const WHAT: &'static str = "integrator";
    const ALL: &'static [Self] = &Integrator::ALL;
    fn name(self) -> &'static str {
        self.as_str()
    }
}

impl Named for FixupMethod {
    const WHAT: &'static str = "fix-up method";
    const ALL: &'static [Self] = &[FixupMethod::GaussSeidel, FixupMethod::Jacobi];
    fn name(self) -> &'static str {
        self.as_str()
    }
}

impl Named for FilterMethod {
    const WHAT: &'static str = "filter";
    const ALL: &'static [Self] = &[
        FilterMethod::Auto,
        FilterMethod::Dense,
        FilterMethod::Banded,
    ];
    fn name(self) -> &'static str {
        self.as_str()
    }
}

impl Named for Orientation {
    const WHAT: &'static str = "orientation";
    const ALL: &'static [Self] = &[Orientation::Horizontal, Orientation::Vertical];
    fn name(self) -> &'static str {
        match self {
            Orientation::Horizontal => "horizontal",
            Orientation::Vertical => "vertical",
        }
    }
}

/// One of a [`Named`] set, parsed from its spelling. The types it wraps live
/// outside this module and do not implement `Deserialize`.
struct Choice<T>(T);

/// "`a`, `b`, `c`", the way serde lists allowed names.
fn list_names<T: Named>() -> String {
    let names: Vec<String> = T::ALL.iter().map(|v| format!("`{}`", v.name())).collect();
    names.join(", ")
}

impl<'de, T: Named> Deserialize<'de> for Choice<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct ChoiceVisitor<T>(PhantomData<T>);
        impl<T: Named> Visitor<'_> for ChoiceVisitor<T> {
            type Value = Choice<T>;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "one of {}", list_names::<T>())
            }
            fn visit_str<E: de::Error>(self, s: &str) -> Result<Self::Value, E> {
                match T::ALL.iter().find(|v| v.name() == s) {
                    Some(&v) => Ok(Choice(v)),
                    None => Err(E::custom(format!(
                        "unknown {} `{s}`, expected one of {}",
                        T::WHAT,
                        list_names::<T>()
                    ))),
                }
            }
        }
        d.deserialize_str(ChoiceVisitor(PhantomData))
    }
}

/// One entry of `pins`: a name (`"top-left"`) or a particle index.
struct PinEntry(Pin);

impl<'de> Deserialize<'de> for PinEntry {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct PinVisitor;
        impl Visitor<'_> for PinVisitor {
            type Value = PinEntry;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "one of {} or a particle index", Pin::NAMES)
            }
            fn visit_str<E: de::Error>(self, s: &str) -> Result<PinEntry, E> {
                Pin::parse(s).map(PinEntry).ok_or_else(|| {
                    E::custom(format!(
                        "unknown pin `{s}`, expected one of {} or a particle index",
                        Pin::NAMES
                    ))
                })
            }
            fn visit_u64<E: de::Error>(self, i: u64) -> Result<PinEntry, E> {
                // An index too large for usize is out of range anyway; let
                // `ClothSpec::validate` say so with the real particle count.
                Ok(PinEntry(Pin::Index(
                    usize::try_from(i).unwrap_or(usize::MAX),
                )))
            }
            fn visit_i64<E: de::Error>(self, i: i64) -> Result<PinEntry, E> {
                match u64::try_from(i) {
                    Ok(i) => self.visit_u64(i),
                    Err(_) => Err(E::custom(format!(
                        "pin index {i} is negative, expected a particle index ≥ 0"
                    ))),
                }
            }
        }
        d.deserialize_any(PinVisitor)
    }
}
