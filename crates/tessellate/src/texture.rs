//! Image texture maps for `paintedplastic`: any format the `image` crate reads (PNG, JPEG,
//! TIFF, OpenEXR). Like RenderMan, `(s, t) = (0, 0)` is the top-left corner of the image and
//! values are used as stored (no gamma decoding). Lookups are filtered: a mip-map pyramid
//! (2x2 box reductions) is built at load, and [`Texture::lookup_filtered`] blends the two
//! levels around the footprint's size (trilinear filtering, as pbrt and RenderMan's
//! `texture()` do by default). Wrap modes are `MakeTexture`'s: periodic (the default for a
//! picture read directly), clamp, or black.

use glam::{DVec3, Vec2, Vec3};
use std::path::Path;

/// How coordinates outside `[0, 1)` are read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    Periodic,
    Clamp,
    Black,
}

impl Wrap {
    /// A `MakeTexture` wrap mode (`"periodic"`, `"clamp"`, `"black"`); `None` for others.
    pub fn from_name(name: &str) -> Option<Wrap> {
        match name {
            "periodic" => Some(Wrap::Periodic),
            "clamp" => Some(Wrap::Clamp),
            "black" => Some(Wrap::Black),
            _ => None,
        }
    }

    /// The texel index for `i` in a row of `n`, `None` for black.
    fn index(self, i: i64, n: u32) -> Option<usize> {
        let n = i64::from(n);
        match self {
            Wrap::Periodic => Some(i.rem_euclid(n) as usize),
            Wrap::Clamp => Some(i.clamp(0, n - 1) as usize),
            Wrap::Black => (0..n).contains(&i).then_some(i as usize),
        }
    }
}

/// One level of the pyramid, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
struct Level {
    width: u32,
    height: u32,
    texels: Vec<Vec3>,
}

impl Level {
    fn texel(&self, x: i64, y: i64, wrap: (Wrap, Wrap)) -> Vec3 {
        match (wrap.0.index(x, self.width), wrap.1.index(y, self.height)) {
            (Some(x), Some(y)) => self.texels[y * self.width as usize + x],
            _ => Vec3::ZERO,
        }
    }

    fn bilinear(&self, st: Vec2, wrap: (Wrap, Wrap)) -> Vec3 {
        let x = st.x * self.width as f32 - 0.5;
        let y = st.y * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let a = self.texel(x0, y0, wrap).lerp(self.texel(x0 + 1, y0, wrap), fx);
        let b = self.texel(x0, y0 + 1, wrap).lerp(self.texel(x0 + 1, y0 + 1, wrap), fx);
        a.lerp(b, fy)
    }

    /// The next coarser level: each texel the mean of up to 2x2 texels.
    fn reduced(&self) -> Level {
        let (w, h) = ((self.width / 2).max(1), (self.height / 2).max(1));
        let mut texels = Vec::with_capacity(w as usize * h as usize);
        for y in 0..h {
            for x in 0..w {
                let mut sum = Vec3::ZERO;
                let mut n = 0.0;
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let (sx, sy) = (2 * x + dx, 2 * y + dy);
                    if sx < self.width && sy < self.height {
                        sum += self.texels[(sy * self.width + sx) as usize];
                        n += 1.0;
                    }
                }
                texels.push(sum / n);
            }
        }
        Level { width: w, height: h, texels }
    }
}

/// An RGB texture with its mip-map pyramid.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    levels: Vec<Level>,
    wrap: (Wrap, Wrap),
}

/// Textures larger than this many texels are refused rather than allocated.
pub const MAX_TEXELS: u64 = 1 << 28;

impl Texture {
    pub fn from_rgb(width: u32, height: u32, texels: Vec<Vec3>) -> Option<Texture> {
        if !(width > 0 && height > 0 && texels.len() == width as usize * height as usize) {
            return None;
        }
        let mut levels = vec![Level { width, height, texels }];
        while let Some(last) = levels.last()
            && (last.width > 1 || last.height > 1)
        {
            let next = last.reduced();
            levels.push(next);
        }
        Some(Texture { levels, wrap: (Wrap::Periodic, Wrap::Periodic) })
    }

    /// The same texture read with other wrap modes (s, t).
    pub fn with_wrap(self, swrap: Wrap, twrap: Wrap) -> Texture {
        Texture { wrap: (swrap, twrap), ..self }
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

    /// Bilinear lookup of the finest level at `(s, t)`.
    pub fn lookup(&self, st: Vec2) -> Vec3 {
        self.lookup_filtered(st, 0.0)
    }

    /// Bilinear lookup of the finest level read as a lat-long environment map: periodic in
    /// `s` (longitude), clamped in `t` (the poles), whatever the texture's own wrap modes.
    pub fn lookup_lat_long(&self, st: Vec2) -> Vec3 {
        let finest = &self.levels[0];
        if !st.is_finite() {
            return finest.texels[0];
        }
        finest.bilinear(st, (Wrap::Periodic, Wrap::Clamp))
    }

    /// The texture seen through a box filter `blur` wide in `s` and in `t`, in texture
    /// coordinates as RenderMan's `"blur"` (`blur = 0.1`: a tenth of the texture's width and of
    /// its height), beyond its edges as its wrap modes say, built from the finest level; `None`
    /// unless `blur` is finite and positive.
    pub fn blurred(&self, blur: f32) -> Option<Texture> {
        self.blurred_with(blur, self.wrap)
    }

    /// [`Texture::blurred`] for the texture read as a lat-long map: periodic in `s`, clamped in
    /// `t` (the poles), whatever its own wrap modes.
    pub fn blurred_lat_long(&self, blur: f32) -> Option<Texture> {
        self.blurred_with(blur, (Wrap::Periodic, Wrap::Clamp))
    }

    fn blurred_with(&self, blur: f32, (s_edge, t_edge): (Wrap, Wrap)) -> Option<Texture> {
        if !(blur.is_finite() && blur > 0.0) {
            return None;
        }
        let finest = &self.levels[0];
        let (w, h) = (finest.width as usize, finest.height as usize);
        let mut texels = finest.texels.clone();
        let across = f64::from(blur) * w as f64;
        for row in texels.chunks_mut(w) {
            let filtered = box_filter(row, across, s_edge);
            row.copy_from_slice(&filtered);
        }
        let down = f64::from(blur) * h as f64;
        let mut column = vec![Vec3::ZERO; h];
        for x in 0..w {
            for (y, c) in column.iter_mut().enumerate() {
                *c = texels[y * w + x];
            }
            for (y, c) in box_filter(&column, down, t_edge).into_iter().enumerate() {
                texels[y * w + x] = c;
            }
        }
        Some(Texture::from_rgb(finest.width, finest.height, texels)?.with_wrap(self.wrap.0, self.wrap.1))
    }

    /// The finest level of the pyramid with at most `max_texels` texels (the coarsest, 1x1,
    /// when none is that small): `(width, height, texels)`, row 0 at the top.
    pub fn level_within(&self, max_texels: usize) -> (u32, u32, &[Vec3]) {
        let level = self
            .levels
            .iter()
            .find(|l| l.texels.len() <= max_texels)
            .unwrap_or_else(|| &self.levels[self.levels.len() - 1]);
        (level.width, level.height, &level.texels)
    }

    /// Lookup filtered over a footprint `width` wide in `(s, t)` units: bilinear in the two
    /// pyramid levels whose texels are about that size, blended by the level in between.
    pub fn lookup_filtered(&self, st: Vec2, width: f32) -> Vec3 {
        let finest = &self.levels[0];
        if !st.is_finite() {
            return finest.texels[0];
        }
        let texels_across = width * finest.width.max(finest.height) as f32;
        let level = if texels_across > 1.0 && texels_across.is_finite() { texels_across.log2() } else { 0.0 };
        let coarsest = (self.levels.len() - 1) as f32;
        let level = level.min(coarsest);
        let lo = level.floor() as usize;
        let f = level - lo as f32;
        let a = self.levels[lo].bilinear(st, self.wrap);
        if f == 0.0 {
            return a;
        }
        a.lerp(self.levels[lo + 1].bilinear(st, self.wrap), f)
    }
}

/// Each texel of `line` (texel `k` covering `[k, k + 1]`, constant over it) averaged over a box
/// `width` texels wide around its centre, beyond the ends as `edge` says (periodic, the end
/// texels repeated, or black). Exact for any width, through the running integral of the line
/// (in `f64`).
fn box_filter(line: &[Vec3], width: f64, edge: Wrap) -> Vec<Vec3> {
    let n = line.len();
    if n == 0 || !(width > 0.0) {
        return line.to_vec();
    }
    let mut running = Vec::with_capacity(n + 1);
    running.push(DVec3::ZERO);
    for c in line {
        let last = running[running.len() - 1];
        running.push(last + c.as_dvec3());
    }
    let total = running[n];
    // The integral of the line from 0 to x.
    let integral = |x: f64| -> DVec3 {
        let (turns, x) = if edge == Wrap::Periodic {
            let turns = (x / n as f64).floor();
            (turns, x - turns * n as f64)
        } else {
            (0.0, x)
        };
        // Beyond the ends, black adds nothing and clamping repeats the end texel.
        let clamp = f64::from(u8::from(edge == Wrap::Clamp));
        let inside = if x <= 0.0 {
            line[0].as_dvec3() * (x * clamp)
        } else if x >= n as f64 {
            total + line[n - 1].as_dvec3() * ((x - n as f64) * clamp)
        } else {
            let k = (x.floor() as usize).min(n - 1);
            running[k] + line[k].as_dvec3() * (x - k as f64)
        };
        total * turns + inside
    };
    (0..n)
        .map(|k| {
            let centre = k as f64 + 0.5;
            ((integral(centre + 0.5 * width) - integral(centre - 0.5 * width)) / width).as_vec3()
        })
        .collect()
}

/// A lat-long map resampled from `MakeCubeFaceEnvironment`'s six faces (in the order
/// `px nx py ny pz nz`, each seen from the centre with a field of view of `fov_degrees`), so
/// that cube-face environments are read by the lat-long code (`shinymetal`, environment
/// lights). Face coordinates follow RenderMan's (and OpenGL's) cube-map convention: along +x,
/// `(s, t) = (-z, -y) / |x|`, along -x `(z, -y)`, along +y `(x, z)`, along -y `(x, -z)`, along
/// +z `(x, -y)`, along -z `(-x, -y)`, scaled by `1 / tan(fov / 2)` from `[-1, 1]` to `[0, 1]`
/// (`t = 0` at the top row). The map is `4n x 2n` for faces of `n` texels at most (at most
/// 2048, and within [`MAX_TEXELS`]), read bilinearly from each face.
pub fn lat_long_from_cube_faces(faces: [&Texture; 6], fov_degrees: f32) -> Option<Texture> {
    let half = (0.5 * fov_degrees.to_radians()).tan();
    if !(half.is_finite() && half > 0.0) {
        return None;
    }
    let n = faces.iter().map(|f| f.levels[0].width.max(f.levels[0].height)).max()?.clamp(1, 2048);
    let n = n.min(((MAX_TEXELS / 8) as f64).sqrt() as u32);
    let (width, height) = (4 * n, 2 * n);
    let mut texels = Vec::with_capacity(width as usize * height as usize);
    for y in 0..height {
        let theta = (y as f32 + 0.5) / height as f32 * std::f32::consts::PI;
        for x in 0..width {
            let phi = (x as f32 + 0.5) / width as f32 * 2.0 * std::f32::consts::PI;
            let d = Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
            let a = d.abs();
            let (face, sc, tc, ma) = if a.x >= a.y && a.x >= a.z {
                if d.x > 0.0 { (0, -d.z, -d.y, a.x) } else { (1, d.z, -d.y, a.x) }
            } else if a.y >= a.z {
                if d.y > 0.0 { (2, d.x, d.z, a.y) } else { (3, d.x, -d.z, a.y) }
            } else if d.z > 0.0 {
                (4, d.x, -d.y, a.z)
            } else {
                (5, -d.x, -d.y, a.z)
            };
            let st = Vec2::new(sc, tc) / (ma * half) * 0.5 + Vec2::splat(0.5);
            texels.push(faces[face].levels[0].bilinear(st, (Wrap::Clamp, Wrap::Clamp)));
        }
    }
    Texture::from_rgb(width, height, texels).map(|t| t.with_wrap(Wrap::Periodic, Wrap::Clamp))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_filters_average_exactly_over_their_width() {
        let line: Vec<Vec3> = [0.0, 0.0, 4.0, 0.0, 0.0, 0.0].map(Vec3::splat).to_vec();
        // Three texels wide: the bright texel spread over its neighbours, the sum kept.
        let periodic = box_filter(&line, 3.0, Wrap::Periodic);
        let values: Vec<f32> = periodic.iter().map(|c| c.x).collect();
        let third = 4.0 / 3.0;
        for (got, want) in values.iter().zip([0.0, third, third, third, 0.0, 0.0]) {
            assert!((got - want).abs() < 1e-6, "{values:?}");
        }
        // Two texels wide: half of each neighbour, and the texel itself.
        let two = box_filter(&line, 2.0, Wrap::Periodic);
        assert!(
            (two[1].x - 1.0).abs() < 1e-6 && (two[2].x - 2.0).abs() < 1e-6 && (two[3].x - 1.0).abs() < 1e-6
        );
        // Wider than the line: every texel is the mean when periodic.
        for c in box_filter(&line, 6.0, Wrap::Periodic) {
            assert!((c.x - 4.0 / 6.0).abs() < 1e-6, "{c}");
        }
        // Clamped: beyond the ends the end texels repeat, so a ramp's ends keep their values.
        let ramp: Vec<Vec3> = (0..5).map(|k| Vec3::splat(k as f32)).collect();
        let clamped = box_filter(&ramp, 3.0, Wrap::Clamp);
        assert!((clamped[0].x - 1.0 / 3.0).abs() < 1e-6 && (clamped[2].x - 2.0).abs() < 1e-6);
        assert!((clamped[4].x - 11.0 / 3.0).abs() < 1e-6, "{clamped:?}");
        // Black: nothing beyond the ends.
        let black = box_filter(&ramp, 3.0, Wrap::Black);
        assert!((black[0].x - 1.0 / 3.0).abs() < 1e-6 && (black[4].x - 7.0 / 3.0).abs() < 1e-6, "{black:?}");
    }

    #[test]
    fn a_blurred_lat_long_map_is_its_rows_mean_when_blurred_by_the_whole_width() {
        let texels = (0..8 * 4).map(|i| Vec3::splat(if i % 8 == 3 { 8.0 } else { 0.0 })).collect();
        let map = Texture::from_rgb(8, 4, texels).unwrap();
        let blurred = map.blurred_lat_long(1.0).unwrap();
        for c in &blurred.levels[0].texels {
            assert!((c.x - 1.0).abs() < 1e-6, "{c}");
        }
        assert!(map.blurred_lat_long(0.0).is_none() && map.blurred_lat_long(f32::NAN).is_none());
        assert!(map.blurred_lat_long(-0.1).is_none());
    }

    #[test]
    fn bilinear_and_wrap() {
        let t = Texture::from_rgb(2, 1, vec![Vec3::ZERO, Vec3::ONE]).unwrap();
        assert_eq!(t.lookup(Vec2::new(0.25, 0.5)), Vec3::ZERO);
        assert_eq!(t.lookup(Vec2::new(0.75, 0.5)), Vec3::ONE);
        assert!((t.lookup(Vec2::new(0.5, 0.5)).x - 0.5).abs() < 1e-6);
        assert_eq!(t.lookup(Vec2::new(1.25, 0.5)), Vec3::ZERO);
        assert!(Texture::load(Path::new("/nonexistent.png")).is_err());
    }

    /// Six faces of distinct colours become a lat-long map whose directions along each axis
    /// read that axis's face, and a face's top row is where RenderMan puts it.
    #[test]
    fn cube_faces_resample_to_lat_long() {
        let colours =
            [Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE, Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 1.0)];
        let faces: Vec<Texture> =
            colours.iter().map(|&c| Texture::from_rgb(32, 32, vec![c; 1024]).unwrap()).collect();
        let map = lat_long_from_cube_faces(std::array::from_fn(|i| &faces[i]), 90.0).unwrap();
        let lat_long = |d: Vec3| {
            let phi = d.y.atan2(d.x).rem_euclid(2.0 * std::f32::consts::PI);
            map.lookup_lat_long(Vec2::new(
                phi / (2.0 * std::f32::consts::PI),
                d.z.acos() / std::f32::consts::PI,
            ))
        };
        for (axis, colour) in [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z].iter().zip(colours) {
            let d = (*axis + Vec3::new(0.1, 0.13, 0.12)).normalize();
            assert_eq!(lat_long(d), colour, "{axis}");
        }
        // On the +x face, +y (up in RenderMan's camera) is the top row.
        let mut texels = vec![Vec3::ZERO; 1024];
        texels[..512].fill(Vec3::ONE);
        let top = Texture::from_rgb(32, 32, texels).unwrap();
        let mut with_top: Vec<&Texture> = faces.iter().collect();
        with_top[0] = &top;
        let map = lat_long_from_cube_faces(std::array::from_fn(|i| with_top[i]), 90.0).unwrap();
        let phi_theta = |d: Vec3| {
            Vec2::new(
                d.y.atan2(d.x).rem_euclid(2.0 * std::f32::consts::PI) / (2.0 * std::f32::consts::PI),
                d.z.acos() / std::f32::consts::PI,
            )
        };
        assert_eq!(map.lookup_lat_long(phi_theta(Vec3::new(1.0, 0.5, 0.1).normalize())), Vec3::ONE);
        assert_eq!(map.lookup_lat_long(phi_theta(Vec3::new(1.0, -0.5, 0.1).normalize())), Vec3::ZERO);
        assert!(lat_long_from_cube_faces(std::array::from_fn(|i| &faces[i]), 0.0).is_none());
    }

    /// A fine checkerboard seen through a footprint of many texels is its mean, and wrap modes
    /// read outside `[0, 1)` as `MakeTexture` says.
    #[test]
    fn filtered_lookups_average_and_wrap_modes() {
        let n = 64u32;
        let texels = (0..n * n)
            .map(|i| if (i % n + i / n).is_multiple_of(2) { Vec3::ONE } else { Vec3::ZERO })
            .collect();
        let t = Texture::from_rgb(n, n, texels).unwrap();
        for st in [Vec2::new(0.31, 0.77), Vec2::new(0.5, 0.5), Vec2::new(0.013, 0.9)] {
            let fine = t.lookup(st + Vec2::splat(0.5 / n as f32));
            assert!(fine == Vec3::ONE || fine == Vec3::ZERO || (fine.x - 0.5).abs() < 0.5);
            let wide = t.lookup_filtered(st, 16.0 / n as f32);
            assert!((wide.x - 0.5).abs() < 1e-6, "{wide}");
        }
        let ramp = Texture::from_rgb(2, 1, vec![Vec3::ZERO, Vec3::ONE]).unwrap();
        let clamp = ramp.clone().with_wrap(Wrap::Clamp, Wrap::Clamp);
        assert_eq!(clamp.lookup(Vec2::new(1.75, 0.5)), Vec3::ONE);
        let black = ramp.with_wrap(Wrap::Black, Wrap::Black);
        assert_eq!(black.lookup(Vec2::new(1.75, 0.5)), Vec3::ZERO);
        assert_eq!(Wrap::from_name("clamp"), Some(Wrap::Clamp));
        assert_eq!(Wrap::from_name("mirror"), None);
    }
}
