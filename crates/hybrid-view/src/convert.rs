//! From a parsed RIB [`Scene`] to the viewer's own inputs: the camera, the lights as live
//! lights (area emitters reduced to a representative point), and the tone map.

use glam::{DVec3, Vec3};
use rib_parser::scene::{LightId, LightKind, Scene};
use tessellate::{Tolerance, tessellate_placed};
use viewer::{AreaSample, LiveLight, ToneMap};

/// What the conversion could not use, as warnings for the user.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Skipped {
    pub warnings: Vec<String>,
}

/// `Exposure gain gamma` of the scene.
pub fn tone_map(scene: &Scene) -> ToneMap {
    ToneMap { gain: scene.render.exposure.gain, gamma: scene.render.exposure.gamma }
}

/// The pixel filter the image was rendered with, which the viewer applies to live objects'
/// edges. A filter `lrt-depth` cannot use is replaced by RenderMan's default there, so here too
/// (with a warning); a filter wider than the viewer gathers is cut, with a warning.
pub fn pixel_filter(scene: &Scene, skipped: &mut Skipped) -> viewer::PixelFilter {
    let f = &scene.render.pixel_filter;
    let filter = viewer::PixelFilter::from_rib(&f.name, f.x_width, f.y_width).unwrap_or_else(|why| {
        skipped
            .warnings
            .push(format!("PixelFilter: {why}; live objects' edges use gaussian 2 2, as the renderer does"));
        viewer::PixelFilter::RENDERMAN_DEFAULT
    });
    if let Some(note) = viewer::pixel_filter::note(&filter) {
        skipped.warnings.push(format!("PixelFilter: {note}"));
    }
    filter
}

/// Warns when the pre-rendered image has camera effects the live objects are drawn without:
/// they are drawn with a pinhole, so they stay sharp where the image is defocused, and at one
/// instant, so they stay sharp where the image is motion blurred (its depth table holds the
/// scene at shutter open).
pub fn camera_effects(scene: &Scene, skipped: &mut Skipped) {
    if scene.has_motion_blur() {
        let (open, close) = scene.render.shutter.unwrap_or_default();
        skipped.warnings.push(format!(
            "Shutter {open} {close}: the image has motion blur but live objects are drawn sharp, and depths are those at shutter open"
        ));
    }
    if let Some(d) = scene.render.depth_of_field {
        skipped.warnings.push(format!(
            "DepthOfField {} {} {}: the image is defocused but live objects are drawn sharp (pinhole)",
            d.fstop, d.focal_length, d.focal_distance
        ));
    }
}

/// A live light with where it came from: its index in the scene's lights (the sidecar's light
/// numbering) and, for an area light, samples of its emitting surface.
pub struct SourcedLight {
    pub scene_index: usize,
    pub light: LiveLight,
    pub area_samples: Vec<AreaSample>,
}

/// The scene's lights as the viewer's live lights, in the scene's order (lights that cannot be
/// used are left out with a warning), each with its scene index and area samples.
pub fn live_lights_with_sources(scene: &Scene, skipped: &mut Skipped) -> Vec<SourcedLight> {
    let mut out = Vec::new();
    // RenderMan's delta lights give `Kd Cs Cl cos` on a matte surface (`diffuse()` has no
    // `1/pi`); the ray tracer carries that as a factor `pi` on their intensity, and so do the
    // live lights, which the shaders apply to a true Lambertian `Kd Cs / pi`.
    let delta = rib_parser::scene::RENDERMAN_DELTA_LIGHT_SCALE;
    for (k, light) in scene.lights.iter().enumerate() {
        let finite = |v: f32| v.is_finite();
        let mut samples = Vec::new();
        let converted = match &light.kind {
            LightKind::Ambient { intensity, color } => {
                Some(LiveLight::Ambient { colour: *color * *intensity })
            }
            LightKind::Distant { direction, intensity, color } => {
                Some(LiveLight::Distant { direction: *direction, colour: *color * *intensity * delta })
            }
            LightKind::Point { position, intensity, color } => {
                Some(LiveLight::Point { position: *position, colour: *color * *intensity * delta })
            }
            LightKind::Spot {
                position,
                direction,
                intensity,
                color,
                cone_angle,
                cone_delta_angle,
                beam_distribution,
            } => Some(LiveLight::Spot {
                position: *position,
                axis: *direction,
                colour: *color * *intensity * delta,
                cone_angle: *cone_angle,
                cone_delta_angle: *cone_delta_angle,
                beam_distribution: *beam_distribution,
            }),
            LightKind::Area { intensity, color } => {
                area_light(scene, LightId(k as u32), *color * *intensity, skipped, &mut samples)
            }
            LightKind::Other => {
                skipped.warnings.push(format!(
                    "{}: light shader \"{}\" is not one the viewer knows; the live objects ignore it",
                    light.shader.loc, light.shader.name
                ));
                None
            }
        };
        match converted {
            Some(l) if light_is_finite(&l, finite) => {
                out.push(SourcedLight { scene_index: k, light: l, area_samples: samples })
            }
            Some(_) => skipped.warnings.push(format!(
                "{}: light has non-finite values; the live objects ignore it",
                light.shader.loc
            )),
            None => {}
        }
    }
    out
}

fn light_is_finite(l: &LiveLight, finite: impl Fn(f32) -> bool) -> bool {
    let c = |v: Vec3| v.is_finite();
    match l {
        LiveLight::Ambient { colour } => c(*colour),
        LiveLight::Distant { direction, colour } => direction.is_finite() && c(*colour),
        LiveLight::Point { position, colour } => position.is_finite() && c(*colour),
        LiveLight::Spot { position, axis, colour, cone_angle, cone_delta_angle, beam_distribution } => {
            position.is_finite()
                && axis.is_finite()
                && c(*colour)
                && finite(*cone_angle)
                && finite(*cone_delta_angle)
                && finite(*beam_distribution)
        }
        LiveLight::Area { centroid, normal, radiance, area, radius, .. } => {
            centroid.is_finite()
                && normal.is_none_or(|n| n.is_finite())
                && c(*radiance)
                && area.is_finite()
                && radius.is_finite()
        }
    }
}

/// An area light as a representative point: the area-weighted centroid of its emitting shapes
/// (tessellated in world space), their total area, and their mean normal when they are flat
/// enough to have one (the mean of unit normals keeps at least half its length); otherwise the
/// emitter is treated as radiating evenly in all directions (a sphere).
fn area_light(
    scene: &Scene,
    id: LightId,
    radiance: Vec3,
    skipped: &mut Skipped,
    samples: &mut Vec<AreaSample>,
) -> Option<LiveLight> {
    let mut triangles: Vec<[DVec3; 3]> = Vec::new();
    let tolerance = Tolerance::relative(1e-3).with_max_triangles(1 << 20);
    let mut area = 0.0f64;
    let mut weighted_centre = DVec3::ZERO;
    let mut weighted_normal = DVec3::ZERO;
    let mut two_sided = false;
    for shape in &scene.shapes {
        let attributes = scene.attributes_of(shape.attributes);
        if attributes.area_light != Some(id) {
            continue;
        }
        two_sided |= attributes.sides == 2;
        let mesh = match tessellate_placed(
            &shape.shape,
            &shape.world_from_object,
            attributes.reverse_orientation,
            &tolerance,
        ) {
            Ok(m) => m,
            Err(e) => {
                skipped.warnings.push(format!("{}: area light shape skipped by the viewer: {e}", shape.loc));
                continue;
            }
        };
        for t in 0..mesh.triangle_count() {
            let cross = mesh.face_cross(t);
            let a = 0.5 * cross.length();
            let [p0, p1, p2] = mesh.triangle(t).map(|p| p.as_dvec3());
            area += a;
            triangles.push([p0, p1, p2]);
            weighted_centre += (p0 + p1 + p2) / 3.0 * a;
            weighted_normal += cross * 0.5;
        }
    }
    let light = &scene.lights[id.0 as usize];
    if area <= 0.0 {
        skipped.warnings.push(format!(
            "{}: area light has no emitting geometry the viewer can place; the live objects ignore it",
            light.shader.loc
        ));
        return None;
    }
    // Many more than the shaders take, so that any share of them is still spread evenly.
    *samples =
        viewer::light_layers::area_samples(&triangles, 4 * viewer::light_layers::AREA_SAMPLES_PER_LIGHT);
    let centroid = weighted_centre / area;
    let flat = weighted_normal.length() >= 0.5 * area;
    let (normal, radius) = if flat {
        (Some(weighted_normal.normalize()), (area / std::f64::consts::PI).sqrt())
    } else {
        (None, (area / (4.0 * std::f64::consts::PI)).sqrt())
    };
    Some(LiveLight::Area { centroid, normal, two_sided, radiance, area, radius })
}

/// World-space bounds of the scene's shapes (transformed object bounds of their tessellation),
/// `None` when there are none.
pub fn scene_bounds(scene: &Scene) -> Option<(DVec3, DVec3)> {
    let tolerance = Tolerance::relative(1e-2).with_max_triangles(1 << 20);
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for shape in &scene.shapes {
        let attributes = scene.attributes_of(shape.attributes);
        if let Ok(mesh) = tessellate_placed(
            &shape.shape,
            &shape.world_from_object,
            attributes.reverse_orientation,
            &tolerance,
        ) && let Some((a, b)) = mesh.bounds()
        {
            lo = lo.min(a.as_dvec3());
            hi = hi.max(b.as_dvec3());
        }
    }
    (lo.is_finite() && hi.is_finite()).then_some((lo, hi))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene(rib: &str) -> Scene {
        rib_parser::load_bytes("test.rib", rib.as_bytes().to_vec(), &rib_parser::LoadOptions::default())
            .expect("a valid scene")
            .scene
    }

    #[test]
    fn motion_blur_warns_only_with_an_open_shutter_and_something_moving() {
        let moving = "WorldBegin\nMotionBegin [0 1]\nTranslate 0 0 0\nTranslate 1 0 0\nMotionEnd\nSphere 1 -1 1 360\nWorldEnd\n";
        let warnings = |rib: &str| {
            let mut skipped = Skipped::default();
            camera_effects(&scene(rib), &mut skipped);
            skipped.warnings
        };
        let w = warnings(&format!("Shutter 0 1\n{moving}"));
        assert!(w.len() == 1 && w[0].contains("motion blur"), "{w:?}");
        // RenderMan's default shutter (0 0) takes one instant: no blur.
        assert!(warnings(moving).is_empty());
        assert!(warnings("Shutter 0 1\nWorldBegin\nSphere 1 -1 1 360\nWorldEnd\n").is_empty());
    }

    #[test]
    fn cornell_area_light_becomes_its_centroid_facing_down() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/reference/cornell/cornell.rib");
        let loaded = rib_parser::load_scene(std::path::Path::new(path), &Default::default()).unwrap();
        let mut skipped = Skipped::default();
        let lights: Vec<LiveLight> =
            live_lights_with_sources(&loaded.scene, &mut skipped).into_iter().map(|l| l.light).collect();
        assert_eq!(lights.len(), 1, "{skipped:?}");
        let LiveLight::Area { centroid, normal, radiance, area, radius, .. } = &lights[0] else {
            panic!("not an area light: {:?}", lights[0]);
        };
        assert!((*centroid - DVec3::new(0.0, 0.99, 0.01)).length() < 1e-6, "{centroid}");
        assert!((normal.unwrap() - DVec3::NEG_Y).length() < 1e-9);
        assert!((area - 0.46 * 0.38).abs() < 1e-6);
        assert!((radius - (0.46f64 * 0.38 / std::f64::consts::PI).sqrt()).abs() < 1e-6);
        assert!((radiance.x - 18.387).abs() < 1e-4);
        assert_eq!(tone_map(&loaded.scene), ToneMap { gain: 1.0, gamma: 1.0 });
    }

    #[test]
    fn standard_lights_convert_and_unknown_ones_warn() {
        let s = scene(
            r#"Format 8 8 1
            Exposure 2 2.2
            WorldBegin
              LightSource "ambientlight" 1 "intensity" [0.5]
              LightSource "distantlight" 2 "from" [0 1 0] "to" [0 0 0] "intensity" [3]
              LightSource "pointlight" 3 "from" [1 2 3] "intensity" [4] "lightcolor" [1 0.5 0.25]
              LightSource "spotlight" 4 "from" [0 5 0] "to" [0 0 0] "coneangle" [0.5] "conedeltaangle" [0.1]
              LightSource "mysterylight" 5
              AttributeBegin
                AreaLightSource "arealight" 6 "intensity" [2]
                Sphere 0.5 -0.5 0.5 360
              AttributeEnd
            WorldEnd
            "#,
        );
        let mut skipped = Skipped::default();
        let lights: Vec<LiveLight> =
            live_lights_with_sources(&s, &mut skipped).into_iter().map(|l| l.light).collect();
        assert_eq!(skipped.warnings.len(), 1, "{skipped:?}");
        assert!(skipped.warnings[0].contains("mysterylight"));
        assert_eq!(lights.len(), 5);
        assert_eq!(lights[0], LiveLight::Ambient { colour: Vec3::splat(0.5) });
        let LiveLight::Distant { direction, colour } = &lights[1] else { panic!() };
        // Delta lights carry RenderMan's factor pi, as in the ray tracer.
        let pi = std::f32::consts::PI;
        assert!((*direction - DVec3::NEG_Y).length() < 1e-12 && *colour == Vec3::splat(3.0) * pi);
        assert_eq!(
            lights[2],
            LiveLight::Point { position: DVec3::new(1.0, 2.0, 3.0), colour: Vec3::new(4.0, 2.0, 1.0) * pi }
        );
        let LiveLight::Spot { axis, cone_angle, .. } = &lights[3] else { panic!() };
        assert!((*axis - DVec3::NEG_Y).length() < 1e-12 && (cone_angle - 0.5).abs() < 1e-6);
        // A sphere emitter: no single normal, area about 4 pi r^2.
        let LiveLight::Area { normal, area, centroid, .. } = &lights[4] else { panic!() };
        assert!(normal.is_none() && centroid.length() < 1e-6);
        assert!((area - std::f64::consts::PI).abs() < 0.01 * std::f64::consts::PI, "{area}");
        assert_eq!(tone_map(&s), ToneMap { gain: 2.0, gamma: 2.2 });
    }
}
