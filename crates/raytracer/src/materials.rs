//! RenderMan's standard surface shaders (and LRT's `mirror` and `glass`) as BSDFs.
//!
//! | shader | parameters (defaults) | model |
//! |---|---|---|
//! | `matte` | `Ka` 1, `Kd` 1 | Lambertian, albedo `Kd * Cs` (CONTRACTS.md §3) |
//! | `plastic` | `Ka` 1, `Kd` .5, `Ks` .5, `roughness` .1, `specularcolor` 1 | Lambertian + Blinn microfacet, exponent `1 / roughness` |
//! | `paintedplastic` | as plastic, `texturename` | plastic with `Cs` multiplied by the texture at `(s, t)` |
//! | `metal` | `Ka` 1, `Ks` 1, `roughness` .1 | Blinn microfacet tinted by `Cs` |
//! | `shinymetal` | `Ka` 1, `Ks` 1, `Kr` 1, `roughness` .1, `texturename` | metal + perfect mirror `Kr * Cs`: the lat-long environment map `texturename` in the reflected direction (world space, +z up) when given, else ray traced |
//! | `mirror` | `Kr` 1 | perfect mirror, reflectance `Kr * Cs` |
//! | `glass` | `eta` 1.5 (or `index`), `Kr` 1, `Kt` 1 | smooth dielectric, exact Fresnel, both parts tinted by `Cs` |
//! | `constant` | | emits `Cs` toward every ray, reflects nothing |
//! | `defaultsurface` | `Ka` .2, `Kd` .8 | RenderMan's headlight: emits `Cs (Ka + Kd cos^2)`, reflects nothing |
//!
//! `Ka * Cs` times the sum of the `ambientlight`s illuminating the surface is added where the
//! shader has `Ka`. When the lobes of a shader could reflect more than all incident light (e.g.
//! `Kd + Ks > 1`), they are scaled down together so that a path tracer stays bounded. Unknown
//! shaders become `matte` with their `Kd`/`Ka` if given (the renderer warns once per name).

use crate::bsdf::{Bsdf, Lobe};
use crate::math::Frame;
use crate::texture::Texture;
use glam::{Vec2, Vec3};
use rib_parser::scene::{Attributes, ParamList};
use std::sync::Arc;

/// The surface model of a shader.
#[derive(Clone, Debug)]
pub enum Surface {
    Constant,
    DefaultSurface {
        ka: f32,
        kd: f32,
    },
    Matte {
        kd: f32,
    },
    Plastic {
        kd: f32,
        ks: f32,
        roughness: f32,
        specular_color: Vec3,
        texture: Option<Arc<Texture>>,
    },
    Metal {
        ks: f32,
        roughness: f32,
    },
    /// `environment`: the lat-long map reflected instead of the scene, when `texturename` names one.
    ShinyMetal {
        ks: f32,
        kr: f32,
        roughness: f32,
        environment: Option<Arc<Texture>>,
    },
    Mirror {
        kr: f32,
    },
    Glass {
        kr: f32,
        kt: f32,
        eta: f32,
    },
}

/// A shader with the attribute state it is used with.
#[derive(Clone, Debug)]
pub struct Material {
    pub surface: Surface,
    /// `Color` (Cs).
    pub color: Vec3,
    /// `Opacity` (Os), clamped to `[0, 1]`.
    pub opacity: Vec3,
    /// `Ka` of shaders that have it (0 otherwise).
    pub ka: f32,
    /// `Matte 1`: a holdout that renders black with zero alpha.
    pub holdout: bool,
}

/// What happened while interpreting a shader, for the caller to turn into a warning.
#[derive(Clone, Debug, PartialEq)]
pub enum MaterialNote {
    UnknownShader(String),
    TextureUnreadable {
        path: String,
        reason: String,
    },
    /// A `"blur"` that is not a finite width >= 0: the texture is read unblurred.
    BadBlur(f32),
}

fn param(params: &ParamList, name: &str, default: f32) -> f32 {
    params.float(name).filter(|v| v.is_finite()).unwrap_or(default)
}

fn clamp_color(c: Vec3) -> Vec3 {
    let c = Vec3::new(
        if c.x.is_finite() { c.x } else { 0.0 },
        if c.y.is_finite() { c.y } else { 0.0 },
        if c.z.is_finite() { c.z } else { 0.0 },
    );
    c.max(Vec3::ZERO)
}

impl Material {
    /// Interprets an attribute state's surface shader. `load_texture` resolves `texturename`.
    pub fn from_attributes(
        attributes: &Attributes,
        load_texture: &mut dyn FnMut(&str) -> Result<Arc<Texture>, String>,
        notes: &mut Vec<MaterialNote>,
    ) -> Material {
        let color = clamp_color(attributes.color);
        let opacity = clamp_color(attributes.opacity).min(Vec3::ONE);
        let (name, params) = match &attributes.surface {
            Some(call) => (call.name.as_str(), call.params.clone()),
            None => ("defaultsurface", ParamList::default()),
        };
        let p = |n: &str, d: f32| param(&params, n, d);
        let roughness = |d: f32| p("roughness", d).max(1e-4);
        let specular_color = params.vec3("specularcolor").map(clamp_color).unwrap_or(Vec3::ONE);
        // RenderMan's "blur" of the texture lookups: the map seen through a box filter that
        // wide (`lat_long`: as the environment map `shinymetal` reads, periodic in s).
        let blur = params.float("blur").unwrap_or(0.0);
        let mut texture = |lat_long: bool| match params.string("texturename") {
            Some(path) if !path.is_empty() => match load_texture(path) {
                Ok(t) if blur == 0.0 => Some(t),
                Ok(t) => {
                    let blurred = if lat_long { t.blurred_lat_long(blur) } else { t.blurred(blur) };
                    if blurred.is_none() {
                        notes.push(MaterialNote::BadBlur(blur));
                    }
                    Some(blurred.map_or(t, Arc::new))
                }
                Err(reason) => {
                    notes.push(MaterialNote::TextureUnreadable { path: path.to_string(), reason });
                    None
                }
            },
            _ => None,
        };
        let (surface, ka) = match name {
            "constant" => (Surface::Constant, 0.0),
            "defaultsurface" => (Surface::DefaultSurface { ka: p("Ka", 0.2), kd: p("Kd", 0.8) }, 0.0),
            "matte" => (Surface::Matte { kd: p("Kd", 1.0) }, p("Ka", 1.0)),
            "plastic" => (
                Surface::Plastic {
                    kd: p("Kd", 0.5),
                    ks: p("Ks", 0.5),
                    roughness: roughness(0.1),
                    specular_color,
                    texture: None,
                },
                p("Ka", 1.0),
            ),
            "paintedplastic" => (
                Surface::Plastic {
                    kd: p("Kd", 0.5),
                    ks: p("Ks", 0.5),
                    roughness: roughness(0.1),
                    specular_color,
                    texture: texture(false),
                },
                p("Ka", 1.0),
            ),
            "metal" => (Surface::Metal { ks: p("Ks", 1.0), roughness: roughness(0.1) }, p("Ka", 1.0)),
            "shinymetal" => (
                Surface::ShinyMetal {
                    ks: p("Ks", 1.0),
                    kr: p("Kr", 1.0),
                    roughness: roughness(0.1),
                    environment: texture(true),
                },
                p("Ka", 1.0),
            ),
            "mirror" => (Surface::Mirror { kr: p("Kr", 1.0) }, 0.0),
            "glass" => {
                let eta = params
                    .float("eta")
                    .or_else(|| params.float("index"))
                    .filter(|e| e.is_finite() && *e > 0.0);
                (Surface::Glass { kr: p("Kr", 1.0), kt: p("Kt", 1.0), eta: eta.unwrap_or(1.5) }, 0.0)
            }
            other => {
                notes.push(MaterialNote::UnknownShader(other.to_string()));
                (Surface::Matte { kd: p("Kd", 1.0) }, p("Ka", 1.0))
            }
        };
        Material { surface, color, opacity, ka: ka.max(0.0), holdout: attributes.matte }
    }

    /// A plain Lambertian material (for tests and fallbacks).
    pub fn matte(color: Vec3) -> Material {
        Material { surface: Surface::Matte { kd: 1.0 }, color, opacity: Vec3::ONE, ka: 0.0, holdout: false }
    }

    /// True for materials that stop shadow rays whatever their opacity (mirror and glass: light
    /// reaches through them only along specular paths).
    pub fn blocks_shadows(&self) -> bool {
        matches!(self.surface, Surface::Mirror { .. } | Surface::Glass { .. })
    }

    /// True when some lobe is a smooth dielectric (the outward normal matters).
    pub fn is_dielectric(&self) -> bool {
        matches!(self.surface, Surface::Glass { .. })
    }

    /// True when the material has a specular (delta) lobe.
    pub fn has_specular(&self) -> bool {
        match self.surface {
            Surface::Mirror { kr } => kr > 0.0,
            Surface::Glass { .. } => true,
            Surface::ShinyMetal { kr, environment: None, .. } => kr > 0.0,
            _ => false,
        }
    }

    /// True when [`Material::self_emission`], [`Material::ambient_reflectance`] or
    /// [`Material::environment_reflection`] can be nonzero (most materials have none of them,
    /// and a path vertex skips them then).
    pub fn has_surface_terms(&self) -> bool {
        self.ka > 0.0
            || matches!(
                self.surface,
                Surface::Constant
                    | Surface::DefaultSurface { .. }
                    | Surface::ShinyMetal { environment: Some(_), .. }
            )
    }

    /// True when the material reads a texture at the surface's texture coordinates (the
    /// world computes `st` and its footprint only then): [`Material::color_at`] is the one
    /// reader.
    pub fn reads_texture_coordinates(&self) -> bool {
        matches!(self.surface, Surface::Plastic { texture: Some(_), .. })
    }

    /// The surface colour at texture coordinates `st`, the texture filtered over `st_width`
    /// (the footprint of a pixel in texture space; 0 reads the finest level).
    pub fn color_at(&self, st: Vec2, st_width: f32) -> Vec3 {
        match &self.surface {
            Surface::Plastic { texture: Some(t), .. } => self.color * t.lookup_filtered(st, st_width),
            _ => self.color,
        }
    }

    /// Radiance the shader itself emits toward `wo` (constant and defaultsurface).
    pub fn self_emission(&self, ns: Vec3, wo: Vec3, st: Vec2, st_width: f32) -> Vec3 {
        match self.surface {
            Surface::Constant => self.color_at(st, st_width),
            Surface::DefaultSurface { ka, kd } => {
                let c = ns.dot(wo);
                self.color_at(st, st_width) * (ka + kd * c * c)
            }
            _ => Vec3::ZERO,
        }
    }

    /// `shinymetal`'s `Kr * Cs * environment(texturename, R)`: the lat-long map in the mirror
    /// direction of `wo` about `ns` (world axes, +z up: `s = atan2(y, x) / 2 pi`,
    /// `t = acos(z) / pi`, as PRMan and pbrt index lat-long maps). Zero without a map.
    pub fn environment_reflection(&self, ns: Vec3, wo: Vec3) -> Vec3 {
        let Surface::ShinyMetal { ks, kr, environment: Some(map), .. } = &self.surface else {
            return Vec3::ZERO;
        };
        let r = (2.0 * wo.dot(ns) * ns - wo).normalize_or_zero();
        if r == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let phi = r.y.atan2(r.x).rem_euclid(2.0 * std::f32::consts::PI);
        let st =
            Vec2::new(phi / (2.0 * std::f32::consts::PI), r.z.clamp(-1.0, 1.0).acos() / std::f32::consts::PI);
        // The same energy split as the ray-traced mirror lobe.
        let (_, m) = conserve(self.color * ks.max(0.0), self.color * kr.max(0.0));
        m * map.lookup(st)
    }

    /// `Ka * Cs`: what multiplies the ambient light.
    pub fn ambient_reflectance(&self, st: Vec2, st_width: f32) -> Vec3 {
        if self.ka > 0.0 { self.color_at(st, st_width) * self.ka } else { Vec3::ZERO }
    }

    /// The BSDF at a surface point. `ng` and `ns` are the geometric and shading normals (same
    /// hemisphere), `n_outward` the solid's outward normal (for glass), `dpdu` a tangent hint.
    #[allow(clippy::too_many_arguments)]
    pub fn bsdf(
        &self,
        wo: Vec3,
        ng: Vec3,
        ns: Vec3,
        n_outward: Vec3,
        dpdu: Vec3,
        st: Vec2,
        st_width: f32,
    ) -> Bsdf {
        self.bsdf_inlined(wo, ng, ns, n_outward, dpdu, st, st_width)
    }

    /// [`Material::bsdf`], inlined where it is hot (the scalar path tracer's loop): out of
    /// line, the BSDF (about 200 bytes) was built in the callee's frame and copied out with
    /// `memcpy`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn bsdf_inlined(
        &self,
        wo: Vec3,
        ng: Vec3,
        ns: Vec3,
        n_outward: Vec3,
        dpdu: Vec3,
        st: Vec2,
        st_width: f32,
    ) -> Bsdf {
        let mut bsdf = Bsdf::new(Frame::from_z(Vec3::Z), Vec3::Z);
        self.write_bsdf(&mut bsdf, wo, ng, ns, n_outward, dpdu, st, st_width);
        bsdf
    }

    /// [`Material::bsdf`] written into `out`, which it replaces whole ([`Bsdf::reset`], then
    /// the lobes): where the BSDF is stored (the wavefront's records) it is built there, with
    /// no copy from a temporary.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn write_bsdf(
        &self,
        out: &mut Bsdf,
        wo: Vec3,
        ng: Vec3,
        ns: Vec3,
        n_outward: Vec3,
        dpdu: Vec3,
        st: Vec2,
        st_width: f32,
    ) {
        let cs = self.color_at(st, st_width);
        if let Surface::Glass { kr, kt, eta } = self.surface {
            // The frame's +z is the outward normal: the lobe knows which side is inside.
            let flip = ng.dot(n_outward) < 0.0;
            let (ng_o, ns_o) = if flip { (-ng, -ns) } else { (ng, ns) };
            out.reset(Frame::from_z_and_tangent(ns_o, dpdu), ng_o);
            out.add(Lobe::Dielectric { eta, r: cs * kr.max(0.0), t: cs * kt.max(0.0) });
            return;
        }
        // Opaque shaders are two-sided: face the normals toward the viewer (RenderMan's
        // faceforward).
        let (ng, ns) = if wo.dot(ng) < 0.0 { (-ng, -ns) } else { (ng, ns) };
        out.reset(Frame::from_z_and_tangent(ns, dpdu), ng);
        let bsdf = out;
        let exponent = |roughness: f32| (1.0 / roughness).clamp(1.0, 10_000.0);
        match self.surface {
            Surface::Constant | Surface::DefaultSurface { .. } | Surface::Glass { .. } => {}
            Surface::Matte { kd } => bsdf.add(Lobe::Lambert { r: (cs * kd.max(0.0)).min(Vec3::ONE) }),
            Surface::Plastic { kd, ks, roughness, specular_color, .. } => {
                let (d, s) = conserve(cs * kd.max(0.0), specular_color * ks.max(0.0));
                bsdf.add(Lobe::Lambert { r: d });
                bsdf.add(Lobe::Blinn { ks: s, exponent: exponent(roughness) });
            }
            Surface::Metal { ks, roughness } => {
                bsdf.add(Lobe::Blinn {
                    ks: (cs * ks.max(0.0)).min(Vec3::ONE),
                    exponent: exponent(roughness),
                });
            }
            Surface::ShinyMetal { ks, kr, roughness, ref environment } => {
                let (g, m) = conserve(cs * ks.max(0.0), cs * kr.max(0.0));
                bsdf.add(Lobe::Blinn { ks: g, exponent: exponent(roughness) });
                // With a map, the mirror term is the map's light (`environment_reflection`).
                if environment.is_none() {
                    bsdf.add(Lobe::SpecularReflection { r: m });
                }
            }
            Surface::Mirror { kr } => {
                bsdf.add(Lobe::SpecularReflection { r: (cs * kr.max(0.0)).min(Vec3::ONE) })
            }
        }
    }
}

/// Scales two reflectances together so that their sum is at most one in every channel.
fn conserve(a: Vec3, b: Vec3) -> (Vec3, Vec3) {
    let sum = (a + b).max_element();
    if sum > 1.0 { (a / sum, b / sum) } else { (a, b) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rib_parser::scene::{FileLoc, Param, ParamDecl, ParamType, ParamValues, ShaderCall, StorageClass};

    fn call(name: &str, floats: &[(&str, f32)]) -> ShaderCall {
        let params = floats
            .iter()
            .map(|(n, v)| Param {
                name: n.to_string(),
                decl: ParamDecl { class: StorageClass::Uniform, ty: ParamType::Float, array_len: 1 },
                values: ParamValues::Floats(vec![*v]),
                loc: FileLoc::new("t.rib", 1, 1),
            })
            .collect();
        ShaderCall { name: name.into(), params: ParamList(params), loc: FileLoc::new("t.rib", 1, 1) }
    }

    fn material(name: &str, floats: &[(&str, f32)]) -> (Material, Vec<MaterialNote>) {
        let attributes = Attributes { surface: Some(call(name, floats)), ..Attributes::default() };
        let mut notes = Vec::new();
        let m = Material::from_attributes(&attributes, &mut |_| Err("no".into()), &mut notes);
        (m, notes)
    }

    /// [`Material::write_bsdf`] over a BSDF that holds another's lobes ([`Bsdf::reset`] leaves
    /// them in place past the lobes in use) gives what [`Material::bsdf`] builds new: equal,
    /// and the same bits of `f`, `pdf`, `f_and_pdf` and `sample`, for materials of one to
    /// three lobes written after one another in every order, with normals on both sides.
    #[test]
    fn bsdf_written_over_another_matches_a_new_one() {
        use crate::bsdf::{BsdfSample, LobeFlags, TransportMode};
        let materials = [
            material("plastic", &[("Kd", 0.6), ("Ks", 0.5), ("roughness", 0.2)]).0,
            material("matte", &[("Kd", 0.5)]).0,
            material("shinymetal", &[("Ks", 0.4), ("Kr", 0.5)]).0,
            material("glass", &[]).0,
            material("metal", &[("Ks", 0.7)]).0,
            material("constant", &[]).0,
            material("mirror", &[("Kr", 0.9)]).0,
            material("matte", &[("Kd", 0.0)]).0,
        ];
        let mut rng = crate::sampling::Rng::new(21, 9);
        let mut direction = || crate::sampling::sample_uniform_sphere(rng.uniform2());
        let mut out = Bsdf::new(crate::math::Frame::from_z(Vec3::Z), Vec3::Z);
        let bits = |s: Option<BsdfSample>| {
            s.map(|s| (s.f.to_array().map(f32::to_bits), s.wi.to_array().map(f32::to_bits), s.pdf.to_bits()))
        };
        let mut compared = 0;
        for round in 0..3000 {
            let m = &materials[(round * 5 + round / 8) % materials.len()];
            let (ng, dpdu, wo, wi) = (direction(), direction(), direction(), direction());
            let ns = (ng + direction() * 0.2).normalize();
            let n_outward = if round % 3 == 0 { -ng } else { ng };
            m.write_bsdf(&mut out, wo, ng, ns, n_outward, dpdu, Vec2::new(0.3, 0.7), 0.0);
            let new = m.bsdf(wo, ng, ns, n_outward, dpdu, Vec2::new(0.3, 0.7), 0.0);
            assert!(out == new, "{out:?} against {new:?}");
            let (u_lobe, u) = (direction().x * 0.5 + 0.5, Vec2::new(direction().y * 0.5 + 0.5, 0.25));
            for mask in [LobeFlags::ALL, LobeFlags::NON_SPECULAR] {
                let f = |b: &Bsdf| {
                    let (f, pdf) = b.f_and_pdf(wo, wi, mask);
                    (
                        b.f(wo, wi, mask).to_array().map(f32::to_bits),
                        b.pdf(wo, wi, mask).to_bits(),
                        f.to_array().map(f32::to_bits),
                        pdf.to_bits(),
                        bits(b.sample(wo, u_lobe, u, TransportMode::Radiance, mask)),
                    )
                };
                assert_eq!(f(&out), f(&new), "{out:?}");
            }
            compared += usize::from(!new.is_black());
        }
        assert!(compared > 2000, "{compared} BSDFs compared");
    }

    #[test]
    fn matte_albedo_and_unknown_fallback() {
        let (m, notes) = material("matte", &[("Kd", 0.5)]);
        assert!(notes.is_empty());
        let b = m.bsdf(Vec3::Z, Vec3::Z, Vec3::Z, Vec3::Z, Vec3::X, Vec2::ZERO, 0.0);
        let f = b.f(Vec3::Z, Vec3::new(0.0, 0.6, 0.8), crate::bsdf::LobeFlags::ALL);
        assert!((f.x - 0.5 / std::f32::consts::PI).abs() < 1e-6);
        let (m, notes) = material("wood_grain", &[("Kd", 0.3)]);
        assert_eq!(notes, vec![MaterialNote::UnknownShader("wood_grain".into())]);
        assert!(matches!(m.surface, Surface::Matte { kd } if kd == 0.3));
    }

    #[test]
    fn plastic_is_energy_bounded_and_two_sided() {
        let (m, _) = material("plastic", &[("Kd", 1.0), ("Ks", 1.0)]);
        let b = m.bsdf(-Vec3::Z, Vec3::Z, Vec3::Z, Vec3::Z, Vec3::X, Vec2::ZERO, 0.0);
        // Viewed from below: the frame faces the viewer.
        assert!(b.frame.z.z < 0.0);
        let sum: f32 = b
            .lobes()
            .iter()
            .map(|l| match l {
                Lobe::Lambert { r } => r.x,
                Lobe::Blinn { ks, .. } => ks.x,
                _ => 0.0,
            })
            .sum();
        assert!(sum <= 1.0 + 1e-6);
        assert!(m.ka == 1.0);
    }

    #[test]
    fn glass_and_mirror_block_shadows() {
        assert!(material("glass", &[("eta", 1.33)]).0.blocks_shadows());
        assert!(material("mirror", &[]).0.blocks_shadows());
        assert!(!material("matte", &[]).0.blocks_shadows());
        let (g, _) = material("glass", &[("eta", 1.33)]);
        assert!(matches!(g.surface, Surface::Glass { eta, .. } if eta == 1.33));
    }
}
