//! File names of the sidecar files, derived from the depth table's or the image's path alone
//! (CONTRACTS.md §6: `hybrid-view` finds them from the DEPTH or IMAGE path).

use std::path::{Path, PathBuf};

/// Where the sidecar files of one render live.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SidecarPaths {
    /// Light layers, normal and albedo: `STEM.layers.exr`.
    pub layers: PathBuf,
    /// Irradiance probes: `STEM.probes.exr`.
    pub probes: PathBuf,
    /// Reflection probes: `STEM.reflections.exr`.
    pub reflections: PathBuf,
    /// Caustic photons and their estimates' kernels: `STEM.caustics.exr`.
    pub caustics: PathBuf,
}

impl SidecarPaths {
    /// The sidecar of the depth table at `depth`: its file name without the extension (and
    /// without a `.depth` before a final `.exr`), plus `.layers.exr` / `.probes.exr` / `.reflections.exr`, in the same
    /// directory. `out.depth` and `out.depth.exr` give `out.layers.exr`.
    pub fn for_depth(depth: &Path) -> SidecarPaths {
        SidecarPaths::from_stem(&stem_path(depth))
    }

    /// The same rule applied to the image's path: `out.tif` gives `out.layers.exr`. The viewer
    /// looks here when nothing exists next to the depth table.
    pub fn for_image(image: &Path) -> SidecarPaths {
        SidecarPaths::from_stem(&stem_path(image))
    }

    /// The places a reader looks, in order: next to the depth table, then next to the image
    /// (duplicates removed).
    pub fn candidates(image: &Path, depth: &Path) -> Vec<SidecarPaths> {
        let mut out = vec![SidecarPaths::for_depth(depth)];
        let by_image = SidecarPaths::for_image(image);
        if by_image != out[0] {
            out.push(by_image);
        }
        out
    }

    fn from_stem(stem: &Path) -> SidecarPaths {
        let with = |suffix: &str| {
            let mut name = stem.as_os_str().to_os_string();
            name.push(suffix);
            PathBuf::from(name)
        };
        SidecarPaths {
            layers: with(".layers.exr"),
            probes: with(".probes.exr"),
            reflections: with(".reflections.exr"),
            caustics: with(".caustics.exr"),
        }
    }
}

/// `path` without its last extension, and without an inner `.depth` when the last one is `.exr`.
fn stem_path(path: &Path) -> PathBuf {
    let mut stem = path.with_extension("");
    let was_exr = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    if was_exr && stem.extension().is_some_and(|e| e.eq_ignore_ascii_case("depth")) {
        stem = stem.with_extension("");
    }
    stem
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_follow_the_depth_table_and_the_image() {
        let p = SidecarPaths::for_depth(Path::new("dir/out.depth"));
        assert_eq!(p.layers, Path::new("dir/out.layers.exr"));
        assert_eq!(p.probes, Path::new("dir/out.probes.exr"));
        assert_eq!(p.reflections, Path::new("dir/out.reflections.exr"));
        assert_eq!(p.caustics, Path::new("dir/out.caustics.exr"));
        assert_eq!(SidecarPaths::for_depth(Path::new("out.depth.exr")).layers, Path::new("out.layers.exr"));
        assert_eq!(SidecarPaths::for_depth(Path::new("z.exr")).layers, Path::new("z.layers.exr"));
        assert_eq!(SidecarPaths::for_depth(Path::new("noext")).layers, Path::new("noext.layers.exr"));
        assert_eq!(SidecarPaths::for_image(Path::new("a/b.c.tiff")).layers, Path::new("a/b.c.layers.exr"));
        let c = SidecarPaths::candidates(Path::new("out.tif"), Path::new("out.depth"));
        assert_eq!(c.len(), 1);
        let c = SidecarPaths::candidates(Path::new("img.tif"), Path::new("z.depth"));
        assert_eq!(c[1].layers, Path::new("img.layers.exr"));
    }
}
