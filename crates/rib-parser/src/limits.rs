//! Limits that keep hostile or broken input from running away with memory or time.
//!
//! The parser's memory is proportional to its input (every array element costs at least two
//! input bytes, binary array lengths are checked against the bytes left), so the limits below
//! bound the input itself: total bytes read (archives and decompressed gzip included), the depth
//! of archive and block nesting, and the image size.

/// Configurable limits; [`Limits::default`] suits any real scene.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Total RIB bytes read in one run, after decompression, archives included.
    pub max_total_bytes: u64,
    /// `ReadArchive` / `DelayedReadArchive` nesting depth.
    pub max_archive_depth: usize,
    /// Nesting depth of `AttributeBegin`, `TransformBegin`, `FrameBegin`, ... blocks.
    pub max_nesting_depth: usize,
    /// Elements in one array.
    pub max_array_len: usize,
    /// Pixels of the image (`Format` x * y).
    pub max_image_pixels: u64,
    /// Pixels along one image axis.
    pub max_image_side: u32,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_total_bytes: default_total_bytes(),
            max_archive_depth: 64,
            max_nesting_depth: 10_000,
            max_array_len: 1 << 30,
            max_image_pixels: 1 << 30,
            max_image_side: 1 << 17,
        }
    }
}

/// Half the memory the system says is available (at most 16 GiB, at least 256 MiB), since the
/// parsed scene needs about as much memory again as its text.
fn default_total_bytes() -> u64 {
    const MIB: u64 = 1 << 20;
    let available = std::fs::read_to_string("/proc/meminfo").ok().and_then(|info| {
        info.lines()
            .find(|l| l.starts_with("MemAvailable:"))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|kib| kib.parse::<u64>().ok())
            .map(|kib| kib * 1024)
    });
    available.map_or(4096 * MIB, |a| a / 2).clamp(256 * MIB, 16384 * MIB)
}
