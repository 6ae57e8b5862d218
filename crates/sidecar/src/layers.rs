//! The light layers of one rendered frame: what each light adds directly at the primary hit,
//! what the camera sees emitted, the indirect remainder, and the surface at the primary hit.

/// At most this many per-light layers; a scene with more lights gets this many light groups
/// (contiguous runs of lights in scene order, see [`light_layer_of`]).
pub const MAX_LIGHT_LAYERS: usize = 16;

/// How many `light.K` layers a scene with `light_count` lights gets.
pub fn light_layer_count(light_count: usize) -> usize {
    light_count.min(MAX_LIGHT_LAYERS)
}

/// The layer holding the scene's light number `light` (0-based, scene order) of `light_count`:
/// `light * layers / light_count`, so each layer holds a contiguous run of lights and with at
/// most [`MAX_LIGHT_LAYERS`] lights, light `k` is layer `k`.
pub fn light_layer_of(light: usize, light_count: usize) -> usize {
    let layers = light_layer_count(light_count);
    if layers == 0 {
        return 0;
    }
    // u128 so that no light count can overflow the product.
    ((light as u128 * layers as u128) / light_count as u128) as usize
}

/// The optional layers of a frame whose primary hits include specular reflections (mirrors,
/// glass): `reflectance` and `reflected`, both present or both absent (absent: zero).
pub const REFLECTION_LAYERS: [&str; 2] = ["reflectance", "reflected"];

/// The optional layers of a frame whose primary hits include a glossy lobe (the ray tracer's
/// Blinn microfacet lobe of `metal`, `shinymetal` and `plastic`): `glossy` and
/// `glossy_exponent`, both present or both absent (absent: zero).
pub const GLOSSY_LAYERS: [&str; 2] = ["glossy", "glossy_exponent"];

/// The optional layers of a frame whose primary hits include a specular transmission (glass):
/// the transmitted chain's weight and radiance and its exit ray (origin, direction, and the
/// distance to the surface it meets), all present or all absent (absent: zero).
pub const TRANSMISSION_LAYERS: [&str; 5] = [
    "transmittance",
    "transmitted",
    "transmission_origin",
    "transmission_direction",
    "transmission_distance",
];

/// The optional layer groups, each all or none, in the order the format lists them.
pub const OPTIONAL_LAYER_GROUPS: [&[&str]; 3] = [&REFLECTION_LAYERS, &GLOSSY_LAYERS, &TRANSMISSION_LAYERS];

/// One light of the scene as the layers refer to it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LightSource {
    /// The light's position in the scene's light list: RIB `LightSource` and `AreaLightSource`
    /// requests in the order they appear (the order `rib_parser::scene::Scene::lights` keeps).
    pub index: u32,
    /// A human-readable description, e.g. `pointlight at scene.rib:12:1` (ASCII; other
    /// characters are replaced by `?` when written).
    pub description: String,
}

impl LightSource {
    pub fn new(index: u32, description: impl Into<String>) -> LightSource {
        LightSource { index, description: description.into() }
    }
}

/// What the reader expects of a layers file: the size of the image it is paired with and,
/// when known, the fingerprint of its depth table ([`crate::depth_fingerprint`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LayerExpectation {
    pub width: u32,
    pub height: u32,
    pub depth_fingerprint: Option<u64>,
}

/// Light layers of a `width x height` frame, every buffer in row order, top row first, linear
/// radiance in the image's own units (before exposure and quantisation) for the radiance layers.
///
/// `beauty = sum(light) + emission + indirect` per pixel and channel, up to float rounding.
#[derive(Debug, Clone, PartialEq)]
pub struct LightLayers {
    pub width: u32,
    pub height: u32,
    /// [`crate::depth_fingerprint`] of the depth table rendered with these layers.
    pub depth_fingerprint: u64,
    /// Every light of the scene in scene order; `lights.len()` decides the layer count.
    pub lights: Vec<LightSource>,
    /// `light.K`: the direct light of the lights in layer `K` reflected at the primary hit.
    pub light: Vec<Vec<[f32; 3]>>,
    /// `emission`: what the camera sees emitted at the primary hit (area lights seen
    /// directly) and the background where the ray misses.
    pub emission: Vec<[f32; 3]>,
    /// `indirect`: everything else (light reflected more than once, specular paths, caustics).
    pub indirect: Vec<[f32; 3]>,
    /// `normal`: the pixel-filtered world-space shading normal at the primary hit, turned toward
    /// the camera; zero where the ray misses (not renormalised: edges average).
    pub normal: Vec<[f32; 3]>,
    /// `albedo`: the pixel-filtered diffuse albedo (`Kd * Color` for matte and plastic) at the
    /// primary hit; zero where the ray misses or the surface has no diffuse lobe.
    pub albedo: Vec<[f32; 3]>,
    /// `reflectance`: the pixel-filtered weight of the primary hit's specular reflection (a
    /// mirror's `Kr * Color`, a dielectric's Fresnel reflectance), times the hit's opacity; zero
    /// where the surface has no specular reflection. Written only when some pixel has one.
    pub reflectance: Vec<[f32; 3]>,
    /// `reflected`: the radiance that specular reflection brings toward the camera, weighted by
    /// `reflectance` (a part of `indirect`). Written with `reflectance`.
    pub reflected: Vec<[f32; 3]>,
    /// `glossy`: the pixel-filtered weight `Ks` of the primary hit's Blinn lobe (metal's
    /// `Ks * Color`, plastic's `Ks * specularcolor` after its energy conservation with `Kd`),
    /// times the hit's opacity; zero where the surface has no glossy lobe. Written only when
    /// some pixel has one.
    pub glossy: Vec<[f32; 3]>,
    /// `glossy_exponent`: the Blinn exponent of that lobe (`1 / roughness`, clamped to
    /// [1, 10000]) in all three channels, averaged over the pixel's samples with the weight
    /// of their `glossy` (so that an edge against a surface without a lobe keeps the lobe's
    /// exponent); zero where `glossy` is. Written with `glossy`.
    pub glossy_exponent: Vec<[f32; 3]>,
    /// `transmittance`: the pixel-filtered weight of the primary hit's transmitted chain (the
    /// product of the specular transmissions' weights, or total internal reflections', from
    /// the primary hit until the chain's exit ray meets a surface that does not transmit
    /// specularly), times the hit's opacity; zero where the primary hit does not transmit or
    /// the chain was cut short. Written only when some pixel has one.
    pub transmittance: Vec<[f32; 3]>,
    /// `transmitted`: the radiance the exit ray brought, weighted by `transmittance` (a part of
    /// `indirect`). Written with `transmittance`.
    pub transmitted: Vec<[f32; 3]>,
    /// `transmission_origin`: the world-space origin of the exit ray (the chain's last specular
    /// vertex), averaged over the pixel's samples with the weight of their transmittance's
    /// largest channel. Written with `transmittance`.
    pub transmission_origin: Vec<[f32; 3]>,
    /// `transmission_direction`: the exit ray's world-space unit direction, averaged as the
    /// origin is (not renormalised: its length below 1 tells that the samples' chains diverge).
    /// Written with `transmittance`.
    pub transmission_direction: Vec<[f32; 3]>,
    /// `transmission_distance`: the distance along the exit ray to the surface it meets (1e30
    /// where it leaves the scene), averaged as the origin is, in all three channels. Written
    /// with `transmittance`.
    pub transmission_distance: Vec<[f32; 3]>,
}

impl LightLayers {
    /// Zero-filled layers for `lights`.
    pub fn new(width: u32, height: u32, depth_fingerprint: u64, lights: Vec<LightSource>) -> LightLayers {
        let n = width as usize * height as usize;
        let zero = vec![[0.0f32; 3]; n];
        LightLayers {
            width,
            height,
            depth_fingerprint,
            light: vec![zero.clone(); light_layer_count(lights.len())],
            lights,
            emission: zero.clone(),
            indirect: zero.clone(),
            normal: zero.clone(),
            albedo: zero.clone(),
            reflectance: zero.clone(),
            reflected: zero.clone(),
            glossy: zero.clone(),
            glossy_exponent: zero.clone(),
            transmittance: zero.clone(),
            transmitted: zero.clone(),
            transmission_origin: zero.clone(),
            transmission_direction: zero.clone(),
            transmission_distance: zero,
        }
    }

    /// Pixels per buffer.
    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// The `light.K` buffer.
    pub fn light_mut(&mut self, layer: usize) -> &mut [[f32; 3]] {
        &mut self.light[layer]
    }

    /// The lights (positions in [`LightLayers::lights`]) that layer `layer` holds.
    pub fn lights_of_layer(&self, layer: usize) -> std::ops::Range<usize> {
        let n = self.lights.len();
        let start = (0..n).find(|&k| light_layer_of(k, n) == layer).unwrap_or(n);
        let end = (start..n).find(|&k| light_layer_of(k, n) != layer).unwrap_or(n);
        start..end
    }

    /// The sum of the radiance layers per pixel: the beauty image before quantisation.
    pub fn beauty(&self) -> Vec<[f32; 3]> {
        let mut sum = self.emission.clone();
        for layer in self.light.iter().chain(std::iter::once(&self.indirect)) {
            for (s, v) in sum.iter_mut().zip(layer) {
                for c in 0..3 {
                    s[c] += v[c];
                }
            }
        }
        sum
    }

    /// Whether some pixel sees a specular reflection at its primary hit: the file then holds
    /// the optional [`REFLECTION_LAYERS`].
    pub fn has_reflection(&self) -> bool {
        self.reflectance.iter().any(|p| p.iter().any(|&v| v != 0.0))
    }

    /// Whether some pixel's primary hit has a glossy lobe: the file then holds the optional
    /// [`GLOSSY_LAYERS`].
    pub fn has_glossy(&self) -> bool {
        self.glossy.iter().any(|p| p.iter().any(|&v| v != 0.0))
    }

    /// Whether some pixel's primary hit transmits specularly: the file then holds the optional
    /// [`TRANSMISSION_LAYERS`].
    pub fn has_transmission(&self) -> bool {
        self.transmittance.iter().any(|p| p.iter().any(|&v| v != 0.0))
    }

    /// Every buffer with its EXR layer name, in the order the format lists them (the
    /// [`REFLECTION_LAYERS`] only when [`LightLayers::has_reflection`], the [`GLOSSY_LAYERS`]
    /// only when [`LightLayers::has_glossy`], the [`TRANSMISSION_LAYERS`] only when
    /// [`LightLayers::has_transmission`]).
    pub fn named_buffers(&self) -> Vec<(String, &[[f32; 3]])> {
        let mut out: Vec<(String, &[[f32; 3]])> = Vec::new();
        for (k, layer) in self.light.iter().enumerate() {
            out.push((format!("light.{k}"), layer));
        }
        out.push(("emission".into(), &self.emission));
        out.push(("indirect".into(), &self.indirect));
        out.push(("normal".into(), &self.normal));
        out.push(("albedo".into(), &self.albedo));
        if self.has_reflection() {
            out.push((REFLECTION_LAYERS[0].into(), &self.reflectance));
            out.push((REFLECTION_LAYERS[1].into(), &self.reflected));
        }
        if self.has_glossy() {
            out.push((GLOSSY_LAYERS[0].into(), &self.glossy));
            out.push((GLOSSY_LAYERS[1].into(), &self.glossy_exponent));
        }
        if self.has_transmission() {
            let buffers = [
                &self.transmittance,
                &self.transmitted,
                &self.transmission_origin,
                &self.transmission_direction,
                &self.transmission_distance,
            ];
            for (name, buffer) in TRANSMISSION_LAYERS.iter().zip(buffers) {
                out.push(((*name).into(), buffer));
            }
        }
        out
    }

    /// Every buffer with its EXR layer name, the optional groups ([`OPTIONAL_LAYER_GROUPS`])
    /// last.
    pub(crate) fn named_buffers_mut(&mut self) -> Vec<(String, &mut Vec<[f32; 3]>)> {
        let mut out: Vec<(String, &mut Vec<[f32; 3]>)> = Vec::new();
        for (k, layer) in self.light.iter_mut().enumerate() {
            out.push((format!("light.{k}"), layer));
        }
        out.push(("emission".into(), &mut self.emission));
        out.push(("indirect".into(), &mut self.indirect));
        out.push(("normal".into(), &mut self.normal));
        out.push(("albedo".into(), &mut self.albedo));
        out.push((REFLECTION_LAYERS[0].into(), &mut self.reflectance));
        out.push((REFLECTION_LAYERS[1].into(), &mut self.reflected));
        out.push((GLOSSY_LAYERS[0].into(), &mut self.glossy));
        out.push((GLOSSY_LAYERS[1].into(), &mut self.glossy_exponent));
        let transmission = [
            &mut self.transmittance,
            &mut self.transmitted,
            &mut self.transmission_origin,
            &mut self.transmission_direction,
            &mut self.transmission_distance,
        ];
        for (name, buffer) in TRANSMISSION_LAYERS.iter().zip(transmission) {
            out.push(((*name).into(), buffer));
        }
        out
    }
}

/// The channel suffixes of a buffer: `X`, `Y`, `Z` for the vectors (`normal`, the exit ray's
/// `transmission_origin` and `transmission_direction`), `R`, `G`, `B` otherwise.
pub(crate) fn channel_suffixes(layer: &str) -> [&'static str; 3] {
    match layer {
        "normal" | "transmission_origin" | "transmission_direction" => ["X", "Y", "Z"],
        _ => ["R", "G", "B"],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups_are_contiguous_and_cover_every_layer() {
        for n in [0usize, 1, 5, 16, 17, 40, 1000] {
            let layers = light_layer_count(n);
            let mut previous = 0;
            for k in 0..n {
                let l = light_layer_of(k, n);
                assert!(l < layers && l >= previous && l - previous <= 1, "n={n} k={k}");
                previous = l;
            }
            if n > 0 {
                assert_eq!(previous, layers - 1);
            }
        }
        assert_eq!(light_layer_of(7, 10), 7);
        let lights = (0..40).map(|k| LightSource::new(k, "l")).collect();
        let layers = LightLayers::new(1, 1, 0, lights);
        assert_eq!(layers.light.len(), 16);
        assert_eq!(layers.lights_of_layer(0), 0..3);
        assert_eq!(layers.lights_of_layer(15), 38..40);
    }
}
