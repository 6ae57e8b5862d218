//! Image texture maps for `paintedplastic`: any format the `image` crate reads (PNG, JPEG,
//! TIFF, OpenEXR), looked up bilinearly with periodic wrapping. Like RenderMan, `(s, t) = (0, 0)`
//! is the top-left corner of the image and values are used as stored (no gamma decoding).

use glam::{Vec2, Vec3};
use std::path::Path;

/// An RGB texture in linear memory, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    width: u32,
    height: u32,
    texels: Vec<Vec3>,
}

/// Textures larger than this many texels are refused rather than allocated.
pub const MAX_TEXELS: u64 = 1 << 28;

impl Texture {
    pub fn from_rgb(width: u32, height: u32, texels: Vec<Vec3>) -> Option<Texture> {
        (width > 0 && height > 0 && texels.len() == width as usize * height as usize).then_some(Texture {
            width,
            height,
            texels,
        })
    }

    /// Reads an image file; the error is a human-readable reason.
    pub fn load(path: &Path) -> Result<Texture, String> {
        let reader = image::ImageReader::open(path)
            .map_err(|e| e.to_string())?
            .with_guessed_format()
            .map_err(|e| e.to_string())?;
        let (w, h) = reader.into_dimensions().map_err(|e| e.to_string())?;
        if u64::from(w) * u64::from(h) > MAX_TEXELS {
            return Err(format!("{w}x{h} texels is more than the limit of {MAX_TEXELS}"));
        }
        let img = image::ImageReader::open(path)
            .map_err(|e| e.to_string())?
            .with_guessed_format()
            .map_err(|e| e.to_string())?
            .decode()
            .map_err(|e| e.to_string())?;
        let rgb = img.to_rgb32f();
        let texels = rgb.pixels().map(|p| Vec3::new(p[0], p[1], p[2])).collect();
        Texture::from_rgb(rgb.width(), rgb.height(), texels).ok_or_else(|| "empty image".to_string())
    }

    fn texel(&self, x: i64, y: i64) -> Vec3 {
        let x = x.rem_euclid(i64::from(self.width)) as usize;
        let y = y.rem_euclid(i64::from(self.height)) as usize;
        self.texels[y * self.width as usize + x]
    }

    /// Bilinear lookup at `(s, t)`, wrapping periodically.
    pub fn lookup(&self, st: Vec2) -> Vec3 {
        if !st.is_finite() {
            return self.texels[0];
        }
        let x = st.x * self.width as f32 - 0.5;
        let y = st.y * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let a = self.texel(x0, y0).lerp(self.texel(x0 + 1, y0), fx);
        let b = self.texel(x0, y0 + 1).lerp(self.texel(x0 + 1, y0 + 1), fx);
        a.lerp(b, fy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bilinear_and_wrap() {
        let t = Texture::from_rgb(2, 1, vec![Vec3::ZERO, Vec3::ONE]).unwrap();
        assert_eq!(t.lookup(Vec2::new(0.25, 0.5)), Vec3::ZERO);
        assert_eq!(t.lookup(Vec2::new(0.75, 0.5)), Vec3::ONE);
        assert!((t.lookup(Vec2::new(0.5, 0.5)).x - 0.5).abs() < 1e-6);
        assert_eq!(t.lookup(Vec2::new(1.25, 0.5)), Vec3::ZERO);
        assert!(Texture::load(Path::new("/nonexistent.png")).is_err());
    }
}
