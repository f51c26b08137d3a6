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
use super::shape::{Exactly, Form, List, Number, OneOrMany, Table, Whole};
use super::CameraSpec;
use crate::material::{Material, WarpWeft};
use crate::model::{ClothSpec, Orientation, Pin, MAX_PARTICLES};
use crate::params::{
    Capsule, ContactMethod, FilterMethod, FixupMethod, Ground, Integrator, Params, SelfCollision,
    Sphere, SpringKind, SpringParams, Wind,
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
    cloth: OneOrMany<ClothTable>,
    #[serde(default)]
    seam: List<Table<SeamTable>>,
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
    material: Option<Table<MaterialTable>>,
    springs: Option<Table<SpringsTable>>,
    color: Option<Vec3>,
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

impl SpringsTable {
    /// Each kind's table, with its name.
    fn kinds(&self) -> [(SpringKind, &Option<Table<SpringTable>>); 3] {
        [
            (SpringKind::Stretch, &self.stretch),
            (SpringKind::Shear, &self.shear),
            (SpringKind::Bend, &self.bend),
        ]
    }

    /// The names of the kinds the file gives a table.
    fn given(&self) -> impl Iterator<Item = &'static str> + '_ {
        self.kinds()
            .into_iter()
            .filter(|(_, t)| t.is_some())
            .map(|(kind, _)| kind.as_str())
    }

    /// The first kind whose table gives `max_stretch`.
    fn max_stretch_given(&self) -> Option<&'static str> {
        self.kinds()
            .into_iter()
            .find(|(_, t)| t.as_ref().is_some_and(|Table(t)| t.max_stretch.is_some()))
            .map(|(kind, _)| kind.as_str())
    }

    /// `base` with the keys these tables give over it (missing keys keep
    /// the base's value of *that* kind).
    fn over(&self, mut base: [SpringParams; 3]) -> [SpringParams; 3] {
        for (kind, table) in self.kinds() {
            if let Some(Table(t)) = table {
                let spring = &mut base[kind.index()];
                set(&mut spring.stiffness, t.stiffness);
                set(&mut spring.damping, t.damping);
                set(&mut spring.max_stretch, t.max_stretch.map(|m| Some(m.0)));
            }
        }
        base
    }
}

/// A `[[seam]]`: two sides of cloths joined particle by particle.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SeamTable {
    /// Required, as `b`: a seam joins two sides.
    a: Table<SeamSideTable>,
    b: Table<SeamSideTable>,
    stiffness: Option<Number>,
    damping: Option<Number>,
}

/// One side of a seam: `{ cloth = 0, edge = "right" }`, `{ cloth = 1,
/// vertices = [...] }` or `{ cloth = 0, box = [[…], […]] }`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SeamSideTable {
    cloth: Option<Whole<usize>>,
    edge: Option<String>,
    vertices: Option<List<Whole<usize>>>,
    #[serde(rename = "box")]
    bounds: Option<Exactly<Vec3, 2>>,
}

impl Form for SeamSideTable {
    const ONE: &'static str = "a table: `{ cloth = 0, edge = \"right\" }`, `{ cloth = 0, \
                               vertices = [...] }` or `{ cloth = 0, box = [[x0, y0, z0], [x1, \
                               y1, z1]] }`";
    const MANY: &'static str = "seam sides";
}

/// A `[[seam]]` as the file gives it, not yet checked against the cloths.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct SeamKeys {
    pub(super) a: SeamSideKeys,
    pub(super) b: SeamSideKeys,
    /// `stiffness` \[N/m\].
    pub(super) stiffness: Option<f64>,
    /// `damping` \[N·s/m\].
    pub(super) damping: Option<f64>,
}

/// One side of a seam as the file gives it.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct SeamSideKeys {
    /// `cloth` (default 0).
    pub(super) cloth: usize,
    /// `edge`, as written.
    pub(super) edge: Option<String>,
    /// `vertices`.
    pub(super) vertices: Option<Vec<usize>>,
    /// `box`.
    pub(super) bounds: Option<[DVec3; 2]>,
}

impl From<Table<SeamSideTable>> for SeamSideKeys {
    fn from(Table(t): Table<SeamSideTable>) -> Self {
        SeamSideKeys {
            cloth: t.cloth.map_or(0, |c| c.0),
            edge: t.edge,
            vertices: t.vertices.map(|v| v.0.into_iter().map(|w| w.0).collect()),
            bounds: t.bounds.map(|Exactly([lo, hi])| [lo.into(), hi.into()]),
        }
    }
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

impl MaterialTable {
    /// Sets the keys this table gives on `m`.
    fn set_into(&self, m: &mut Material) {
        set(&mut m.density, self.density);
        set(&mut m.stretch, self.stretch);
        set(&mut m.shear, self.shear);
        set(&mut m.bending, self.bending);
        set(&mut m.damping, self.damping);
    }
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
    /// The cloth it follows (index among the scene's cloths; default 0).
    cloth: Option<Whole<usize>>,
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
    /// The cloth it follows (checked against the scene's cloths by the
    /// caller).
    pub cloth: usize,
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
    method: Option<Choice<ContactMethod>>,
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

/// How an array of tables written `[[header]]` looks, for "expected …".
macro_rules! array_form {
    ($table:ty, $header:literal) => {
        impl Form for $table {
            const ONE: &'static str = concat!(
                "a table: a `[[",
                $header,
                "]]` line with its keys on the lines below"
            );
            const MANY: &'static str = concat!(
                "tables, each a `[[",
                $header,
                "]]` line (double brackets) with its keys on the lines below"
            );
        }
    };
}

array_form!(SeamTable, "seam");
array_form!(SphereTable, "sphere");
array_form!(CapsuleTable, "capsule");
array_form!(ColliderTable, "collider");
array_form!(RenderMeshTable, "render_mesh");
array_form!(CharacterCapsuleTable, "character.capsule");
array_form!(CharacterColliderTable, "character.collider");
array_form!(KeyTable, "character.key");

/// `[cloth]`: one table, or an array of them (`[[cloth]]`, a world).
impl Form for ClothTable {
    const ONE: &'static str = "a table: a `[cloth]` line with its keys on the lines below";
    const MANY: &'static str =
        "tables, each a `[[cloth]]` line (double brackets) with its keys on the lines below";
}
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

/// One `[cloth]` (or `[[cloth]]` entry) as the file gives it, its
/// material and springs resolved against the file's own, not yet
/// validated.
pub(super) struct ClothKeys {
    /// How its keys are named in messages: `cloth`, or `cloth[i]` in a
    /// file of `[[cloth]]` tables.
    pub(super) key: String,
    /// The grid's (or the mesh's placement and pins) from the file.
    pub(super) spec: ClothSpec,
    /// The mesh keys of a mesh cloth.
    pub(super) mesh: Option<MeshKeys>,
    /// Its material: the file's `[material]` with its own
    /// `[cloth.material]` keys over it.
    pub(super) material: Option<Material>,
    /// Its own spring kinds: the file's `[springs.*]` with its own
    /// `[cloth.springs.*]` stiffness and damping over them, or its own
    /// material's kinds; `None`: the file's.
    pub(super) springs: Option<[SpringParams; 3]>,
    /// `color`, as written.
    pub(super) color: Option<DVec3>,
    /// `render_mesh`, as written.
    pub(super) render_mesh: Option<String>,
}

impl ClothTable {
    /// The mesh keys when this cloth has `mesh`; refuses the grid's keys
    /// beside it, and the mesh's keys without it (`key`: how the cloth
    /// is named).
    fn mesh_keys(&self, key: &str) -> Result<Option<MeshKeys>, String> {
        let Some(file) = &self.mesh else {
            for (name, given) in [
                ("mesh_name", self.mesh_name.is_some()),
                ("scale", self.scale.is_some()),
            ] {
                if given {
                    return Err(format!(
                        "`{key}.{name}`: only a mesh cloth (`{key}.mesh = \"file.obj\"`) takes \
                         it; remove it or give `{key}.mesh`"
                    ));
                }
            }
            return Ok(None);
        };
        for (name, given) in [
            ("resolution", self.resolution.is_some()),
            ("size", self.size.is_some()),
            ("orientation", self.orientation.is_some()),
        ] {
            if given {
                return Err(format!(
                    "`{key}.{name}` conflicts with `{key}.mesh`: a mesh cloth takes its \
                     particles, size and shape from the mesh file (place it with `origin` and \
                     `scale`); remove `{name}`"
                ));
            }
        }
        Ok(Some(MeshKeys {
            file: file.clone(),
            name: self.mesh_name.clone(),
            scale: self.scale.map_or(1.0, f64::from),
            origin_given: self.origin.is_some(),
            pins_given: self.pins.is_some(),
        }))
    }
}

impl SceneFile {
    /// The file's `[material]` (not yet validated), absent keys from
    /// [`Material::default`]; refuses `[springs.*]` tables beside it,
    /// which would give the springs twice.
    pub(super) fn material(&self) -> Result<Option<Material>, String> {
        let Some(Table(t)) = &self.material else {
            return Ok(None);
        };
        if let Some(kind) = self.springs.0.given().next() {
            return Err(format!(
                "`[springs.{kind}]` conflicts with `[material]`: a material cloth's springs \
                 follow from `material.stretch`, `shear`, `bending` and `damping` and the \
                 rest geometry; remove `[springs.{kind}]`, or `[material]` to give the springs \
                 by hand"
            ));
        }
        let mut m = Material::default();
        t.set_into(&mut m);
        Ok(Some(m))
    }

    /// The file's cloths, taken out, each resolved against the file's
    /// `material` (from [`SceneFile::material`]) and its `[springs.*]`;
    /// refuses a
    /// cloth's `mass` or `[cloth.springs.*]` beside a material and a
    /// cloth's own `max_stretch` (the fix-up's limits are the world's).
    pub(super) fn take_cloths(
        &mut self,
        material: Option<&Material>,
    ) -> Result<Vec<ClothKeys>, String> {
        let world = self.springs(material);
        let cloths = std::mem::take(&mut self.cloth);
        let many = cloths.many;
        let mut out = Vec::with_capacity(cloths.values.len());
        for (n, c) in cloths.values.into_iter().enumerate() {
            let key = if many {
                format!("cloth[{n}]")
            } else {
                "cloth".to_string()
            };
            let mesh = c.mesh_keys(&key)?;
            let material = match (&c.material, material) {
                (Some(Table(own)), base) => {
                    let mut m = base.cloned().unwrap_or_default();
                    own.set_into(&mut m);
                    Some(m)
                }
                (None, base) => base.cloned(),
            };
            let own_springs = c.springs.as_ref().map(|Table(t)| t);
            let springs = match (&material, own_springs) {
                (Some(_), _) if c.mass.is_some() => {
                    let table = match c.material {
                        Some(_) => format!("{key}.material"),
                        None => "material".to_string(),
                    };
                    return Err(format!(
                        "`{key}.mass` conflicts with `[{table}]`: a material cloth's mass is \
                         `material.density` × its area; remove `{key}.mass`, or `[{table}]` \
                         to give the mass and springs by hand"
                    ));
                }
                (Some(_), Some(own)) if own.given().next().is_some() => {
                    let kind = own.given().next().unwrap_or("stretch");
                    return Err(format!(
                        "`[{key}.springs.{kind}]` conflicts with a material: a material \
                         cloth's springs follow from its material; remove it, or the material"
                    ));
                }
                (Some(m), _) if c.material.is_some() => Some(m.spring_params()),
                (Some(_), _) => None,
                (None, Some(own)) => {
                    if let Some(kind) = own.max_stretch_given() {
                        return Err(format!(
                            "`{key}.springs.{kind}.max_stretch`: the fix-up's limits are the \
                             world's; give `max_stretch` in `[springs.{kind}]` for every cloth"
                        ));
                    }
                    Some(own.over(world))
                }
                (None, None) => None,
            };
            let mut spec = ClothSpec::default();
            if let Some(Exactly([nx, ny])) = c.resolution {
                (spec.nx, spec.ny) = (nx.0, ny.0);
            }
            set(&mut spec.size, c.size);
            set(&mut spec.origin, c.origin);
            set(&mut spec.orientation, c.orientation.map(|o| o.0));
            set(&mut spec.mass, c.mass);
            set(
                &mut spec.pins,
                c.pins
                    .map(|v| v.0.into_iter().map(|e| e.0).collect::<Vec<_>>()),
            );
            out.push(ClothKeys {
                key,
                spec,
                mesh,
                material,
                springs,
                color: c.color.map(DVec3::from),
                render_mesh: c.render_mesh,
            });
        }
        Ok(out)
    }

    /// The spring kinds of the file's world: its `material`'s (from
    /// [`SceneFile::material`]) or its `[springs.*]` over the defaults.
    fn springs(&self, material: Option<&Material>) -> [SpringParams; 3] {
        match material {
            Some(m) => m.spring_params(),
            None => self.springs.0.over(Params::default().springs),
        }
    }

    /// The file's `[[seam]]`s, taken out.
    pub(super) fn take_seams(&mut self) -> Vec<SeamKeys> {
        std::mem::take(&mut self.seam.0)
            .into_iter()
            .map(|Table(t)| SeamKeys {
                a: t.a.into(),
                b: t.b.into(),
                stiffness: t.stiffness.map(f64::from),
                damping: t.damping.map(f64::from),
            })
            .collect()
    }

    /// The parameters, the duration \[s\] and the camera this file
    /// describes with its `material` (from [`SceneFile::material`]), not
    /// yet validated (the cloths taken out before:
    /// [`SceneFile::take_cloths`]).
    pub(super) fn into_parts(self, material: Option<&Material>) -> (Params, f64, CameraSpec) {
        let mut p = Params {
            springs: self.springs(material),
            ..Params::default()
        };
        let s = self.simulation.0;
        set(&mut p.integrator, s.integrator.map(|c| c.0));
        set(&mut p.dt, s.dt);
        set(&mut p.gravity, s.gravity);

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
            set(&mut c.method, t.method.map(|m| m.0));
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
        (p, duration, camera)
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
    /// The file's `[[render_mesh]]`s, taken out (a cloth's own
    /// `render_mesh` is its [`ClothKeys::render_mesh`]).
    pub(super) fn take_render_meshes(&mut self) -> Vec<RenderMeshKeys> {
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
                cloth: t.cloth.map_or(0, |Whole(c)| c),
            });
        tables.collect()
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

impl Named for ContactMethod {
    const WHAT: &'static str = "self-collision method";
    const ALL: &'static [Self] = &[ContactMethod::Particles, ContactMethod::Triangles];
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
