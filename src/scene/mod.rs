//! Scene files (TOML) and the built-in scenes.
//!
//! A [`Scene`] is a validated cloth spec plus parameters: loading one either
//! succeeds completely or fails with an error that names the file, the key
//! and what is allowed. Nothing partial is ever returned.
//!
//! The format is described key by key in `docs/scene-format.md`. The schema
//! lives in `file.rs`; ranges are checked by [`ClothSpec::validate`] (a
//! mesh cloth's by [`MeshCloth::validate`]) and [`Params::validate`] only,
//! so a file and the library API accept exactly the same values.
//!
//! A mesh cloth's file (`[cloth] mesh`) is read when the scene is, relative
//! to the scene file's folder, so a bad mesh fails the load. A built-in
//! scene's mesh is embedded in the crate with the scene.

pub mod animation;
mod file;
mod shape;

use glam::{DQuat, DVec3};
use std::fmt::Write as _;
use std::io::Read as _;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::material::Material;
use crate::mesh::{Mesh, MeshCloth};
use crate::model::{ClothSpec, Model, Pin};
use crate::params::{check, check_finite, format_number, format_short, Params, SpringParams};
use crate::render_mesh::{Embedding, RenderMesh};
use crate::world::{self, SeamSpring};

/// A complete, validated scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// Display name (the built-in name or the file stem).
    pub name: String,
    /// The world's cloths in particle order (cloth 0's particles first):
    /// one for `[cloth]`, each `[[cloth]]` in the file's order.
    pub cloths: Vec<SceneCloth>,
    /// The `[[seam]]`s, as springs between the world's particles.
    pub seams: Vec<SeamSpring>,
    /// Everything else (for a scene of a `[material]`, its spring kinds are
    /// [`Material::spring_params`]).
    pub params: Params,
    /// How long the scene runs by default \[s\] (`[simulation] duration`).
    pub duration: f64,
    /// How `wgcloth render` looks at it (`[camera]`; absent keys: framed
    /// automatically).
    pub camera: CameraSpec,
    /// The scripted character (`[character]`), whose capsules are the last
    /// of `params.capsules` (posed at its first key) and which carries the
    /// cloths' pins; see [`Scene::animation`].
    pub character: Option<animation::Character>,
    /// The meshes drawn in place of the cloth (`[cloth] render_mesh`, then
    /// each `[[render_mesh]]`; a scene of one cloth only), placed as the
    /// cloth is: a mesh cloth's `scale` and `origin` apply to them too; a
    /// grid's are in the scene's frame.
    pub render_meshes: Vec<SceneRenderMesh>,
}

/// One cloth of a scene's world.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneCloth {
    /// Its geometry and mass. For a mesh cloth only its `origin`, `mass`
    /// and `pins` apply. For a cloth of a [`Material`] the model's masses
    /// are the material's (`mass` is then, on a grid, their sum).
    pub spec: ClothSpec,
    /// The mesh, for a mesh cloth (`mesh`); `None` for a grid.
    pub mesh: Option<MeshCloth>,
    /// Its material (the scene's `[material]` with the cloth's own
    /// `[cloth.material]` keys over it), whose density and stiffnesses give
    /// its masses and spring constants; `None`: `spec.mass` and `springs`
    /// give them.
    pub material: Option<Material>,
    /// Its own spring kinds: the scene's `[springs.*]` with the cloth's own
    /// `[cloth.springs.*]` stiffness and damping over them, or its own
    /// `[cloth.material]`'s [`Material::spring_params`]; `None`: the
    /// scene's (`params.springs`).
    pub springs: Option<[SpringParams; 3]>,
    /// `color`: its colour in pictures, sRGB components in 0..=1; `None`:
    /// the renderer's cloth colour.
    pub color: Option<DVec3>,
}

/// A render mesh of a scene: the mesh, placed, and how far from the cloth
/// its vertices may lie.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneRenderMesh {
    /// The mesh, its vertices in the scene's frame \[m\].
    pub mesh: RenderMesh,
    /// `max_distance` \[m\]: a vertex farther from the cloth is refused.
    pub max_distance: f64,
    /// The cloth it follows and is drawn in place of (its index among the
    /// scene's cloths).
    pub cloth: usize,
}

/// The `[camera]` table: each key overrides one choice of the automatic
/// framing (which looks at everything the cloth can reach, from 20° above
/// and 35° around, at a 45° field of view, far enough back to fit it all).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CameraSpec {
    /// The point looked at \[m\].
    pub target: Option<DVec3>,
    /// Distance from the eye to the target \[m\], `> 0`.
    pub distance: Option<f64>,
    /// Height of the eye as an angle above the target \[deg\], `−89..=89`.
    pub elevation: Option<f64>,
    /// Direction of the eye around the vertical axis, from +z towards +x
    /// \[deg\].
    pub azimuth: Option<f64>,
    /// Vertical field of view \[deg\], `5..=150`.
    pub fov: Option<f64>,
}

impl CameraSpec {
    /// Refuses a distance that is not positive, an elevation beyond ±89°,
    /// a field of view outside 5°–150°, and anything non-finite.
    pub fn validate(&self) -> Result<()> {
        let optional = |key: &str, v: Option<f64>, ok: fn(f64) -> bool, allowed: &str| match v {
            Some(x) => check(&format!("camera.{key}"), x, ok(x), allowed),
            None => Ok(()),
        };
        optional("distance", self.distance, |x| x > 0.0, "> 0 (m)")?;
        optional(
            "elevation",
            self.elevation,
            |x| x.abs() <= 89.0,
            "−89 ≤ elevation ≤ 89 (degrees)",
        )?;
        if let Some(azimuth) = self.azimuth {
            check_finite("camera.azimuth", azimuth, "degrees")?;
        }
        optional(
            "fov",
            self.fov,
            |x| (5.0..=150.0).contains(&x),
            "5 ≤ fov ≤ 150 (degrees)",
        )?;
        for (k, c) in self.target.iter().flat_map(|t| t.to_array()).enumerate() {
            check_finite(&format!("camera.target[{k}]"), c, "m")?;
        }
        Ok(())
    }
}

impl Scene {
    /// Parses and validates a scene from TOML text; `path` is used in error
    /// messages (and its stem as the scene's name) only.
    pub fn from_toml(text: &str, path: &Path) -> Result<Scene> {
        Scene::from_toml_with(text, path, &|file, name| Mesh::load(file, name), &|| false)
    }

    /// [`Scene::from_toml`] with `read_mesh` reading a mesh cloth's file
    /// (already resolved against the scene's folder) and picking its mesh,
    /// and `stop` asked while a collider bakes ([`crate::sdf::bake_until`]).
    fn from_toml_with(
        text: &str,
        path: &Path,
        read_mesh: &dyn Fn(&Path, Option<&str>) -> Result<Mesh>,
        stop: &dyn Fn() -> bool,
    ) -> Result<Scene> {
        let fail = |message: String| Error::Scene {
            path: path.to_path_buf(),
            message,
        };
        if let Some(message) = control_character(text) {
            return Err(fail(message));
        }
        let de = toml::Deserializer::parse(text).map_err(|e| {
            fail(format!(
                "{}TOML syntax error: {}",
                location(text, &e),
                e.message().trim_end()
            ))
        })?;
        let mut parsed: file::SceneFile =
            serde_path_to_error::deserialize(de).map_err(|e| fail(describe(text, &e)))?;
        let material = parsed.material().map_err(fail)?;
        let cloth_keys = parsed.take_cloths(material.as_ref()).map_err(fail)?;
        let seam_keys = parsed.take_seams();
        let (mut character, character_colliders) = parsed.take_character();
        let colliders = parsed.take_colliders();
        let mut render_mesh_keys = parsed.take_render_meshes();
        let (mut params, duration, camera) = parsed.into_parts(material.as_ref());
        if let Some(m) = &material {
            m.validate().map_err(|e| fail(e.to_string()))?;
        }
        if let Some(c) = &character {
            c.validate().map_err(|e| fail(e.to_string()))?;
            let start = c.keys.first().map_or(0.0, |k| k.time);
            params.capsules.extend(c.capsules_at(start));
        }
        // The key names in `InvalidParameter` are already the file's
        // spelling, so its message is the scene message as is.
        params
            .validate()
            .and_then(|()| check_duration(duration))
            .and_then(|()| camera.validate())
            .map_err(|e| fail(e.to_string()))?;
        let in_file = |e: Error| match e {
            Error::InvalidParameter { .. } => fail(e.to_string()),
            e => e,
        };
        for (n, keys) in colliders.into_iter().enumerate() {
            let collider = mesh_collider(&format!("collider[{n}]"), keys, path, read_mesh, stop);
            params.mesh_colliders.push(collider.map_err(in_file)?);
        }
        if let Some(c) = &mut character {
            for (n, keys) in character_colliders.into_iter().enumerate() {
                let key = format!("character.collider[{n}]");
                let collider = mesh_collider(&key, keys, path, read_mesh, stop);
                c.colliders.push(collider.map_err(in_file)?);
            }
            let start = c.keys.first().map_or(0.0, |k| k.time);
            params.mesh_colliders.extend(c.colliders_at(start));
        }
        let mut cloths = Vec::with_capacity(cloth_keys.len());
        // Each cloth's own `render_mesh` first, in cloth order, then the
        // `[[render_mesh]]`s.
        let mut own_render_meshes = Vec::new();
        for (c, mut keys) in cloth_keys.into_iter().enumerate() {
            if let Some(file) = keys.render_mesh.take() {
                own_render_meshes.push(file::RenderMeshKeys {
                    key: format!("{}.render_mesh", keys.key),
                    file,
                    name: None,
                    max_distance: file::DEFAULT_RENDER_MESH_DISTANCE,
                    cloth: c,
                });
            }
            cloths.push(scene_cloth(keys, path, read_mesh).map_err(in_file)?);
        }
        own_render_meshes.append(&mut render_mesh_keys);
        let seams = seam_springs(&cloths, seam_keys).map_err(in_file)?;
        let mut render_meshes = Vec::with_capacity(own_render_meshes.len());
        for keys in own_render_meshes {
            check(
                &format!("{}.max_distance", keys.key),
                keys.max_distance,
                keys.max_distance > 0.0,
                "> 0 [m]",
            )
            .map_err(|e| fail(e.to_string()))?;
            let Some(cloth) = cloths.get(keys.cloth) else {
                return Err(fail(format!(
                    "`{}.cloth` = {}: not a cloth of this scene, which has {} (0 ≤ cloth < {})",
                    keys.key,
                    keys.cloth,
                    cloths.len(),
                    cloths.len()
                )));
            };
            // Placed as its cloth is: a mesh cloth's scale and origin.
            let (scale, origin) = match &cloth.mesh {
                Some(m) => (m.scale, cloth.spec.origin),
                None => (1.0, DVec3::ZERO),
            };
            let file = path.parent().unwrap_or(Path::new("")).join(&keys.file);
            let read = read_mesh(&file, keys.name.as_deref())?;
            // Named as the scene writes it (as a mesh cloth's file is).
            render_meshes.push(SceneRenderMesh {
                mesh: RenderMesh::from_mesh(Path::new(&keys.file), &read, scale, origin),
                max_distance: keys.max_distance,
                cloth: keys.cloth,
            });
        }
        let name = path
            .file_stem()
            .map_or_else(|| "scene".to_string(), |s| s.to_string_lossy().into_owned());
        let scene = Scene {
            name,
            cloths,
            seams,
            params,
            duration,
            camera,
            character,
            render_meshes,
        };
        Ok(scene)
    }

    /// The animation of this scene's `[character]` on `model` (this scene's
    /// model), `None` without one: a host calls its
    /// [`apply`](animation::Animation::apply) once per frame.
    pub fn animation(&self, model: &Model) -> Option<animation::Animation> {
        self.character.as_ref().map(|c| {
            let others = self.params.capsules.len().saturating_sub(c.capsules.len());
            let meshes = self
                .params
                .mesh_colliders
                .len()
                .saturating_sub(c.colliders.len());
            animation::Animation::new(
                c,
                &self.params.capsules[..others],
                &self.params.mesh_colliders[..meshes],
                model,
            )
        })
    }

    /// Reads, parses and validates a scene file. A directory, anything
    /// that is not a regular file (a FIFO, a device such as `/dev/zero`
    /// behind a symlink) and a file over [`MAX_SCENE_BYTES`] are refused
    /// without being read.
    pub fn load(path: &Path) -> Result<Scene> {
        Scene::load_until(path, &|| false)
    }

    /// [`Scene::load`], its colliders' bakes asking `stop` ([`Scene::resolve_until`]).
    fn load_until(path: &Path, stop: &dyn Fn() -> bool) -> Result<Scene> {
        let text = read_scene_text(path).map_err(|message| Error::Scene {
            path: path.to_path_buf(),
            message,
        })?;
        Scene::from_toml_with(&text, path, &|file, name| Mesh::load(file, name), stop)
    }

    /// The names of the built-in scenes.
    pub fn builtin_names() -> &'static [&'static str] {
        &[
            "hanging",
            "curtain",
            "flag",
            "drape",
            "tablecloth",
            "banner",
            "cape",
            "heap",
            "table",
            "layers",
            "skirt",
        ]
    }

    /// A built-in scene by name.
    pub fn builtin(name: &str) -> Result<Scene> {
        Scene::builtin_until(name, &|| false)
    }

    /// [`Scene::builtin`], its colliders' bakes asking `stop`.
    fn builtin_until(name: &str, stop: &dyn Fn() -> bool) -> Result<Scene> {
        // Embedded so a built-in scene works from any working directory.
        let text = match name {
            "hanging" => include_str!("../../scenes/hanging.toml"),
            "curtain" => include_str!("../../scenes/curtain.toml"),
            "flag" => include_str!("../../scenes/flag.toml"),
            "drape" => include_str!("../../scenes/drape.toml"),
            "tablecloth" => include_str!("../../scenes/tablecloth.toml"),
            "banner" => include_str!("../../scenes/banner.toml"),
            "cape" => include_str!("../../scenes/cape.toml"),
            "heap" => include_str!("../../scenes/heap.toml"),
            "table" => include_str!("../../scenes/table.toml"),
            "layers" => include_str!("../../scenes/layers.toml"),
            "skirt" => include_str!("../../scenes/skirt.toml"),
            _ => {
                return Err(Error::UnknownScene {
                    name: name.to_string(),
                    available: Scene::builtin_names().join(", "),
                })
            }
        };
        let path = Path::new("scenes").join(format!("{name}.toml"));
        Scene::from_toml_with(
            text,
            &path,
            &|file, mesh_name| {
                let bytes = builtin_mesh(file).ok_or_else(|| Error::Mesh {
                    path: file.to_path_buf(),
                    message: "is not a mesh embedded with the built-in scenes".to_string(),
                })?;
                Mesh::parse(bytes, file, mesh_name, &|uri| {
                    Err(format!("a built-in mesh has no external buffer `{uri}`"))
                })
            },
            stop,
        )
    }

    /// A path to a scene file if one exists there, else a built-in name.
    ///
    /// A regular file wins over a built-in name; a built-in name wins over
    /// a directory of that name (a folder called `flag` must not hide the
    /// built-in scene). Anything else that exists (a directory, a FIFO) or
    /// any name ending in `.toml` is taken as a path, so it is refused as
    /// what it is, and a mistyped file name reports the missing file rather
    /// than an unknown built-in.
    pub fn resolve(name_or_path: &str) -> Result<Scene> {
        Scene::resolve_until(name_or_path, &|| false)
    }

    /// [`Scene::resolve`], asking `stop` while a `[[collider]]` mesh bakes
    /// (a fine grid takes a minute): once it says so, the load ends with
    /// [`Error::Interrupted`] within a row of lattice points.
    pub fn resolve_until(name_or_path: &str, stop: &dyn Fn() -> bool) -> Result<Scene> {
        let path = Path::new(name_or_path);
        if path.is_file() {
            Scene::load_until(path, stop)
        } else if Scene::builtin_names().contains(&name_or_path) {
            Scene::builtin_until(name_or_path, stop)
        } else if path.symlink_metadata().is_ok() || name_or_path.ends_with(".toml") {
            Scene::load_until(path, stop)
        } else {
            Scene::builtin_until(name_or_path, stop)
        }
    }

    /// Builds the model of this scene's world: its cloths in order, joined
    /// by its seams ([`world::join`]); a scene of one cloth without seams
    /// builds that cloth's model.
    pub fn model(&self) -> Result<Model> {
        let several = self.cloths.len() > 1;
        let mut parts = Vec::with_capacity(self.cloths.len());
        for (n, cloth) in self.cloths.iter().enumerate() {
            let key = match several {
                true => format!("cloth[{n}]"),
                false => "cloth".to_string(),
            };
            let model = cloth.model(&self.params).map_err(|e| name_cloth(e, &key))?;
            parts.push((model, cloth.springs.unwrap_or(self.params.springs)));
        }
        world::join(parts, &self.params.springs, &self.seams)
    }

    /// Each render mesh embedded in `model` (this scene's model), in
    /// order; a vertex farther from the cloth than its mesh's
    /// `max_distance` is refused, by name.
    pub fn embeddings(&self, model: &Model) -> Result<Vec<Embedding>> {
        self.render_meshes
            .iter()
            .map(|r| Embedding::on_cloth(model, r.cloth, &r.mesh, r.max_distance))
            .collect()
    }

    /// Each cloth's `color` (sRGB components), in order, for
    /// [`Renderer::set_cloth_colors`](crate::render::Renderer::set_cloth_colors).
    pub fn cloth_colors(&self) -> Vec<Option<[f64; 3]>> {
        self.cloths
            .iter()
            .map(|c| c.color.map(|c| c.to_array()))
            .collect()
    }

    /// Number of particles of the world.
    pub fn particle_count(&self) -> usize {
        self.cloths.iter().map(SceneCloth::particle_count).sum()
    }

    /// The world in a few words: `33 × 33 = 1089 particles` for a grid,
    /// `mesh banner.gltf, 432 particles` for a mesh, `3 cloths (33 × 33,
    /// 25 × 25, 17 × 17) = 2003 particles` for a world of several.
    pub fn cloth_summary(&self) -> String {
        match &self.cloths[..] {
            [one] => one.summary(),
            cloths => format!(
                "{} cloths ({}) = {} particles",
                cloths.len(),
                cloths
                    .iter()
                    .map(SceneCloth::shape)
                    .collect::<Vec<_>>()
                    .join(", "),
                self.particle_count()
            ),
        }
    }
}

impl SceneCloth {
    /// Builds this cloth's model under `params` (whose spring kinds its
    /// own replace).
    pub fn model(&self, params: &Params) -> Result<Model> {
        let springs = self.springs.unwrap_or(params.springs);
        let mut model = match &self.mesh {
            Some(mesh) => mesh.model(&self.spec, &springs)?,
            None => Model::new(&self.spec, &springs)?,
        };
        if let Some(material) = &self.material {
            match &self.mesh {
                Some(mesh) => {
                    let warps = SceneCloth::warps(material, mesh, &model.rest_positions)?;
                    let faces = mesh.mesh.faces.iter().map(|f| f.corners());
                    material.apply(&mut model, faces.zip(warps))?
                }
                None => {
                    let cells = model.grid_cells();
                    let warp = model.grid_warp();
                    material.apply(&mut model, cells.iter().map(|c| (&c[..], warp)))?
                }
            }
            let params = Params {
                springs,
                ..params.clone()
            };
            material.check_explicit(&model, &params)?;
        }
        Ok(model)
    }

    /// Number of particles.
    pub fn particle_count(&self) -> usize {
        match &self.mesh {
            Some(mesh) => mesh.mesh.vertex_count(),
            None => self.spec.particle_count(),
        }
    }

    /// Rest positions \[m\], particle order.
    pub fn rest_positions(&self) -> Vec<DVec3> {
        match &self.mesh {
            Some(mesh) => mesh.rest_positions(&self.spec),
            None => (0..self.spec.particle_count())
                .map(|p| self.spec.rest_position(p))
                .collect(),
        }
    }

    /// The cloth's shape: `33 × 33` for a grid, `mesh banner.gltf` for a
    /// mesh.
    pub fn shape(&self) -> String {
        match &self.mesh {
            Some(mesh) => format!("mesh {}", mesh.path.display()),
            None => format!("{} × {}", self.spec.nx, self.spec.ny),
        }
    }

    /// The cloth in a few words: `33 × 33 = 1089 particles` for a grid,
    /// `mesh banner.gltf, 432 particles` for a mesh.
    pub fn summary(&self) -> String {
        match &self.mesh {
            Some(mesh) => format!(
                "mesh {}, {} particles",
                mesh.path.display(),
                mesh.mesh.vertex_count()
            ),
            None => format!(
                "{} × {} = {} particles",
                self.spec.nx,
                self.spec.ny,
                self.spec.particle_count()
            ),
        }
    }

    /// Refuses a material whose shear stiffness is too large for the
    /// cloth's cells (what [`Material::apply`] would refuse), before
    /// anything is built: a grid's cells are all one rectangle.
    fn check_material_geometry(&self) -> Result<()> {
        let Some(material) = &self.material else {
            return Ok(());
        };
        match &self.mesh {
            None => {
                let c = &self.spec;
                let (w, h) = (c.size[0] / (c.nx - 1) as f64, c.size[1] / (c.ny - 1) as f64);
                material.check_grid_cell(w, h)
            }
            Some(mesh) => {
                let rest = mesh.rest_positions(&self.spec);
                let warps = SceneCloth::warps(material, mesh, &rest)?;
                material
                    .edge_stiffness(
                        &rest,
                        mesh.mesh.faces.iter().map(|f| f.corners()).zip(warps),
                    )
                    .map(|_| ())
            }
        }
    }

    /// Each face's warp on a mesh cloth of `material` at the rest
    /// positions `rest` ([`Mesh::warp_directions`]), for a material that
    /// needs it; else no direction, which an isotropic material ignores.
    /// Refuses a mesh whose faces do not give one, naming the key that
    /// needs it.
    fn warps(material: &Material, mesh: &MeshCloth, rest: &[DVec3]) -> Result<Vec<DVec3>> {
        if !material.is_anisotropic() {
            return Ok(vec![DVec3::ZERO; mesh.mesh.faces.len()]);
        }
        let (key, value) = if material.stretch.is_isotropic() {
            ("material.bending", material.bending)
        } else {
            ("material.stretch", material.stretch)
        };
        mesh.mesh
            .warp_directions(rest)
            .map_err(|why| Error::InvalidParameter {
                key: key.to_string(),
                allowed: format!(
                    "one number (the same along warp and weft) on a mesh without a warp: a \
                     value per direction needs {why} (in {})",
                    mesh.path.display()
                ),
                got: value.to_string(),
            })
    }
}

/// `e` with its `cloth.` or `material.` key named for the cloth `cloth`
/// (`cloth[1]`: `cloth[1].pins[2]`, `cloth[1].material.density`); as it
/// is for `cloth`, the one cloth of a `[cloth]` table.
fn name_cloth(e: Error, cloth: &str) -> Error {
    match e {
        Error::InvalidParameter { key, allowed, got } if cloth != "cloth" => {
            Error::InvalidParameter {
                key: match key.strip_prefix("cloth.") {
                    Some(rest) => format!("{cloth}.{rest}"),
                    None if key.starts_with("material.") => format!("{cloth}.{key}"),
                    None => key,
                },
                allowed,
                got,
            }
        }
        e => e,
    }
}

/// A cloth of the scene file `path` from its keys: its mesh read (through
/// `read_mesh`, relative to the scene's folder) and everything checked,
/// its material against its cells included, errors naming the cloth as
/// the file does (`cloth`, `cloth[1]`).
fn scene_cloth(
    keys: file::ClothKeys,
    path: &Path,
    read_mesh: &dyn Fn(&Path, Option<&str>) -> Result<Mesh>,
) -> Result<SceneCloth> {
    let file::ClothKeys {
        key,
        mut spec,
        mesh,
        material,
        springs,
        color,
        ..
    } = keys;
    let named = |e: Error| name_cloth(e, &key);
    if let Some(m) = &material {
        m.validate().map_err(named)?;
        // What the model's masses add up to on a grid (a mesh's follow
        // from its faces' areas).
        spec.mass = m.density * spec.size[0] * spec.size[1];
    }
    if let Some(springs) = &springs {
        crate::params::check_springs(&format!("{key}.springs"), springs)?;
    }
    if let Some(c) = color {
        for (k, v) in c.to_array().into_iter().enumerate() {
            check(
                &format!("{key}.color[{k}]"),
                v,
                (0.0..=1.0).contains(&v),
                "0 ≤ component ≤ 1 (sRGB)",
            )?;
        }
    }
    let mesh = match mesh {
        None => {
            spec.validate().map_err(named)?;
            None
        }
        Some(keys) => {
            if !keys.origin_given {
                spec.origin = DVec3::ZERO;
            }
            if !keys.pins_given {
                spec.pins.clear();
            }
            check(
                &format!("{key}.scale"),
                keys.scale,
                keys.scale > 0.0,
                "> 0 (a factor)",
            )?;
            let file = path.parent().unwrap_or(Path::new("")).join(&keys.file);
            let mesh = MeshCloth {
                mesh: read_mesh(&file, keys.name.as_deref())?,
                path: PathBuf::from(keys.file),
                mesh_name: keys.name,
                scale: keys.scale,
            };
            mesh.validate(&spec).map_err(named)?;
            Some(mesh)
        }
    };
    let cloth = SceneCloth {
        spec,
        mesh,
        material,
        springs,
        color,
    };
    cloth.check_material_geometry().map_err(named)?;
    Ok(cloth)
}

/// The `[[seam]]`s of a scene as springs between the world's particles:
/// each side's particles in order (a grid edge's as a pin of that name
/// lists them, `vertices` as written, a `box`'s along its longest side),
/// joined one to one. Refuses an unknown cloth or edge, an index past
/// the cloth, an empty side and sides of different counts, naming the
/// keys.
fn seam_springs(cloths: &[SceneCloth], seams: Vec<file::SeamKeys>) -> Result<Vec<SeamSpring>> {
    let mut starts = Vec::with_capacity(cloths.len());
    let mut at = 0usize;
    for c in cloths {
        starts.push(at);
        at += c.particle_count();
    }
    let mut out = Vec::new();
    for (n, seam) in seams.into_iter().enumerate() {
        for (name, v) in [("stiffness", seam.stiffness), ("damping", seam.damping)] {
            if let Some(v) = v {
                check(
                    &format!("seam[{n}].{name}"),
                    v,
                    (0.0..=1e9).contains(&v),
                    "0 ≤ value ≤ 1e9 (N/m, N·s/m)",
                )?;
            }
        }
        let a = seam_side(cloths, &format!("seam[{n}].a"), &seam.a)?;
        let b = seam_side(cloths, &format!("seam[{n}].b"), &seam.b)?;
        if a.len() != b.len() {
            return Err(Error::InvalidParameter {
                key: format!("seam[{n}]"),
                allowed: "two sides of as many particles (a seam joins them one to one)".into(),
                got: format!(
                    "`seam[{n}].a` has {} particles, `seam[{n}].b` {}",
                    a.len(),
                    b.len()
                ),
            });
        }
        let (ca, cb) = (starts[seam.a.cloth], starts[seam.b.cloth]);
        for (&p, &q) in a.iter().zip(&b) {
            let (p, q) = ((ca + p) as u32, (cb + q) as u32);
            if p == q {
                return Err(Error::InvalidParameter {
                    key: format!("seam[{n}]"),
                    allowed: "two sides that join distinct particles".into(),
                    got: format!("particle {p} on both sides"),
                });
            }
            out.push(SeamSpring {
                a: p,
                b: q,
                stiffness: seam.stiffness,
                damping: seam.damping,
            });
        }
    }
    Ok(out)
}

/// The particles of one side of a seam (`key`: `seam[0].a`), indices
/// within its cloth, in order.
fn seam_side(cloths: &[SceneCloth], key: &str, side: &file::SeamSideKeys) -> Result<Vec<usize>> {
    let Some(cloth) = cloths.get(side.cloth) else {
        return Err(Error::InvalidParameter {
            key: format!("{key}.cloth"),
            allowed: format!("a cloth of the scene: 0 ≤ cloth < {}", cloths.len()),
            got: side.cloth.to_string(),
        });
    };
    let given = [
        side.edge.is_some(),
        side.vertices.is_some(),
        side.bounds.is_some(),
    ];
    if given.iter().filter(|&&g| g).count() != 1 {
        return Err(Error::InvalidParameter {
            key: key.to_string(),
            allowed: "exactly one of `edge`, `vertices` and `box`".into(),
            got: format!("{} of them", given.iter().filter(|&&g| g).count()),
        });
    }
    let count = cloth.particle_count();
    let particles: Vec<usize> = if let Some(edge) = &side.edge {
        let pin = Pin::parse(edge).filter(|p| matches!(p, Pin::Edge(_)));
        match (pin, &cloth.mesh) {
            (Some(pin), None) => cloth.spec.pin_indices(pin),
            (None, _) => {
                return Err(Error::InvalidParameter {
                    key: format!("{key}.edge"),
                    allowed: "one of top, bottom, left, right (a grid's edges, as pins name them)"
                        .into(),
                    got: format!("\"{edge}\""),
                })
            }
            (Some(_), Some(_)) => {
                return Err(Error::InvalidParameter {
                    key: format!("{key}.edge"),
                    allowed: "an edge of a grid cloth; a mesh cloth's side is `vertices` or `box`"
                        .into(),
                    got: format!("\"{edge}\" of mesh cloth {}", side.cloth),
                })
            }
        }
    } else if let Some(vertices) = &side.vertices {
        if let Some((k, &v)) = vertices.iter().enumerate().find(|&(_, &v)| v >= count) {
            return Err(Error::InvalidParameter {
                key: format!("{key}.vertices[{k}]"),
                allowed: format!("a particle of cloth {}: 0 ≤ index < {count}", side.cloth),
                got: v.to_string(),
            });
        }
        vertices.clone()
    } else if let Some([lo, hi]) = side.bounds {
        let pin = Pin::Region([lo, hi]);
        pin.check_region(key)?;
        let rest = cloth.rest_positions();
        let longest = (hi - lo).max_position();
        let mut inside: Vec<usize> = (0..count).filter(|&p| pin.contains(rest[p])).collect();
        inside.sort_by(|&p, &q| {
            rest[p][longest]
                .total_cmp(&rest[q][longest])
                .then(p.cmp(&q))
        });
        inside
    } else {
        Vec::new()
    };
    if particles.is_empty() {
        return Err(Error::InvalidParameter {
            key: key.to_string(),
            allowed: "a side with at least one particle".into(),
            got: "none".into(),
        });
    }
    Ok(particles)
}

/// The `[[collider]]` `key` (`collider[0]`) of the scene file `scene` from its keys:
/// its numbers checked, then its mesh read (through `read_mesh`, relative
/// to the scene's folder, as a mesh cloth's) and baked.
fn mesh_collider(
    key: &str,
    k: file::ColliderKeys,
    scene: &Path,
    read_mesh: &dyn Fn(&Path, Option<&str>) -> Result<Mesh>,
    stop: &dyn Fn() -> bool,
) -> Result<crate::sdf::MeshCollider> {
    check(
        &format!("{key}.scale"),
        k.scale,
        k.scale > 0.0 && k.scale.is_finite(),
        "> 0 (a factor on the mesh file's coordinates)",
    )?;
    check(
        &format!("{key}.thickness"),
        k.thickness,
        k.thickness >= 0.0 && k.thickness.is_finite(),
        "≥ 0 (m)",
    )?;
    check(
        &format!("{key}.friction"),
        k.friction,
        k.friction >= 0.0 && k.friction.is_finite(),
        "friction ≥ 0",
    )?;
    let rotation = collider_rotation(key, k.axis, k.degrees)?;
    let pose = crate::sdf::MeshPose {
        position: k.position,
        rotation,
        velocity: k.velocity,
        angular_velocity: k.angular_velocity,
    };
    crate::params::check_mesh_pose(key, &pose)?;
    let file = scene.parent().unwrap_or(Path::new("")).join(&k.file);
    let mesh = read_mesh(&file, k.name.as_deref())?;
    let resolution = crate::sdf::check_resolution(key, k.resolution)?;
    let grid = crate::sdf::bake_until(&mesh, &file, key, k.scale, resolution, k.thickness, stop)?;
    let collider = crate::sdf::MeshCollider {
        path: PathBuf::from(k.file),
        grid: std::sync::Arc::new(grid),
        position: pose.position,
        rotation,
        velocity: pose.velocity,
        angular_velocity: pose.angular_velocity,
        friction: k.friction,
        thickness: k.thickness,
    };
    // A scene file's body keeps its orientation (nothing sets its pose
    // each frame), so it may turn only about an axis it is round about.
    if let Some((normal, rim)) = collider.turning_off_axis() {
        let w = pose.angular_velocity;
        return Err(Error::InvalidParameter {
            key: format!("{key}.angular_velocity"),
            allowed: format!(
                "a turning about an axis the body is round about (a turntable, a roller), \
                 through its `position`: a collider keeps its orientation, so only such a \
                 body's surface moves along itself as it turns; this one's would move along \
                 its normal at up to {} m/s, {} % of its rim speed of {} m/s (at most {} %), and \
                 drive the cloth round a body that does not turn; turn any other body by \
                 setting its pose each frame through the API",
                format_short(normal),
                format_short(100.0 * normal / rim),
                format_short(rim),
                format_short(100.0 * crate::sdf::MAX_TURNING_NORMAL_SHARE)
            ),
            got: format!(
                "[{}, {}, {}]",
                format_number(w.x),
                format_number(w.y),
                format_number(w.z)
            ),
        });
    }
    Ok(collider)
}

/// A collider's `rotation = [x, y, z, degrees]` (`key`: `collider[0]`)
/// as a unit quaternion, or what is wrong with it: a component that is
/// not finite (named by its place), and a zero axis with a non-zero
/// angle. Any finite axis but zero has a direction, however long or
/// short: it is scaled by its largest component before it is normalised,
/// so that its squared length neither overflows nor underflows.
fn collider_rotation(key: &str, axis: DVec3, degrees: f64) -> Result<DQuat> {
    for (c, value) in axis.to_array().into_iter().enumerate() {
        check_finite(&format!("{key}.rotation[{c}]"), value, "an axis component")?;
    }
    check_finite(
        &format!("{key}.rotation[3]"),
        degrees,
        "the angle in degrees",
    )?;
    if degrees == 0.0 {
        return Ok(DQuat::IDENTITY);
    }
    let largest = axis.abs().max_element();
    if largest == 0.0 {
        return Err(Error::InvalidParameter {
            key: format!("{key}.rotation"),
            allowed: "[x, y, z, degrees] with an axis other than [0, 0, 0] where the angle is \
                      not 0 (any length: only its direction counts)"
                .to_string(),
            got: format!("[0, 0, 0, {}]", format_number(degrees)),
        });
    }
    Ok(DQuat::from_axis_angle(
        (axis / largest).normalize(),
        degrees.to_radians(),
    ))
}

/// The mesh files of the built-in scenes, embedded so a built-in scene
/// works from any working directory; `file` as the scene resolves it
/// (`scenes/<file>`).
fn builtin_mesh(file: &Path) -> Option<&'static [u8]> {
    let name = file.strip_prefix("scenes").ok()?.to_str()?;
    Some(match name {
        "tablecloth.obj" => include_bytes!("../../scenes/tablecloth.obj"),
        "banner.gltf" => include_bytes!("../../scenes/banner.gltf"),
        "table.obj" => include_bytes!("../../scenes/table.obj"),
        "cape_detail.obj" => include_bytes!("../../scenes/cape_detail.obj"),
        "skirt_front.obj" => include_bytes!("../../scenes/skirt_front.obj"),
        "skirt_back.obj" => include_bytes!("../../scenes/skirt_back.obj"),
        _ => return None,
    })
}

/// Largest scene file read \[bytes\]: the built-in scenes are about 1 KiB
/// and a hand-written scene a few KiB, so 1 MiB leaves room for any scene
/// (long comments, many spheres) while a wrong path (a log, a disk image,
/// `/dev/zero` behind a symlink) is refused at once instead of read until
/// memory runs out.
pub const MAX_SCENE_BYTES: u64 = 1 << 20;

/// The text of a scene file, or what is wrong with the path: checked
/// before it is opened (opening a FIFO would block), and read through
/// [`Read::take`] so that a file growing after the check is still cut off
/// at [`MAX_SCENE_BYTES`] + 1 bytes.
fn read_scene_text(path: &Path) -> std::result::Result<String, String> {
    let cannot = |e: std::io::Error| format!("cannot read the file: {e}");
    let meta = std::fs::metadata(path).map_err(cannot)?;
    if meta.is_dir() {
        return Err(
            "is a directory, not a scene file (give a `.toml` file or a \
                    built-in scene name)"
                .to_string(),
        );
    }
    if !meta.is_file() {
        return Err(
            "is not a regular file (a device, FIFO or socket), not a scene file".to_string(),
        );
    }
    let too_large = || {
        format!(
            "is larger than {} MiB, the most a scene file may hold; a scene is a few KiB \
             of TOML, so this is probably not one",
            MAX_SCENE_BYTES >> 20
        )
    };
    if meta.len() > MAX_SCENE_BYTES {
        return Err(too_large());
    }
    let file = std::fs::File::open(path).map_err(cannot)?;
    let mut bytes = Vec::new();
    file.take(MAX_SCENE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(cannot)?;
    if bytes.len() as u64 > MAX_SCENE_BYTES {
        return Err(too_large());
    }
    String::from_utf8(bytes).map_err(|e| {
        format!(
            "is not UTF-8 text (byte {} is not valid), so not a TOML scene file",
            e.utf8_error().valid_up_to()
        )
    })
}

/// `[simulation] duration` is the one key `Params` does not hold, so the
/// scene checks it, with the error `validate` would give.
fn check_duration(duration: f64) -> Result<()> {
    check(
        "simulation.duration",
        duration,
        duration > 0.0 && duration <= 1e6,
        "0 < duration ≤ 1e6 (seconds)",
    )
}

/// `line L, column C: ` for an error toml could place, else nothing.
fn location(text: &str, err: &toml::de::Error) -> String {
    err.span()
        .map_or_else(String::new, |span| at_byte(text, span.start))
}

/// "line L, column C: " of byte `at` of `text`.
fn at_byte(text: &str, at: usize) -> String {
    let before = text.get(..at).unwrap_or(text);
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let column = before[line_start..].chars().count() + 1;
    format!("line {line}, column {column}: ")
}

/// The first control character TOML forbids in `text` (U+0000 to U+001F
/// but tab, newline and carriage return, and U+007F, anywhere: in
/// strings they are written as escapes), as a message: where it is and what it is. The TOML parser
/// would report it as whatever token it broke (`invalid float` for a NUL
/// after a number), which does not say what is in the file.
fn control_character(text: &str) -> Option<String> {
    let (at, c) = text
        .char_indices()
        .find(|&(_, c)| (c <= '\u{1f}' || c == '\u{7f}') && !matches!(c, '\t' | '\n' | '\r'))?;
    let name = if c == '\0' {
        "a NUL byte"
    } else {
        "a control character"
    };
    Some(format!(
        "{}{name} (U+{:04X}): a TOML file may hold no control character but tab, newline and \
         carriage return (in a string, write it as the escape `\\u{:04X}`); a scene file is \
         text, so this one may not be a scene",
        at_byte(text, at),
        u32::from(c),
        u32::from(c)
    ))
}

/// A schema error as "line L, column C: \`key\`: what is wrong; write
/// <the value's form>", each part where known.
fn describe(text: &str, err: &serde_path_to_error::Error<toml::de::Error>) -> String {
    let key = err.path().to_string();
    let mut out = location(text, err.inner());
    if key != "." {
        let _ = write!(out, "`{key}`: ");
    }
    // serde speaks of fields, maps and sequences; a scene file has keys,
    // tables and arrays.
    let message = err
        .inner()
        .message()
        .replace("unknown field", "unknown key")
        .replace("missing field", "missing key")
        .replace("invalid type: map,", "invalid type: a table,")
        .replace("invalid type: sequence,", "invalid type: an array,")
        // An integer beyond 64 bits, where no visitor takes one (a
        // boolean, a string): serde adds the Rust type it was read as.
        .replace("` as i128,", "`,")
        .replace("` as u128,", "`,")
        .replace(
            "integer number overflowed",
            "an integer too large to read (beyond 128 bits; a float such as 1e40 is read)",
        );
    out.push_str(&message);
    if let Some(shape) = expected_shape(&key) {
        let _ = write!(out, "; write {shape}");
    }
    out
}

/// What a key's value looks like, with its unit, to follow serde's terse
/// "expected f64". Ranges are left to `validate`'s messages.
fn expected_shape(key: &str) -> Option<&'static str> {
    if key.starts_with("cloth.pins[") && !key.ends_with(".box") {
        // The pin parser's own message already lists every allowed entry.
        return None;
    }
    // `sphere[1].radius` → `sphere.radius`; `gravity[2]` → `gravity`.
    let mut bare = String::with_capacity(key.len());
    let mut in_index = false;
    for c in key.chars() {
        match c {
            '[' => in_index = true,
            ']' => in_index = false,
            _ if !in_index => bare.push(c),
            _ => {}
        }
    }
    // The three spring kinds share their keys.
    for kind in ["stretch.", "shear.", "bend."] {
        bare = bare.replace(&format!("springs.{kind}"), "springs.");
    }
    Some(match bare.as_str() {
        "simulation.dt" | "simulation.duration" => "a number of seconds",
        "simulation.gravity" => "[x, y, z], three numbers in m/s²",
        "cloth.resolution" => "[nx, ny], two whole numbers of particles",
        "cloth.size" => "[width, height], two numbers in m",
        "cloth.origin" | "sphere.center" | "capsule.a" | "capsule.b" => {
            "[x, y, z], three numbers in m"
        }
        "sphere.velocity" | "capsule.velocity" => "[x, y, z], three numbers in m/s",
        "cloth.mass" => "a number of kg (the whole cloth)",
        "cloth.pins" => {
            "an array of pin names, particle indices and boxes, e.g. \
             [\"top-left\", 5, { box = [[0, 1, 0], [0.1, 1, 0.1]] }]"
        }
        "cloth.pins.box" => "[[x0, y0, z0], [x1, y1, z1]], two corners in m",
        "cloth.mesh" => "a file path in quotes (.obj, .gltf or .glb), relative to the scene file",
        "cloth.mesh_name" => "the name of a mesh of the glTF file, in quotes",
        "cloth.scale" => "a number (a factor on the mesh file's coordinates)",
        "springs.stiffness" => "a number in N/m",
        "springs.damping" => "a number in N·s/m",
        "springs.max_stretch" => "a number, a multiple of the rest length",
        "fixup.iterations" | "implicit.max_iterations" => "a whole number",
        "fixup.omega" | "implicit.tolerance" => "a number",
        "semi_implicit.torque_compensation" | "implicit.coarse_levels" => "true or false",
        "ground.height" | "sphere.radius" | "capsule.radius" => "a number in m",
        "ground.friction" | "sphere.friction" | "capsule.friction" => {
            "a number (friction coefficient)"
        }
        "collider.mesh" => {
            "a file path in quotes (.obj, .gltf or .glb) of a closed mesh, relative to the \
             scene file"
        }
        "collider.mesh_name" => "the name of a mesh of the glTF file, in quotes",
        "collider.position" => "[x, y, z], three numbers in m",
        "collider.rotation" => "[x, y, z, degrees]: an axis and an angle in degrees",
        "collider.scale" => "a number (a factor on the mesh file's coordinates)",
        "collider.friction" => "a number (friction coefficient)",
        "collider.velocity" => "[x, y, z], three numbers in m/s",
        "collider.angular_velocity" => "[x, y, z], three numbers in rad/s",
        "collider.resolution" => "a whole number of cells along the mesh's longest side",
        "collider.thickness" => "a number in m",
        "wind.velocity" => "[x, y, z], three numbers in m/s",
        "wind.drag" | "wind.lift" => "a number in kg/m³",
        "camera.target" => "[x, y, z], three numbers in m",
        "camera.distance" => "a number in m",
        "camera.elevation" | "camera.azimuth" | "camera.fov" => "a number of degrees",
        "character.capsule.a" | "character.capsule.b" | "character.key.position" => {
            "[x, y, z], three numbers in m"
        }
        "character.capsule.radius" => "a number in m",
        "character.capsule.friction" => "a number (friction coefficient)",
        "character.key.time" => "a number of seconds",
        "character.key.yaw" => "a number of degrees",
        _ => return None,
    })
}
