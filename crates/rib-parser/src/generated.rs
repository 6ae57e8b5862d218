//! Generated RIB inputs for benchmarks (`cargo xtask bench-parse`, `cargo xtask bench-check`):
//! a large polygon mesh written the way exporters of scanned models write one.

use std::fmt::Write;

/// An n x n grid of vertices as one `PointsPolygons` of quads, with normals, written like an
/// exporter writes it (six decimals, one face per line).
pub fn mesh_rib(target_bytes: usize) -> Vec<u8> {
    // About 85 bytes per vertex (P, N, a quad's indices and count): solve for n.
    let n = ((target_bytes as f64 / 85.0).sqrt() as usize).max(2);
    let mut s = String::with_capacity(target_bytes + 1024);
    s.push_str("##RenderMan RIB\nFormat 640 480 1\nProjection \"perspective\" \"fov\" [40]\nTranslate 0 0 5\nWorldBegin\n");
    s.push_str("PointsPolygons [");
    for _ in 0..(n - 1) * (n - 1) {
        s.push_str("4 ");
    }
    s.push_str("]\n[");
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = j * n + i;
            let _ = writeln!(s, "{} {} {} {}", a, a + 1, a + n + 1, a + n);
        }
    }
    s.push_str("]\n\"P\" [");
    for j in 0..n {
        for i in 0..n {
            let (x, y) = (i as f64 / n as f64 - 0.5, j as f64 / n as f64 - 0.5);
            let z = 0.1 * (7.0 * x).sin() * (5.0 * y).cos();
            let _ = writeln!(s, "{x:.6} {y:.6} {z:.6}");
        }
    }
    s.push_str("]\n\"N\" [");
    for _ in 0..n * n {
        s.push_str("0.000000 0.000000 1.000000\n");
    }
    s.push_str("]\nWorldEnd\n");
    s.into_bytes()
}
