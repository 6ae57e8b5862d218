//! Crop windows tile the frame exactly: every crop render's pixels (colour, alpha and depth) are
//! bit for bit the same pixels of the full-frame render, with any pixel filter; and renders do
//! not depend on the thread count.

use raytracer::render::{RenderOptions, RenderOutput, render};

const SCENE: &str = r#"
Format 37 23 1
Projection "perspective" "fov" [45]
PixelSamples 2 3
Translate 0 -0.3 4
WorldBegin
  LightSource "pointlight" 1 "from" [1 2 -3] "intensity" [12]
  AttributeBegin
    AreaLightSource "arealight" 2 "intensity" [3]
    Translate 0 1.6 0
    Rotate 90 1 0 0
    Disk 0 0.4 360
  AttributeEnd
  Surface "plastic" "roughness" [0.05]
  Color [0.9 0.4 0.2]
  Sphere 0.7 -0.7 0.7 360
  Surface "matte"
  Color [0.5 0.6 0.7]
  Polygon "P" [-3 -0.7 -3  3 -0.7 -3  3 -0.7 3  -3 -0.7 3]
WorldEnd
"#;

fn render_with(filter: &str, crop: Option<(f64, f64, f64, f64)>, threads: usize) -> RenderOutput {
    let rib = SCENE.replace("Format 37 23 1", &format!("Format 37 23 1\nPixelFilter {filter}"));
    let mut scene = rib_parser::load_bytes("crop.rib", rib.into_bytes(), &Default::default()).unwrap().scene;
    if let Some((xmin, xmax, ymin, ymax)) = crop {
        scene.camera.crop_window = depth_remap::CropWindow { xmin, xmax, ymin, ymax };
    }
    render(&scene, &RenderOptions { depth: true, threads: Some(threads), seed: 11, ..Default::default() })
        .unwrap()
}

#[test]
fn crop_tiles_merge_exactly_into_the_full_frame() {
    for filter in ["\"box\" 1 1", "\"gaussian\" 2 2", "\"catmull-rom\" 4 4", "\"sinc\" 3 2"] {
        let full = render_with(filter, None, 2);
        let full_depth = full.depth.as_ref().unwrap();
        let mut covered = vec![0u32; (37 * 23) as usize];
        for crop in
            [(0.0, 0.41, 0.0, 0.5), (0.41, 1.0, 0.0, 0.5), (0.0, 0.73, 0.5, 1.0), (0.73, 1.0, 0.5, 1.0)]
        {
            let tile = render_with(filter, Some(crop), 1);
            let img = &tile.image;
            let depth = tile.depth.as_ref().unwrap();
            assert_eq!((img.full_width, img.full_height), (37, 23));
            for y in 0..img.height {
                for x in 0..img.width {
                    let (fx, fy) = (x + img.x_offset, y + img.y_offset);
                    let i = (fy * 37 + fx) as usize;
                    covered[i] += 1;
                    let ours = img.pixels[(y * img.width + x) as usize];
                    assert_eq!(
                        ours.map(f32::to_bits),
                        full.image.pixels[i].map(f32::to_bits),
                        "{filter}: pixel ({fx}, {fy})"
                    );
                    assert_eq!(
                        depth.values[(y * img.width + x) as usize].to_bits(),
                        full_depth.values[i].to_bits()
                    );
                }
            }
        }
        assert!(covered.iter().all(|&c| c == 1), "{filter}: the crops must tile the frame");
    }
}

#[test]
fn renders_do_not_depend_on_the_thread_count() {
    let one = render_with("\"gaussian\" 2 2", None, 1);
    let three = render_with("\"gaussian\" 2 2", None, 3);
    assert_eq!(one.image, three.image);
    assert_eq!(one.depth, three.depth);
}
