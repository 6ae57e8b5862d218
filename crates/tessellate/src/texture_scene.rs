//! The textures a scene's shaders name, resolved as RenderMan does, shared by every consumer:
//! the ray tracer's materials, lights and displacement, and the haptics' displaced surfaces
//! (`tessellate_scene`), so that both read the same texel for the same `(s, t)`.

use crate::texture::{Texture, Wrap, lat_long_from_cube_faces};
use glam::Vec2;
use rib_parser::scene::{MadeTextureKind, Scene};
use std::cell::RefCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The texture a shader names: the picture of the last `MakeTexture` (or lat-long environment)
/// that made `name`, with its wrap modes, a cube-face environment's six pictures resampled to
/// a lat-long map, or else the file `name` itself. Relative paths are tried from the working
/// directory, then from the RIB file's directory.
pub fn load_scene_texture(scene: &Scene, name: &str) -> Result<Arc<Texture>, String> {
    let resolve = |file: &str| {
        let direct = PathBuf::from(file);
        if direct.is_absolute() || direct.exists() {
            return direct;
        }
        match Path::new(scene.source.as_ref()).parent() {
            Some(dir) if dir.join(file).exists() => dir.join(file),
            _ => direct,
        }
    };
    let made = scene.render.textures.iter().rev().find(|t| t.name == name);
    match made.map(|t| &t.kind) {
        Some(MadeTextureKind::Texture { picture, swrap, twrap }) => {
            let wrap = |w: &str| Wrap::from_name(w).unwrap_or(Wrap::Periodic);
            let texture = Texture::load(&resolve(picture)).map_err(|e| format!("{picture}: {e}"))?;
            Ok(Arc::new(texture.with_wrap(wrap(swrap), wrap(twrap))))
        }
        Some(MadeTextureKind::LatLong { picture }) => {
            let texture = Texture::load(&resolve(picture)).map_err(|e| format!("{picture}: {e}"))?;
            Ok(Arc::new(texture.with_wrap(Wrap::Periodic, Wrap::Clamp)))
        }
        Some(MadeTextureKind::CubeFaces { faces, fov }) => {
            let mut loaded = Vec::with_capacity(6);
            for face in faces {
                loaded.push(Texture::load(&resolve(face)).map_err(|e| format!("{face}: {e}"))?);
            }
            lat_long_from_cube_faces(std::array::from_fn(|i| &loaded[i]), *fov)
                .map(Arc::new)
                .ok_or_else(|| format!("cube-face field of view {fov} is not in (0, 180) degrees"))
        }
        None => Texture::load(&resolve(name)).map(Arc::new),
    }
}

/// `float texture(name, s, t)` of the standard displacement shader `bumpy`: the first channel
/// of the texture the name resolves to ([`load_scene_texture`]), bilinear on the finest level,
/// each file read once.
pub struct DisplacementTextures<'a> {
    scene: &'a Scene,
    cache: RefCell<HashMap<String, Option<Arc<Texture>>>>,
}

impl std::fmt::Debug for DisplacementTextures<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DisplacementTextures")
            .field("read", &self.cache.borrow().len())
            .finish_non_exhaustive()
    }
}

impl<'a> DisplacementTextures<'a> {
    pub fn new(scene: &'a Scene) -> DisplacementTextures<'a> {
        DisplacementTextures { scene, cache: RefCell::new(HashMap::new()) }
    }

    /// The value at `st`, `None` when the texture cannot be read.
    pub fn value(&self, name: &str, st: Vec2) -> Option<f64> {
        let mut cache = self.cache.borrow_mut();
        let texture = cache
            .entry(name.to_string())
            .or_insert_with(|| load_scene_texture(self.scene, name).ok())
            .clone()?;
        Some(f64::from(texture.lookup(st).x))
    }
}
