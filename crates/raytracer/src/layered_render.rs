//! Rendering with light layers: each camera sample's tally ([`crate::light_layers`]) becomes
//! extra channels beside its colour, filtered with the image's pixel filter exactly as the
//! colour is, and assembled into the sidecar's [`sidecar::LightLayers`] (docs/sidecar.md).

use crate::film::{DepthImage, Filter, Image};
use crate::integrators::{Integrator, RayCounters};
use crate::light_layers;
use crate::render::{Frame, TILE};
use crate::sampler::PixelSampler;
use crate::transmission_layers;
use crate::world::World;
use glam::DVec2;
use rayon::prelude::*;
use rib_parser::scene::Scene;
use sidecar::{LightLayers, LightSource, depth_fingerprint, light_layer_count, light_layer_of};
use std::sync::atomic::{AtomicU64, Ordering};

/// Channels of a sample or pixel before the transmission channels: RGBA, emission, normal,
/// albedo, reflectance, reflected, glossy, the glossy-weighted exponent (three channels, one
/// used).
const FIXED_CHANNELS: usize = 25;

/// The transmitted chain's channels after them ([`crate::transmission_layers`]):
/// transmittance, transmitted, then the exit ray's origin, direction and distance each times
/// the averaging weight, then that weight.
const TRANSMISSION_CHANNELS: usize = 14;

/// The first light layer's channel.
const LIGHTS_START: usize = FIXED_CHANNELS + TRANSMISSION_CHANNELS;

/// How a world's lights map to layers, and the channel layout of a layered sample.
#[derive(Clone, Debug)]
pub(crate) struct LayerPlan {
    /// The layer of each of `World::lights`.
    layer_of_light: Vec<usize>,
    layers: usize,
    /// Channels per sample and pixel: `LIGHTS_START + 3 * layers`.
    pub stride: usize,
    /// World space from the integrators' render space (the exit rays' origins are stored in
    /// world space).
    world_from_render: glam::DMat4,
}

impl LayerPlan {
    pub fn new(world: &World, scene: &Scene) -> LayerPlan {
        let n = scene.lights.len();
        let layer_of_light = world.light_sources.iter().map(|&s| light_layer_of(s as usize, n)).collect();
        let layers = light_layer_count(n);
        LayerPlan {
            layer_of_light,
            layers,
            stride: LIGHTS_START + 3 * layers,
            world_from_render: world.render_from_world.inverse(),
        }
    }

    /// Starts recording a camera sample on this thread.
    pub fn arm(&self) {
        light_layers::arm(self.layer_of_light.len());
        transmission_layers::arm();
    }

    /// Ends the sample and appends its channels after the RGBA already in `values`; a sample
    /// whose ray was never traced (`traced == false`) gets zeros.
    pub fn push_sample(&self, values: &mut Vec<f32>, traced: bool) {
        let start = values.len();
        values.resize(start + self.stride - 4, 0.0);
        if !traced {
            return;
        }
        let out = &mut values[start..];
        transmission_layers::disarm(|t| {
            let out = &mut out[FIXED_CHANNELS - 4..LIGHTS_START - 4];
            out[0..3].copy_from_slice(&t.transmittance.to_array());
            out[3..6].copy_from_slice(&t.transmitted.to_array());
            out[6..9].copy_from_slice(&t.origin.to_array());
            out[9..12].copy_from_slice(&t.direction.to_array());
            out[12] = t.distance;
            out[13] = t.weight;
        });
        light_layers::disarm(|t| {
            out[0..3].copy_from_slice(&t.emission.to_array());
            out[3..6].copy_from_slice(&t.normal.to_array());
            out[6..9].copy_from_slice(&t.albedo.to_array());
            out[9..12].copy_from_slice(&t.reflectance.to_array());
            out[12..15].copy_from_slice(&t.reflected.to_array());
            out[15..18].copy_from_slice(&t.glossy.to_array());
            out[18] = t.glossy_exponent;
            for (light, d) in t.direct.iter().enumerate() {
                let k = LIGHTS_START - 4 + 3 * self.layer_of_light[light];
                for c in 0..3 {
                    out[k + c] += d[c];
                }
            }
        });
    }
}

/// Renders the whole frame in one pass with light layers: the image (identical to
/// `Frame::render`'s: same samples, same filter order) and `plan.stride` channels per pixel.
pub(crate) fn render_layered(
    frame: &Frame,
    integrator: &dyn Integrator,
    plan: &LayerPlan,
) -> (Vec<[f32; 4]>, Vec<f32>, RayCounters) {
    let (x0, y0, x1, y1) = frame.bounds;
    let (w, h) = (frame.width(), frame.height());
    let mut tiles = Vec::new();
    for ty in (y0..y1).step_by(TILE as usize) {
        for tx in (x0..x1).step_by(TILE as usize) {
            tiles.push((tx, ty, (tx + TILE).min(x1), (ty + TILE).min(y1)));
        }
    }
    let total = u64::from(w) * u64::from(h);
    let done = AtomicU64::new(0);
    let results: Vec<(Vec<f32>, RayCounters)> = tiles
        .par_iter()
        .map(|&tile| {
            let r = layered_tile(frame, integrator, plan, tile);
            let n = u64::from(tile.2 - tile.0) * u64::from(tile.3 - tile.1);
            let d = done.fetch_add(n, Ordering::Relaxed) + n;
            if let Some(p) = &frame.progress {
                p(d, total);
            }
            r
        })
        .collect();
    let stride = plan.stride;
    let mut pixels = vec![[0.0f32; 4]; (w * h) as usize];
    let mut layered = vec![0.0f32; (w * h) as usize * stride];
    let mut counters = RayCounters::default();
    for (&(tx0, ty0, tx1, ty1), (tile, c)) in tiles.iter().zip(&results) {
        counters.add(c);
        let tw = tx1 - tx0;
        for y in ty0..ty1 {
            for x in tx0..tx1 {
                let to = ((y - y0) * w + (x - x0)) as usize;
                let from = ((y - ty0) * tw + (x - tx0)) as usize;
                let pixel = &tile[from * stride..(from + 1) * stride];
                pixels[to] = [pixel[0], pixel[1], pixel[2], pixel[3]];
                layered[to * stride..(to + 1) * stride].copy_from_slice(pixel);
            }
        }
    }
    (pixels, layered, counters)
}

/// One tile of [`render_layered`]: every sample within the filter's reach, with its tally.
fn layered_tile(
    frame: &Frame,
    integrator: &dyn Integrator,
    plan: &LayerPlan,
    (x0, y0, x1, y1): (u32, u32, u32, u32),
) -> (Vec<f32>, RayCounters) {
    let (mx, my) = frame.filter.pixel_margin();
    let (sx0, sy0) = (x0 as i64 - i64::from(mx), y0 as i64 - i64::from(my));
    let (sx1, sy1) = (x1 as i64 + i64::from(mx), y1 as i64 + i64::from(my));
    let sw = (sx1 - sx0) as usize;
    let spp = frame.spp as usize;
    let count = sw * (sy1 - sy0) as usize * spp;
    let mut positions = Vec::with_capacity(count);
    let mut values = Vec::with_capacity(count * plan.stride);
    let mut counters = RayCounters::default();
    for py in sy0..sy1 {
        for px in sx0..sx1 {
            let pixel_sampler = PixelSampler::new(frame.seed, px, py);
            for s in 0..frame.spp {
                let mut sampler = pixel_sampler.sample(s);
                // The first pair of dimensions places the sample in the pixel (stratified).
                let jitter = sampler.uniform2();
                let x = px as f64 + f64::from(jitter.x);
                let y = py as f64 + f64::from(jitter.y);
                let lens_u = if frame.rays.has_lens() { sampler.uniform2() } else { glam::Vec2::ZERO };
                // A time sample only where something moves, as in `render.rs`.
                let time = if frame.world.motion_blur { sampler.uniform() } else { 0.0 };
                let ray = frame.rays.lens_ray_at(DVec2::new(x, y), lens_u, time);
                let traced = ray.is_some();
                if traced {
                    plan.arm();
                }
                let r = match ray {
                    Some((ray, _)) => integrator.li(frame.world, ray, &mut sampler, &mut counters),
                    None => Default::default(),
                };
                let composited = if traced { frame.world.over_background(r) } else { r };
                positions.push([x as f32, y as f32]);
                values.extend_from_slice(&[composited.rgb.x, composited.rgb.y, composited.rgb.z, r.alpha]);
                let layers = values.len();
                plan.push_sample(&mut values, traced);
                if traced {
                    // The background is emission seen by the camera: it keeps the layers'
                    // sum equal to the image.
                    for c in 0..3 {
                        values[layers + c] += composited.rgb[c] - r.rgb[c];
                    }
                }
            }
        }
    }
    let out =
        reconstruct(frame.filter, &positions, &values, plan.stride, spp, (sx0, sy0, sw), (x0, y0, x1, y1));
    (out, counters)
}

/// Filters the samples of a tile into pixels: each pixel `[x0, x1) x [y0, y1)` is the
/// filter-weighted mean (in `f64`, neighbours in row order) of the samples within the filter's
/// reach. `positions[i]` is sample `i`'s raster position; samples are stored per pixel of the
/// sample region (`spp` each, rows from `(sx0, sy0)`, `sw` pixels wide), `stride` values each.
/// Non-finite results become 0.
#[allow(clippy::too_many_arguments)]
pub(crate) fn reconstruct(
    filter: &Filter,
    positions: &[[f32; 2]],
    values: &[f32],
    stride: usize,
    spp: usize,
    (sx0, sy0, sw): (i64, i64, usize),
    (x0, y0, x1, y1): (u32, u32, u32, u32),
) -> Vec<f32> {
    let (mx, my) = filter.pixel_margin();
    let tw = (x1 - x0) as usize;
    let mut out = vec![0.0f32; tw * (y1 - y0) as usize * stride];
    let mut sum = vec![0.0f64; stride];
    for y in y0..y1 {
        for x in x0..x1 {
            let (cx, cy) = (x as f32 + 0.5, y as f32 + 0.5);
            sum.fill(0.0);
            let mut weight = 0.0f64;
            for qy in (y as i64 - i64::from(my))..=(y as i64 + i64::from(my)) {
                for qx in (x as i64 - i64::from(mx))..=(x as i64 + i64::from(mx)) {
                    let base = (((qy - sy0) as usize) * sw + (qx - sx0) as usize) * spp;
                    for s in base..base + spp {
                        let [px, py] = positions[s];
                        let wgt = filter.weight(px - cx, py - cy);
                        if wgt != 0.0 {
                            let wgt = f64::from(wgt);
                            for (acc, v) in sum.iter_mut().zip(&values[s * stride..(s + 1) * stride]) {
                                *acc += wgt * f64::from(*v);
                            }
                            weight += wgt;
                        }
                    }
                }
            }
            let pixel = ((y - y0) as usize * tw + (x - x0) as usize) * stride;
            if weight != 0.0 {
                for (o, acc) in out[pixel..pixel + stride].iter_mut().zip(&sum) {
                    let v = (acc / weight) as f32;
                    *o = if v.is_finite() { v } else { 0.0 };
                }
            }
        }
    }
    out
}

/// The sidecar layers of a full frame from its filtered layered pixels (`stride` channels per
/// pixel, as [`LayerPlan`] lays them out, RGBA first). `indirect` is what remains of the colour
/// after the other layers, so the layers sum to the image by construction.
pub(crate) fn assemble(
    scene: &Scene,
    plan: &LayerPlan,
    image: &Image,
    layered: &[f32],
    depth: Option<&DepthImage>,
) -> LightLayers {
    let lights = scene
        .lights
        .iter()
        .enumerate()
        .map(|(i, l)| LightSource::new(i as u32, format!("{} at {}", l.shader.name, l.shader.loc)))
        .collect();
    let fingerprint = depth.map_or(depth_fingerprint(&[]), |d| depth_fingerprint(&d.values));
    let mut out = LightLayers::new(image.width, image.height, fingerprint, lights);
    for (p, px) in layered.chunks_exact(plan.stride).enumerate() {
        let v3 = |k: usize| [px[k], px[k + 1], px[k + 2]];
        out.emission[p] = v3(4);
        out.normal[p] = v3(7);
        out.albedo[p] = v3(10);
        out.reflectance[p] = v3(13);
        out.reflected[p] = v3(16);
        out.glossy[p] = v3(19);
        // The mean exponent of the samples' lobes, weighted as their `glossy`; zero without one.
        let weight = out.glossy[p].iter().fold(0.0f32, |m, &v| m.max(v));
        let exponent = if weight > 0.0 { (px[22] / weight).clamp(1.0, 10_000.0) } else { 0.0 };
        out.glossy_exponent[p] = [exponent; 3];
        assemble_transmission(&mut out, p, &px[FIXED_CHANNELS..LIGHTS_START], &plan.world_from_render);
        let mut indirect = [f64::from(px[0]), f64::from(px[1]), f64::from(px[2])];
        for c in 0..3 {
            indirect[c] -= f64::from(px[4 + c]);
        }
        for k in 0..plan.layers {
            let l = v3(LIGHTS_START + 3 * k);
            out.light[k][p] = l;
            for c in 0..3 {
                indirect[c] -= f64::from(l[c]);
            }
        }
        out.indirect[p] = indirect.map(|v| v as f32);
    }
    out
}

/// Pixel `p`'s transmission layers from its filtered transmission channels (laid out as
/// [`TRANSMISSION_CHANNELS`]): the exit ray's values are their weighted means (its origin
/// moved to world space), zero where no sample's chain ended (or the filter's weights cancel).
fn assemble_transmission(out: &mut LightLayers, p: usize, channels: &[f32], world_from_render: &glam::DMat4) {
    let v3 = |k: usize| [channels[k], channels[k + 1], channels[k + 2]];
    out.transmittance[p] = v3(0);
    out.transmitted[p] = v3(3);
    let weight = channels[13];
    let mean = |v: f32| v / weight;
    let (origin, direction, distance) = (v3(6).map(mean), v3(9).map(mean), mean(channels[12]));
    let finite = origin.iter().chain(&direction).all(|v| v.is_finite()) && distance.is_finite();
    if weight > 0.0 && finite {
        let world = world_from_render.transform_point3(glam::DVec3::from_array(origin.map(f64::from)));
        out.transmission_origin[p] = world.as_vec3().to_array();
        out.transmission_direction[p] = direction;
        out.transmission_distance[p] = [distance; 3];
    }
}
