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

use glam::DVec3;
use serde::de::value::MapAccessDeserializer;
use serde::de::{self, Deserializer, MapAccess, Visitor};
use serde::Deserialize;

use super::animation::{Character, Key};
use super::shape::{Exactly, Form, List, Number, Table, Whole};
use super::CameraSpec;
use crate::material::{Material, WarpWeft};
use crate::model::{ClothSpec, Orientation, Pin, MAX_PARTICLES};
use crate::params::{
    Capsule, FilterMethod, FixupMethod, Ground, Integrator, Params, SelfCollision, Sphere,
    SpringKind, Wind,
};

/// `[simulation] duration` when absent \[s\].
pub(super) const DEFAULT_DURATION: f64 = 2.0;
/// Friction of a `[ground]`, `[[sphere]]` or `[[capsule]]` that does not give one: a plain
/// cloth-on-floor value, so a dropped cloth settles instead of sliding away.
pub(super) const DEFAULT_FRICTION: f64 = 0.5;
/// `[[collider]] thickness` when absent \[m\]: 5 mm, the thickness of a
/// heavy cloth, keeps the cloth visibly on the surface without a gap.
pub(super) const DEFAULT_COLLIDER_THICKNESS: f64 = 0.005;
/// `[wind] drag` when absent [kg/m³]: `½ ρ_air C_d` with `ρ_air = 1.2` and
/// `C_d = 1` (a flat plate face-on).
pub(super) const DEFAULT_WIND_DRAG: f64 = 0.6;

/// The whole file.
#[derive(Deserialize, Default)]
#[serde(
    deny_unknown_fields,
    expecting = "a scene file: TOML tables such as `[simulation]`"
)]
pub(super) struct SceneFile {
    #[serde(default)]
    simulation: Table<SimulationTable>,
    #[serde(default)]
    cloth: Table<ClothTable>,
    #[serde(default)]
    springs: Table<SpringsTable>,
    material: Option<Table<MaterialTable>>,
    #[serde(default)]
    fixup: Table<FixupTable>,
    #[serde(default)]
    implicit: Table<ImplicitTable>,
    #[serde(default)]
    semi_implicit: Table<SemiImplicitTable>,
    ground: Option<Table<GroundTable>>,
    #[serde(default)]
    sphere: List<Table<SphereTable>>,
    #[serde(default)]
    capsule: List<Table<CapsuleTable>>,
    #[serde(default)]
    collider: List<Table<ColliderTable>>,
    #[serde(default)]
    render_mesh: List<Table<RenderMeshTable>>,
    character: Option<Table<CharacterTable>>,
    wind: Option<Table<WindTable>>,
    self_collision: Option<Table<SelfCollisionTable>>,
    #[serde(default)]
    camera: Table<CameraTable>,
}

/// Three numbers, `[x, y, z]`.
type Vec3 = Exactly<Number, 3>;

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct CameraTable {
    target: Option<Vec3>,
    distance: Option<Number>,
    elevation: Option<Number>,
    azimuth: Option<Number>,
    fov: Option<Number>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct SimulationTable {
    integrator: Option<Choice<Integrator>>,
    dt: Option<Number>,
    gravity: Option<Vec3>,
    duration: Option<Number>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct ClothTable {
    resolution: Option<Exactly<Whole<usize>, 2>>,
    size: Option<Exactly<Number, 2>>,
    origin: Option<Vec3>,
    orientation: Option<Choice<Orientation>>,
    mass: Option<Number>,
    pins: Option<List<PinEntry>>,
    mesh: Option<String>,
    mesh_name: Option<String>,
    scale: Option<Number>,
    render_mesh: Option<String>,
}

/// The `[cloth]` keys of a mesh cloth, not yet read or checked.
pub(super) struct MeshKeys {
    /// `mesh`, as written (relative to the scene file's folder).
    pub(super) file: String,
    /// `mesh_name`.
    pub(super) name: Option<String>,
    /// `scale` (default 1).
    pub(super) scale: f64,
    /// Whether the file gives `origin` (a mesh's default is `[0, 0, 0]`,
    /// not the grid's).
    pub(super) origin_given: bool,
    /// Whether the file gives `pins` (a mesh's default is none, not the
    /// grid's top corners).
    pub(super) pins_given: bool,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct SpringsTable {
    stretch: Option<Table<SpringTable>>,
    shear: Option<Table<SpringTable>>,
    bend: Option<Table<SpringTable>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SpringTable {
    stiffness: Option<Number>,
    damping: Option<Number>,
    max_stretch: Option<Number>,
}

/// `[material]`: a cloth in physical units (`crate::material`).
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct MaterialTable {
    density: Option<Number>,
    stretch: Option<Directions>,
    shear: Option<Number>,
    bending: Option<Directions>,
    damping: Option<Number>,
}

/// A fabric property that may differ along the warp and the weft: one
/// number (both directions), or `{ warp = …, weft = … }`.
#[derive(Clone, Copy)]
struct Directions(WarpWeft);

/// Both directions of a [`Directions`] table: neither may be left out.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DirectionsTable {
    warp: Number,
    weft: Number,
}

impl<'de> Deserialize<'de> for Directions {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct DirectionsVisitor;
        impl<'de> Visitor<'de> for DirectionsVisitor {
            type Value = Directions;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a number, or { warp = …, weft = … } (a number along each direction)")
            }
            fn visit_f64<E: de::Error>(self, x: f64) -> Result<Directions, E> {
                Ok(Directions(WarpWeft::both(x)))
            }
            // Integers as `Number` reads them: the nearest f64.
            fn visit_i64<E: de::Error>(self, i: i64) -> Result<Directions, E> {
                self.visit_f64(i as f64)
            }
            fn visit_u64<E: de::Error>(self, i: u64) -> Result<Directions, E> {
                self.visit_f64(i as f64)
            }
            fn visit_i128<E: de::Error>(self, i: i128) -> Result<Directions, E> {
                self.visit_f64(i as f64)
            }
            fn visit_u128<E: de::Error>(self, i: u128) -> Result<Directions, E> {
                self.visit_f64(i as f64)
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<Directions, A::Error> {
                let t = DirectionsTable::deserialize(MapAccessDeserializer::new(map))?;
                Ok(Directions(WarpWeft {
                    warp: t.warp.0,
                    weft: t.weft.0,
                }))
            }
        }
        d.deserialize_any(DirectionsVisitor)
    }
}

impl From<Directions> for WarpWeft {
    fn from(d: Directions) -> WarpWeft {
        d.0
    }
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct FixupTable {
    iterations: Option<Whole<u32>>,
    method: Option<Choice<FixupMethod>>,
    omega: Option<Number>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct ImplicitTable {
    tolerance: Option<Number>,
    max_iterations: Option<Whole<u32>>,
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
    height: Option<Number>,
    friction: Option<Number>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SphereTable {
    center: Option<Vec3>,
    /// Required: no radius is a sensible default.
    radius: Number,
    friction: Option<Number>,
    velocity: Option<Vec3>,
}

/// `[character]`: its capsules and its keyed path (`scene/animation.rs`).
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct CharacterTable {
    #[serde(default)]
    capsule: List<Table<CharacterCapsuleTable>>,
    #[serde(default)]
    collider: List<Table<CharacterColliderTable>>,
    #[serde(default)]
    key: List<Table<KeyTable>>,
}

/// A `[[character.collider]]`: a `[[collider]]` without `velocity` and
/// `angular_velocity`, which the character's keys give; its `position`
/// and `rotation` in the character's frame.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CharacterColliderTable {
    mesh: String,
    mesh_name: Option<String>,
    position: Option<Vec3>,
    rotation: Option<Exactly<Number, 4>>,
    scale: Option<Number>,
    friction: Option<Number>,
    resolution: Option<Whole<u64>>,
    thickness: Option<Number>,
}

impl Form for CharacterColliderTable {
    const ONE: &'static str =
        "a table: a `[[character.collider]]` line with its keys on the lines below";
    const MANY: &'static str = "tables, each a `[[character.collider]]` line (double brackets) \
                                with its keys on the lines below";
}

/// A `[[character.capsule]]`: a `[[capsule]]` without `velocity`, which
/// the character's keys give.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CharacterCapsuleTable {
    a: Vec3,
    b: Vec3,
    radius: Number,
    friction: Option<Number>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct KeyTable {
    /// Required, as `position`: a key is a time and a place.
    time: Number,
    position: Vec3,
    yaw: Option<Number>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CapsuleTable {
    /// Required, as `b` and `radius`: no segment is a sensible default.
    a: Vec3,
    b: Vec3,
    radius: Number,
    friction: Option<Number>,
    velocity: Option<Vec3>,
}

/// `[[render_mesh]] max_distance` when absent \[m\]: a lining or a hem
/// lies millimetres from the cloth; a vertex 5 cm away is almost surely
/// in the wrong place or the wrong units.
pub(super) const DEFAULT_RENDER_MESH_DISTANCE: f64 = 0.05;

/// A `[[render_mesh]]`: a detailed mesh drawn in place of the cloth (see
/// `crate::render_mesh`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RenderMeshTable {
    /// Required: the mesh file.
    file: String,
    mesh_name: Option<String>,
    max_distance: Option<Number>,
}

impl Form for RenderMeshTable {
    const ONE: &'static str = "a table: a `[[render_mesh]]` line with its keys on the lines below";
    const MANY: &'static str =
        "tables, each a `[[render_mesh]]` line (double brackets) with its keys on the lines below";
}

/// A render mesh as the file gives it (`[cloth] render_mesh` or a
/// `[[render_mesh]]`), defaults filled in, not yet read or checked.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct RenderMeshKeys {
    /// The key that gave it, for messages: `cloth.render_mesh` or
    /// `render_mesh[N]`.
    pub key: String,
    /// The file, as written (relative to the scene file's folder).
    pub file: String,
    /// `mesh_name`.
    pub name: Option<String>,
    /// `max_distance` \[m\].
    pub max_distance: f64,
}

/// A `[[collider]]`: a closed mesh (see `crate::sdf`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ColliderTable {
    /// Required: the body is the mesh.
    mesh: String,
    mesh_name: Option<String>,
    position: Option<Vec3>,
    rotation: Option<Exactly<Number, 4>>,
    scale: Option<Number>,
    friction: Option<Number>,
    velocity: Option<Vec3>,
    angular_velocity: Option<Vec3>,
    resolution: Option<Whole<u64>>,
    thickness: Option<Number>,
}

impl Form for ColliderTable {
    const ONE: &'static str = "a table: a `[[collider]]` line with its keys on the lines below";
    const MANY: &'static str =
        "tables, each a `[[collider]]` line (double brackets) with its keys on the lines below";
}

/// A `[[collider]]` as the file gives it, defaults filled in, not yet read
/// or checked (`Scene` reads and bakes its mesh).
#[derive(Clone, Debug, PartialEq)]
pub(super) struct ColliderKeys {
    /// `mesh`, as written (relative to the scene file's folder).
    pub file: String,
    /// `mesh_name`.
    pub name: Option<String>,
    /// `position` \[m\].
    pub position: DVec3,
    /// `rotation`: an axis and an angle \[deg\].
    pub axis: DVec3,
    pub degrees: f64,
    /// `scale`.
    pub scale: f64,
    /// `friction`.
    pub friction: f64,
    /// `velocity` [m/s].
    pub velocity: DVec3,
    /// `angular_velocity` [rad/s].
    pub angular_velocity: DVec3,
    /// `resolution` (its range is the bake's to check, so that a number
    /// beyond `u32` is told the range, not the type).
    pub resolution: u64,
    /// `thickness` \[m\].
    pub thickness: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct WindTable {
    /// Required: a `[wind]` table without a velocity is almost certainly a
    /// mistake; still air is written `velocity = [0, 0, 0]`.
    velocity: Vec3,
    drag: Option<Number>,
    lift: Option<Number>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct SelfCollisionTable {
    thickness: Option<Number>,
    friction: Option<Number>,
    iterations: Option<Whole<u32>>,
}

/// How a table written `[header]` looks, for "expected …".
macro_rules! table_form {
    ($table:ty, $header:literal) => {
        impl Form for $table {
            const ONE: &'static str = concat!(
                "a table: a `[",
                $header,
                "]` line with its keys on the lines below"
            );
            const MANY: &'static str = concat!("`[", $header, "]` tables");
        }
    };
}

table_form!(SimulationTable, "simulation");
table_form!(ClothTable, "cloth");
table_form!(SpringTable, "springs.<stretch|shear|bend>");
table_form!(FixupTable, "fixup");
table_form!(MaterialTable, "material");
table_form!(ImplicitTable, "implicit");
table_form!(SemiImplicitTable, "semi_implicit");
table_form!(GroundTable, "ground");
table_form!(WindTable, "wind");
table_form!(SelfCollisionTable, "self_collision");
table_form!(CameraTable, "camera");
table_form!(CharacterTable, "character");

impl Form for SpringsTable {
    const ONE: &'static str = "a table of spring kinds: `[springs.stretch]`, \
                               `[springs.shear]` and `[springs.bend]` lines, each with its keys \
                               on the lines below";
    const MANY: &'static str = "`[springs]` tables";
}

/// The arrays of tables: `[[sphere]]`, once per sphere, and
/// `[[capsule]]`, once per capsule.
impl Form for SphereTable {
    const ONE: &'static str = "a table: a `[[sphere]]` line with its keys on the lines below";
    const MANY: &'static str =
        "tables, each a `[[sphere]]` line (double brackets) with its keys on the lines below";
}

impl Form for KeyTable {
    const ONE: &'static str =
        "a table: a `[[character.key]]` line with its keys on the lines below";
    const MANY: &'static str =
        "tables, each a `[[character.key]]` line (double brackets) with its \
                                keys on the lines below";
}

impl Form for CapsuleTable {
    const ONE: &'static str = "a table: a `[[capsule]]` line with its keys on the lines below";
    const MANY: &'static str =
        "tables, each a `[[capsule]]` line (double brackets) with its keys on the lines below";
}

impl Form for CharacterCapsuleTable {
    const ONE: &'static str =
        "a table: a `[[character.capsule]]` line with its keys on the lines below";
    const MANY: &'static str = "tables, each a `[[character.capsule]]` line (double brackets) \
                                with its keys on the lines below";
}

impl Form for PinEntry {
    const ONE: &'static str = "a pin name, a particle index or a box";
    const MANY: &'static str = "pin names, particle indices and boxes";
}

impl Form for Vec3 {
    const ONE: &'static str = "[x, y, z], three numbers in m";
    const MANY: &'static str = "[x, y, z] corners";
}

/// A region pin: `{ box = [[x0, y0, z0], [x1, y1, z1]] }`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RegionPin {
    #[serde(rename = "box")]
    bounds: Exactly<Vec3, 2>,
}

/// Overwrites `slot` when the file gave a value.
fn set<T, V: Into<T>>(slot: &mut T, value: Option<V>) {
    if let Some(v) = value {
        *slot = v.into();
    }
}

impl From<Number> for f64 {
    fn from(n: Number) -> f64 {
        n.0
    }
}

impl From<Whole<u32>> for u32 {
    fn from(n: Whole<u32>) -> u32 {
        n.0
    }
}

impl From<Exactly<Number, 3>> for DVec3 {
    fn from(v: Exactly<Number, 3>) -> Self {
        DVec3::from_array(v.into())
    }
}

impl<const N: usize> From<Exactly<Number, N>> for [f64; N] {
    fn from(a: Exactly<Number, N>) -> [f64; N] {
        a.0.map(f64::from)
    }
}

impl SceneFile {
    /// The mesh keys when `[cloth]` has `mesh`; refuses the grid's keys
    /// beside it, and the mesh's keys without it.
    pub(super) fn mesh_keys(&self) -> Result<Option<MeshKeys>, String> {
        let c = &self.cloth.0;
        let Some(file) = &c.mesh else {
            for (key, given) in [
                ("mesh_name", c.mesh_name.is_some()),
                ("scale", c.scale.is_some()),
            ] {
                if given {
                    return Err(format!(
                        "`cloth.{key}`: only a mesh cloth (`cloth.mesh = \"file.obj\"`) takes \
                         it; remove it or give `cloth.mesh`"
                    ));
                }
            }
            return Ok(None);
        };
        for (key, given) in [
            ("resolution", c.resolution.is_some()),
            ("size", c.size.is_some()),
            ("orientation", c.orientation.is_some()),
        ] {
            if given {
                return Err(format!(
                    "`cloth.{key}` conflicts with `cloth.mesh`: a mesh cloth takes its \
                     particles, size and shape from the mesh file (place it with `origin` and \
                     `scale`); remove `{key}`"
                ));
            }
        }
        Ok(Some(MeshKeys {
            file: file.clone(),
            name: c.mesh_name.clone(),
            scale: c.scale.map_or(1.0, f64::from),
            origin_given: c.origin.is_some(),
            pins_given: c.pins.is_some(),
        }))
    }

    /// The file's `[material]` (not yet validated), absent keys from
    /// [`Material::default`]; refuses `cloth.mass` and `[springs.*]`
    /// tables beside it, which would give the mass or the springs twice.
    pub(super) fn material(&self) -> Result<Option<Material>, String> {
        let Some(Table(t)) = &self.material else {
            return Ok(None);
        };
        if self.cloth.0.mass.is_some() {
            return Err(
                "`cloth.mass` conflicts with `[material]`: a material cloth's mass is \
                 `material.density` × its area; remove `cloth.mass`, or `[material]` to give \
                 the mass and springs by hand"
                    .to_string(),
            );
        }
        let springs = &self.springs.0;
        for (kind, given) in [
            (SpringKind::Stretch, springs.stretch.is_some()),
            (SpringKind::Shear, springs.shear.is_some()),
            (SpringKind::Bend, springs.bend.is_some()),
        ] {
            if given {
                return Err(format!(
                    "`[springs.{}]` conflicts with `[material]`: a material cloth's springs \
                     follow from `material.stretch`, `shear`, `bending` and `damping` and the \
                     rest geometry; remove `[springs.{}]`, or `[material]` to give the springs \
                     by hand",
                    kind.as_str(),
                    kind.as_str()
                ));
            }
        }
        let mut m = Material::default();
        set(&mut m.density, t.density);
        set(&mut m.stretch, t.stretch);
        set(&mut m.shear, t.shear);
        set(&mut m.bending, t.bending);
        set(&mut m.damping, t.damping);
        Ok(Some(m))
    }

    /// The cloth, the parameters, the duration \[s\] and the camera this file
    /// describes, not yet validated.
    pub(super) fn into_parts(self) -> (ClothSpec, Params, f64, CameraSpec) {
        let mut p = Params::default();
        let s = self.simulation.0;
        set(&mut p.integrator, s.integrator.map(|c| c.0));
        set(&mut p.dt, s.dt);
        set(&mut p.gravity, s.gravity);

        let mut cloth = ClothSpec::default();
        let c = self.cloth.0;
        if let Some(Exactly([nx, ny])) = c.resolution {
            (cloth.nx, cloth.ny) = (nx.0, ny.0);
        }
        set(&mut cloth.size, c.size);
        set(&mut cloth.origin, c.origin);
        set(&mut cloth.orientation, c.orientation.map(|o| o.0));
        set(&mut cloth.mass, c.mass);
        set(
            &mut cloth.pins,
            c.pins
                .map(|v| v.0.into_iter().map(|e| e.0).collect::<Vec<_>>()),
        );

        let springs = self.springs.0;
        for kind in SpringKind::ALL {
            let table = match kind {
                SpringKind::Stretch => &springs.stretch,
                SpringKind::Shear => &springs.shear,
                SpringKind::Bend => &springs.bend,
            };
            if let Some(Table(t)) = table {
                // Missing keys keep the default of *this* kind.
                let spring = &mut p.springs[kind.index()];
                set(&mut spring.stiffness, t.stiffness);
                set(&mut spring.damping, t.damping);
                set(&mut spring.max_stretch, t.max_stretch.map(|m| Some(m.0)));
            }
        }

        let (fixup, implicit) = (self.fixup.0, self.implicit.0);
        set(&mut p.fixup.iterations, fixup.iterations);
        set(&mut p.fixup.method, fixup.method.map(|c| c.0));
        set(&mut p.fixup.omega, fixup.omega);
        set(&mut p.implicit.tolerance, implicit.tolerance);
        set(&mut p.implicit.max_iterations, implicit.max_iterations);
        set(&mut p.implicit.coarse_levels, implicit.coarse_levels);
        let si = self.semi_implicit.0;
        set(&mut p.semi_implicit.filter, si.filter.map(|c| c.0));
        set(
            &mut p.semi_implicit.torque_compensation,
            si.torque_compensation,
        );

        p.ground = self.ground.map(|Table(g)| Ground {
            height: g.height.map_or(0.0, f64::from),
            friction: g.friction.map_or(DEFAULT_FRICTION, f64::from),
        });
        p.spheres = self
            .sphere
            .0
            .into_iter()
            .map(|Table(s)| Sphere {
                center: s.center.map_or(DVec3::ZERO, DVec3::from),
                radius: s.radius.0,
                friction: s.friction.map_or(DEFAULT_FRICTION, f64::from),
                velocity: s.velocity.map_or(DVec3::ZERO, DVec3::from),
            })
            .collect();
        p.capsules = capsules(self.capsule);
        p.wind = self.wind.map(|Table(w)| Wind {
            velocity: w.velocity.into(),
            drag: w.drag.map_or(DEFAULT_WIND_DRAG, f64::from),
            lift: w.lift.map_or(0.0, f64::from),
        });
        p.self_collision = self.self_collision.map(|Table(t)| {
            let mut c = SelfCollision {
                thickness: t.thickness.map(f64::from),
                ..SelfCollision::default()
            };
            set(&mut c.friction, t.friction);
            set(&mut c.iterations, t.iterations);
            c
        });
        let c = self.camera.0;
        let camera = CameraSpec {
            target: c.target.map(DVec3::from),
            distance: c.distance.map(f64::from),
            elevation: c.elevation.map(f64::from),
            azimuth: c.azimuth.map(f64::from),
            fov: c.fov.map(f64::from),
        };
        let duration = s.duration.map_or(DEFAULT_DURATION, f64::from);
        (cloth, p, duration, camera)
    }
}

/// The capsules of a `[[capsule]]` list.
fn capsules(list: List<Table<CapsuleTable>>) -> Vec<Capsule> {
    list.0
        .into_iter()
        .map(|Table(c)| Capsule {
            velocity: c.velocity.map_or(DVec3::ZERO, DVec3::from),
            ..capsule(c.a, c.b, c.radius, c.friction)
        })
        .collect()
}

/// A capsule at rest from its keys, `friction` defaulted.
fn capsule(a: Vec3, b: Vec3, radius: Number, friction: Option<Number>) -> Capsule {
    Capsule {
        a: a.into(),
        b: b.into(),
        radius: radius.0,
        friction: friction.map_or(DEFAULT_FRICTION, f64::from),
        velocity: DVec3::ZERO,
    }
}

impl SceneFile {
    /// The file's render meshes, taken out: `[cloth] render_mesh` first,
    /// then each `[[render_mesh]]`.
    pub(super) fn take_render_meshes(&mut self) -> Vec<RenderMeshKeys> {
        let cloth = self.cloth.0.render_mesh.take().map(|file| RenderMeshKeys {
            key: "cloth.render_mesh".into(),
            file,
            name: None,
            max_distance: DEFAULT_RENDER_MESH_DISTANCE,
        });
        let tables = std::mem::take(&mut self.render_mesh.0)
            .into_iter()
            .enumerate()
            .map(|(n, Table(t))| RenderMeshKeys {
                key: format!("render_mesh[{n}]"),
                file: t.file,
                name: t.mesh_name,
                max_distance: t
                    .max_distance
                    .map_or(DEFAULT_RENDER_MESH_DISTANCE, f64::from),
            });
        cloth.into_iter().chain(tables).collect()
    }

    /// The file's `[[collider]]` tables, taken out.
    pub(super) fn take_colliders(&mut self) -> Vec<ColliderKeys> {
        std::mem::take(&mut self.collider.0)
            .into_iter()
            .map(|Table(c)| collider_keys(c))
            .collect()
    }

    /// The file's `[character]`, taken out (not yet validated), and its
    /// `[[character.collider]]` tables (which `Scene` reads and bakes).
    pub(super) fn take_character(&mut self) -> (Option<Character>, Vec<ColliderKeys>) {
        let Some(Table(c)) = self.character.take() else {
            return (None, Vec::new());
        };
        let colliders = c
            .collider
            .0
            .into_iter()
            .map(|Table(c)| {
                collider_keys(ColliderTable {
                    mesh: c.mesh,
                    mesh_name: c.mesh_name,
                    position: c.position,
                    rotation: c.rotation,
                    scale: c.scale,
                    friction: c.friction,
                    velocity: None,
                    angular_velocity: None,
                    resolution: c.resolution,
                    thickness: c.thickness,
                })
            })
            .collect();
        let character = Character {
            colliders: Vec::new(),
            capsules: c
                .capsule
                .0
                .into_iter()
                .map(|Table(c)| capsule(c.a, c.b, c.radius, c.friction))
                .collect(),
            keys: c
                .key
                .0
                .into_iter()
                .map(|Table(k)| Key {
                    time: k.time.0,
                    position: k.position.into(),
                    yaw: k.yaw.map_or(0.0, f64::from),
                })
                .collect(),
        };
        (Some(character), colliders)
    }
}

/// A `[[collider]]`'s keys with the defaults of those absent.
fn collider_keys(c: ColliderTable) -> ColliderKeys {
    let [x, y, z, degrees] = c
        .rotation
        .map_or([0.0, 1.0, 0.0, 0.0], |r| r.0.map(f64::from));
    ColliderKeys {
        file: c.mesh,
        name: c.mesh_name,
        position: c.position.map_or(DVec3::ZERO, DVec3::from),
        axis: DVec3::new(x, y, z),
        degrees,
        scale: c.scale.map_or(1.0, f64::from),
        friction: c.friction.map_or(DEFAULT_FRICTION, f64::from),
        velocity: c.velocity.map_or(DVec3::ZERO, DVec3::from),
        angular_velocity: c.angular_velocity.map_or(DVec3::ZERO, DVec3::from),
        resolution: c
            .resolution
            .map_or(u64::from(crate::sdf::DEFAULT_RESOLUTION), |r| r.0),
        thickness: c.thickness.map_or(DEFAULT_COLLIDER_THICKNESS, f64::from),
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
        impl<'de> Visitor<'de> for PinVisitor {
            type Value = PinEntry;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(
                    f,
                    "one of {}, a particle index or {{ box = [[x0, y0, z0], [x1, y1, z1]] }}",
                    Pin::NAMES
                )
            }
            fn visit_str<E: de::Error>(self, s: &str) -> Result<PinEntry, E> {
                Pin::parse(s).map(PinEntry).ok_or_else(|| {
                    E::custom(format!(
                        "unknown pin `{s}`, expected one of {}, a particle index or \
                         {{ box = [[x0, y0, z0], [x1, y1, z1]] }}",
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
                self.visit_i128(i128::from(i))
            }
            // TOML integers beyond 64 bits, which the toml crate reads.
            fn visit_u128<E: de::Error>(self, i: u128) -> Result<PinEntry, E> {
                match u64::try_from(i) {
                    Ok(i) => self.visit_u64(i),
                    Err(_) => Err(E::custom(format!(
                        "pin index {i} is too large, expected a particle index below {}",
                        MAX_PARTICLES
                    ))),
                }
            }
            fn visit_i128<E: de::Error>(self, i: i128) -> Result<PinEntry, E> {
                match u128::try_from(i) {
                    Ok(i) => self.visit_u128(i),
                    Err(_) => Err(E::custom(format!(
                        "pin index {i} is negative, expected a particle index ≥ 0"
                    ))),
                }
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<PinEntry, A::Error> {
                let region = RegionPin::deserialize(MapAccessDeserializer::new(map))?;
                Ok(PinEntry(Pin::Region(region.bounds.0.map(DVec3::from))))
            }
        }
        d.deserialize_any(PinVisitor)
    }
}
