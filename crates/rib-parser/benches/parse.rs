//! Parse throughput (RIB bytes per second, one core, parse + scene build).
//!
//! - a generated 50 MB ASCII `PointsPolygons` mesh (the shape of exported scanned models);
//! - the same mesh in binary RIB;
//! - the corpus's largest files (dragonhead: 1,236 bicubic patches; killeroo: 89 NuPatches;
//!   bikeData: 5,216 patches, decompressed from gzip; sdsbunny: one subdivision mesh with
//!   facevarying data).
//!
//! Run with `cargo xtask bench-parse` (or `cargo bench -p rib-parser --bench parse`).
//!
//! Time is the benchmark thread's CPU time (`CLOCK_THREAD_CPUTIME_ID`), not wall time: the
//! development machine is shared by several builds at once, and CPU time is what one core
//! spends on parsing whatever else runs.

use criterion::measurement::{Measurement, ValueFormatter};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use rib_parser::{LoadOptions, load_bytes};
use std::hint::black_box;

const CORPUS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/rib-corpus");

/// The same mesh in binary RIB: encoded requests, binary float arrays for P and N.
fn mesh_binary(n: usize) -> Vec<u8> {
    let mut b = Vec::new();
    b.extend_from_slice(b"WorldBegin\n");
    b.extend_from_slice(b"PointsPolygons [");
    for _ in 0..(n - 1) * (n - 1) {
        b.extend_from_slice(b"4 ");
    }
    b.extend_from_slice(b"] [");
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = (j * n + i) as u32;
            for v in [a, a + 1, a + n as u32 + 1, a + n as u32] {
                b.push(0x83);
                b.extend_from_slice(&v.to_be_bytes());
            }
        }
    }
    b.extend_from_slice(b"] \"P\" ");
    let count = (3 * n * n) as u32;
    b.push(0xcb);
    b.extend_from_slice(&count.to_be_bytes());
    for j in 0..n {
        for i in 0..n {
            let (x, y) = (i as f32 / n as f32 - 0.5, j as f32 / n as f32 - 0.5);
            for v in [x, y, 0.0f32] {
                b.extend_from_slice(&v.to_be_bytes());
            }
        }
    }
    b.extend_from_slice(b"\nWorldEnd\n");
    b
}

/// A corpus file; fragments (archives without a world) are wrapped in one.
fn corpus(path: &str, wrap: bool) -> Vec<u8> {
    let raw = std::fs::read(format!("{CORPUS}/{path}")).unwrap_or_else(|e| panic!("{path}: {e}"));
    let (bytes, _) = rib_parser::source::decode(raw, u64::MAX).expect("decodable");
    if !wrap {
        return bytes;
    }
    let mut out = b"WorldBegin\n".to_vec();
    out.extend_from_slice(&bytes);
    out.extend_from_slice(b"\nWorldEnd\n");
    out
}

/// CPU time of the calling thread.
struct ThreadCpuTime;

fn thread_cpu_ns() -> u64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: `ts` is a valid, writable timespec; the clock id is a constant Linux provides.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    assert_eq!(rc, 0, "clock_gettime(CLOCK_THREAD_CPUTIME_ID) failed");
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

impl Measurement for ThreadCpuTime {
    type Intermediate = u64;
    type Value = u64;

    fn start(&self) -> u64 {
        thread_cpu_ns()
    }

    fn end(&self, start: u64) -> u64 {
        thread_cpu_ns().saturating_sub(start)
    }

    fn add(&self, a: &u64, b: &u64) -> u64 {
        a + b
    }

    fn zero(&self) -> u64 {
        0
    }

    fn to_f64(&self, v: &u64) -> f64 {
        *v as f64
    }

    fn formatter(&self) -> &dyn ValueFormatter {
        &CpuFormatter
    }
}

/// Milliseconds of CPU time, and throughput in MB/s (10^6 bytes).
struct CpuFormatter;

impl ValueFormatter for CpuFormatter {
    fn scale_values(&self, _typical_ns: f64, values: &mut [f64]) -> &'static str {
        for v in values {
            *v /= 1e6;
        }
        "ms (cpu)"
    }

    fn scale_throughputs(&self, _typical: f64, throughput: &Throughput, values: &mut [f64]) -> &'static str {
        let bytes = match *throughput {
            Throughput::Bytes(b) | Throughput::BytesDecimal(b) => b as f64,
            Throughput::Elements(e) => e as f64,
        };
        for v in values {
            *v = bytes * 1e3 / *v;
        }
        "MB/s (cpu)"
    }

    fn scale_for_machines(&self, _values: &mut [f64]) -> &'static str {
        "ns"
    }
}

fn bench(c: &mut Criterion<ThreadCpuTime>) {
    let mut inputs: Vec<(&str, Vec<u8>)> =
        vec![("mesh_50MB_ascii", rib_parser::generated::mesh_rib(50 << 20))];
    inputs.push(("mesh_binary", mesh_binary(1200)));
    inputs
        .push(("dragonhead", corpus("dpasca__RibTools/DistribSrc__base__TestScenes__dragonhead.rib", false)));
    inputs.push((
        "killeroo",
        corpus("dpasca__RibTools/DistribSrc__base__TestScenes__KillerooNURBS__killeroo.rib", false),
    ));
    inputs.push((
        "bikeData_unzipped",
        corpus("aqsis__aqsis/examples__features__archives__bikeData.rib.gz", true),
    ));
    inputs.push(("sdsbunny", corpus("aqsis__aqsis/testing__regression__RIBs__Scenes__sdsbunny.rib", true)));
    let mut group = c.benchmark_group("parse");
    group.sample_size(10);
    for (name, bytes) in &inputs {
        eprintln!("input {name}: {} bytes", bytes.len());
        // Every input must really build a scene, or the figure means nothing.
        load_bytes(name, bytes.clone(), &LoadOptions::default())
            .unwrap_or_else(|e| panic!("{name}: {}", e.render()));
        group.throughput(Throughput::Bytes(bytes.len() as u64));
        group.bench_function(*name, |b| {
            b.iter(|| {
                load_bytes(name, black_box(bytes.clone()), &LoadOptions::default())
                    .map(|l| l.scene.shapes.len())
            })
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().with_measurement(ThreadCpuTime);
    targets = bench
}
criterion_main!(benches);
