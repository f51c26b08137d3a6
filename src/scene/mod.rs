//! Scene files (TOML) and the built-in scenes.
//!
//! A [`Scene`] is a validated cloth spec plus parameters: loading one either
//! succeeds completely or fails with an error that names the file, the key
//! and what is allowed. Nothing partial is ever returned.

use std::path::Path;

use crate::error::Result;
use crate::model::{ClothSpec, Model};
use crate::params::Params;

/// A complete, validated scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// Display name (the built-in name or the file stem).
    pub name: String,
    /// The cloth's geometry and mass.
    pub cloth: ClothSpec,
    /// Everything else.
    pub params: Params,
    /// How long the scene runs by default [s] (`[simulation] duration`).
    pub duration: f64,
}

impl Scene {
    /// Parses and validates a scene from TOML text; `path` is used in error
    /// messages only.
    pub fn from_toml(text: &str, path: &Path) -> Result<Scene> {
        todo!("scene helper: {text} {path:?}")
    }

    /// Reads, parses and validates a scene file.
    pub fn load(path: &Path) -> Result<Scene> {
        todo!("scene helper: {path:?}")
    }

    /// The names of the built-in scenes.
    pub fn builtin_names() -> &'static [&'static str] {
        &["hanging", "curtain", "flag", "drape"]
    }

    /// A built-in scene by name.
    pub fn builtin(name: &str) -> Result<Scene> {
        todo!("scene helper: {name}")
    }

    /// A path to a scene file if one exists there, else a built-in name.
    pub fn resolve(name_or_path: &str) -> Result<Scene> {
        todo!("scene helper: {name_or_path}")
    }

    /// Builds the model this scene describes.
    pub fn model(&self) -> Result<Model> {
        Model::new(&self.cloth, &self.params.springs)
    }
}
