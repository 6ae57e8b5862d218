//! Nothing panics on any input, and limits stop runaway input with a clear error.

#[path = "support/corpus_fs.rs"]
mod corpus_fs;

use proptest::prelude::*;
use rib_parser::{FileSystem, Limits, LoadOptions, ReadOptions, load_bytes};
use std::io;
use std::path::Path;
use std::sync::Arc;

/// Loads `bytes` and renders whatever comes out (rendering exercises the source snippets).
fn load_anything(bytes: Vec<u8>) {
    match load_bytes("fuzz.rib", bytes, &LoadOptions::default()) {
        Ok(l) => {
            let _ = l.render_warnings();
            let _ = rib_parser::summary::dump(&l.scene);
            let _ = rib_parser::writer::write_scene(&l.scene);
        }
        Err(e) => {
            assert!(e.first_error().is_some(), "an error result without an error: {e:?}");
            let _ = e.render();
        }
    }
}

const REQUESTS: &[&str] = &[
    "WorldBegin",
    "WorldEnd",
    "FrameBegin",
    "FrameEnd",
    "AttributeBegin",
    "AttributeEnd",
    "TransformBegin",
    "TransformEnd",
    "Sphere",
    "Cone",
    "Disk",
    "Torus",
    "Hyperboloid",
    "Polygon",
    "GeneralPolygon",
    "PointsPolygons",
    "PointsGeneralPolygons",
    "Patch",
    "PatchMesh",
    "NuPatch",
    "TrimCurve",
    "SubdivisionMesh",
    "HierarchicalSubdivisionMesh",
    "Points",
    "Curves",
    "Basis",
    "Color",
    "Opacity",
    "Surface",
    "LightSource",
    "AreaLightSource",
    "Illuminate",
    "Orientation",
    "ReverseOrientation",
    "Sides",
    "Translate",
    "Rotate",
    "Scale",
    "Skew",
    "Perspective",
    "ConcatTransform",
    "Transform",
    "Identity",
    "CoordinateSystem",
    "CoordSysTransform",
    "ObjectBegin",
    "ObjectEnd",
    "ObjectInstance",
    "MotionBegin",
    "MotionEnd",
    "SolidBegin",
    "SolidEnd",
    "Declare",
    "Option",
    "Attribute",
    "Format",
    "Projection",
    "ScreenWindow",
    "CropWindow",
    "Clipping",
    "Display",
    "ReadArchive",
    "ArchiveBegin",
    "ArchiveEnd",
    "Procedural",
    "Blobby",
    "ColorSamples",
    "Quantize",
    "PixelFilter",
    "Hider",
];

const WORDS: &[&str] = &[
    "\"P\"",
    "\"Pw\"",
    "\"Pz\"",
    "\"N\"",
    "\"Cs\"",
    "\"st\"",
    "\"uniform float Kd\"",
    "\"vertex point P\"",
    "\"facevarying float[2] st\"",
    "\"bicubic\"",
    "\"bilinear\"",
    "\"periodic\"",
    "\"nonperiodic\"",
    "\"perspective\"",
    "\"fov\"",
    "\"catmull-clark\"",
    "\"crease\"",
    "\"hole\"",
    "\"pointlight\"",
    "\"lh\"",
    "\"inside\"",
    "\"DelayedReadArchive\"",
    "\"x.rib\"",
    "\"bezier\"",
    "\"b-spline\"",
    "\"string depthfile\"",
    "\"lrt\"",
    "\"haptic\"",
    "\"float stiffness\"",
    "[",
    "]",
    "[0 0 0 1 0 0 0 1 0]",
    "[3]",
    "[0 1 2]",
    "0",
    "1",
    "-1",
    "2",
    "3",
    "4",
    "16",
    ".5",
    "1e30",
    "-0",
    "360",
    "2147483648",
    "1e-45",
    "\"",
    "#c\n",
    "\n",
    "\u{80}",
    "\u{a6}",
    "\u{c8}",
];

/// 256 cases per property in the normal suite; `PROPTEST_CASES=100000` for a long run.
fn cases() -> u32 {
    std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(256)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(), .. ProptestConfig::default() })]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..2048)) {
        load_anything(bytes);
    }

    #[test]
    fn request_soup_never_panics(
        parts in proptest::collection::vec(
            prop_oneof![
                proptest::sample::select(REQUESTS).prop_map(|s| s.to_string()),
                proptest::sample::select(WORDS).prop_map(|s| s.to_string()),
                any::<u8>().prop_map(|b| (b as char).to_string()),
                (-1000.0f64..1000.0).prop_map(|f| f.to_string()),
            ],
            0..200,
        )
    ) {
        let mut text = String::new();
        for p in parts {
            text.push_str(&p);
            text.push(' ');
        }
        load_anything(text.into_bytes());
    }

    #[test]
    fn mutated_corpus_files_never_panic(
        file in 0usize..1000,
        edits in proptest::collection::vec((any::<u32>(), any::<u8>(), 0u8..4), 1..24),
    ) {
        let files = corpus_fs::corpus_files();
        let (repo, name) = &files[file % files.len()];
        let mut bytes = std::fs::read(corpus_fs::corpus_dir().join(repo).join(name)).unwrap_or_default();
        // Gzip files are mutated after decompression too, half of the time.
        if rib_parser::source::is_gzip(&bytes) && file % 2 == 0 {
            bytes = rib_parser::source::decode(bytes, 1 << 24).map(|(b, _)| b).unwrap_or_default();
        }
        bytes.truncate(64 * 1024);
        for (at, byte, kind) in edits {
            if bytes.is_empty() {
                bytes.push(byte);
                continue;
            }
            let at = at as usize % bytes.len();
            match kind {
                0 => bytes[at] = byte,
                1 => { bytes.remove(at); }
                2 => bytes.insert(at, byte),
                _ => bytes.truncate(at),
            }
        }
        load_anything(bytes);
    }
}

fn limited(limits: Limits) -> LoadOptions {
    LoadOptions { read: ReadOptions { limits, ..Default::default() }, frame: None }
}

fn error_text(bytes: Vec<u8>, options: &LoadOptions) -> String {
    match load_bytes("limits.rib", bytes, options) {
        Ok(_) => panic!("expected an error"),
        Err(e) => e.render(),
    }
}

#[test]
fn nesting_depth_is_limited() {
    let text = "WorldBegin ".to_string() + &"AttributeBegin ".repeat(200);
    let e = error_text(text.into_bytes(), &limited(Limits { max_nesting_depth: 100, ..Limits::default() }));
    assert!(e.contains("blocks nested deeper than the limit of 100"), "{e}");
}

#[test]
fn solid_nesting_depth_is_limited() {
    // SolidBegin opens no attribute block, so it is counted on its own.
    let text = "WorldBegin ".to_string() + &"SolidBegin \"union\" ".repeat(200);
    let e = error_text(text.into_bytes(), &limited(Limits { max_nesting_depth: 100, ..Limits::default() }));
    assert!(e.contains("SolidBegin blocks nested deeper than the limit of 100"), "{e}");
    let balanced = "WorldBegin ".to_string() + &"SolidBegin \"union\" SolidEnd ".repeat(200) + "WorldEnd";
    let options = limited(Limits { max_nesting_depth: 100, ..Limits::default() });
    assert!(load_bytes("limits.rib", balanced.into_bytes(), &options).is_ok());
}

#[test]
fn array_length_is_limited() {
    let text = format!("WorldBegin Polygon \"P\" [{}] WorldEnd", "0 ".repeat(1000));
    let e = error_text(text.into_bytes(), &limited(Limits { max_array_len: 999, ..Limits::default() }));
    assert!(e.contains("array longer than the limit of 999 values"), "{e}");
    // A binary array announcing 4 billion floats is refused before anything is allocated.
    let e = error_text(vec![b'[', 0xcb, 0xff, 0xff, 0xff, 0xff, b']'], &LoadOptions::default());
    assert!(e.contains("binary float array of 4294967295 values cut short"), "{e}");
}

#[test]
fn decompressed_size_is_limited() {
    use flate2::{Compression, write::GzEncoder};
    use std::io::Write;
    // 16 MB of spaces compress to a few kB: a small gzip bomb.
    let mut enc = GzEncoder::new(Vec::new(), Compression::best());
    enc.write_all(&vec![b' '; 16 << 20]).unwrap();
    let bomb = enc.finish().unwrap();
    assert!(bomb.len() < 100_000);
    let e = error_text(bomb, &limited(Limits { max_total_bytes: 1 << 20, ..Limits::default() }));
    assert!(e.contains("would exceed the limit of 1048576 bytes of RIB input"), "{e}");
}

/// A file system with an endless chain of archives: `a0.rib` reads `a1.rib`, ...
#[derive(Debug)]
struct EndlessChain;

impl FileSystem for EndlessChain {
    fn read(&self, path: &Path) -> io::Result<Vec<u8>> {
        let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("a0");
        let n: u64 = name.trim_start_matches('a').parse().unwrap_or(0);
        Ok(format!("Sphere 1 -1 1 360\nReadArchive \"a{}.rib\"\n", n + 1).into_bytes())
    }

    fn is_file(&self, _path: &Path) -> bool {
        true
    }
}

#[test]
fn archive_depth_is_limited() {
    let options = LoadOptions {
        read: ReadOptions {
            limits: Limits { max_archive_depth: 20, ..Limits::default() },
            file_system: Arc::new(EndlessChain),
        },
        frame: None,
    };
    let e = error_text(b"WorldBegin ReadArchive \"a0.rib\" WorldEnd".to_vec(), &options);
    assert!(e.contains("is nested deeper than the limit of 20 archives"), "{e}");
}

/// Archives 30 deep that each read the next one twice: 2^30 spheres, stopped by the byte
/// budget rather than running for hours.
#[derive(Debug)]
struct Doubling;

impl FileSystem for Doubling {
    fn read(&self, path: &Path) -> io::Result<Vec<u8>> {
        let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("d0");
        let n: u64 = name.trim_start_matches('d').parse().unwrap_or(0);
        if n >= 30 {
            return Ok(b"Sphere 1 -1 1 360\n".to_vec());
        }
        Ok(format!("Sphere 1 -1 1 360\nReadArchive \"d{0}.rib\"\nReadArchive \"d{0}.rib\"\n", n + 1)
            .into_bytes())
    }

    fn is_file(&self, _path: &Path) -> bool {
        true
    }
}

#[test]
fn exponential_archive_trees_hit_the_byte_budget() {
    let options = LoadOptions {
        read: ReadOptions {
            limits: Limits { max_total_bytes: 1 << 20, ..Limits::default() },
            file_system: Arc::new(Doubling),
        },
        frame: None,
    };
    let e = error_text(b"WorldBegin ReadArchive \"d0.rib\" WorldEnd".to_vec(), &options);
    assert!(e.contains("would exceed the limit of 1048576 bytes of RIB input"), "{e}");
}

#[test]
fn too_many_errors_stop_parsing() {
    let text = "WorldBegin ".to_string() + &"Sides 7\n".repeat(500) + "WorldEnd";
    let e = error_text(text.into_bytes(), &LoadOptions::default());
    assert!(e.contains("too many errors (100); stopping"), "{e}");
    assert_eq!(e.matches("Sides must be 1 or 2").count(), 100);
}
