//! The depth-table file (CONTRACTS.md §2): data-driven fixtures, round trips, parallel parsing,
//! OpenEXR and atomic writes.
//!
//! Fixtures live in `fixtures/depth/{ok,err}/NNNN_name.depth`, each with `NNNN_name.expected`
//! beside it: for `ok`, the table as this crate writes it back; for `err`, the exact error
//! text. `UPDATE_EXPECT=1 cargo test -p depth-remap --test table_format` rewrites them.

use depth_remap::*;
use proptest::prelude::*;
use std::fs;
use std::path::{Path, PathBuf};

fn fixtures(kind: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/depth").join(kind);
    let mut files: Vec<PathBuf> = fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "depth"))
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no fixtures in {}", dir.display());
    files
}

fn check_expected(input: &Path, actual: &str) {
    let expected_path = input.with_extension("expected");
    if std::env::var_os("UPDATE_EXPECT").is_some() {
        fs::write(&expected_path, actual).unwrap();
        return;
    }
    let expected = fs::read_to_string(&expected_path)
        .unwrap_or_else(|e| panic!("{}: {e} (UPDATE_EXPECT=1 creates it)", expected_path.display()));
    assert_eq!(actual, expected, "{}", input.display());
}

#[test]
fn ok_fixtures_read_and_write_back() {
    for path in fixtures("ok") {
        let text = fs::read(&path).unwrap();
        let table = DepthTable::parse(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let written = String::from_utf8(table.to_text(1)).unwrap();
        check_expected(&path, &written);
        // What we write reads back to the same table, on any number of threads.
        for threads in [1, 3] {
            let options = ParseOptions { threads, ..ParseOptions::default() };
            assert_eq!(DepthTable::parse_with(written.as_bytes(), options).unwrap(), table);
        }
    }
}

#[test]
fn err_fixtures_give_the_expected_message() {
    for path in fixtures("err") {
        let text = fs::read(&path).unwrap();
        let error = DepthTable::parse(&text).expect_err(&path.display().to_string());
        check_expected(&path, &format!("{error}\n"));
        // The parallel parser reports the same place.
        let options = ParseOptions { threads: 3, ..ParseOptions::default() };
        let parallel = DepthTable::parse_with(&text, options).expect_err("parallel");
        assert_eq!(parallel.to_string(), error.to_string(), "{}", path.display());
    }
}

#[test]
fn read_errors_name_the_file() {
    let path = fixtures("err").into_iter().find(|p| p.ends_with("0004_nan.depth")).unwrap();
    let error = DepthTable::read(&path).unwrap_err();
    assert_eq!(
        error.to_string(),
        format!("{}:3:3: `nan` is not a depth (a miss is written `inf`)", path.display())
    );
    let missing = DepthTable::read("/nonexistent/x.depth").unwrap_err();
    assert!(missing.to_string().starts_with("/nonexistent/x.depth: "), "{missing}");
}

#[test]
fn size_check_names_both_sizes() {
    let table = DepthTable::all_misses(640, 480);
    assert!(table.check_size(640, 480).is_ok());
    assert_eq!(
        table.check_size(320, 240).unwrap_err().to_string(),
        "the depth table is 640x480 but the image is 320x240"
    );
}

#[test]
fn in_memory_tables_refuse_non_depths() {
    assert!(DepthTable::new(2, 1, vec![1.0, f32::NAN]).is_err());
    assert!(DepthTable::new(2, 1, vec![1.0, -1.0]).is_err());
    assert!(DepthTable::new(2, 1, vec![1.0]).is_err());
    assert!(DepthTable::new(0, 0, vec![]).is_err());
    let mut table = DepthTable::new(2, 1, vec![1.0, f32::INFINITY]).unwrap();
    assert!(!table.set(0, 0, f32::NAN));
    assert!(!table.set(2, 0, 1.0));
    assert!(table.set(1, 0, 0.0));
}

#[test]
fn parallel_parse_reports_deep_errors_at_the_right_line() {
    // 3000 rows; a bad token on row 2345 (line 2346 after the header).
    let mut table = DepthTable::all_misses(50, 3000);
    for (k, v) in (0..50 * 3000).zip(0u32..) {
        table.set(k % 50, k / 50, v as f32 * 0.37);
    }
    let mut text = String::from_utf8(table.to_text(2)).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let mut bad = lines[2345].split(' ').map(str::to_owned).collect::<Vec<_>>();
    bad[7] = "1.2.3".into();
    let column = bad[..7].iter().map(|s| s.len() + 1).sum::<usize>() + 1;
    let mut new_lines: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
    new_lines[2345] = bad.join(" ");
    text = new_lines.join("\n");
    for threads in [1, 2, 5, 16] {
        let error = DepthTable::parse_with(text.as_bytes(), ParseOptions { threads, ..Default::default() })
            .unwrap_err();
        assert_eq!(error.location, Some((2346, column as u64)), "{threads} threads: {error}");
    }
    // A short row deep inside: its row number counts data rows across chunks.
    new_lines[2345] = "1 2 3".into();
    let text = new_lines.join("\n");
    for threads in [1, 4] {
        let error = DepthTable::parse_with(text.as_bytes(), ParseOptions { threads, ..Default::default() })
            .unwrap_err();
        assert_eq!(
            error.to_string(),
            "line 2346, column 6: row 2345 has 3 values, but the header's width is 50"
        );
    }
}

#[test]
fn limits_stop_runaway_tables() {
    let limits = ReadLimits { max_pixels: 100, max_bytes: 1 << 20 };
    let options = ParseOptions { limits, threads: 1 };
    let row = ["1"; 11].join(" ");
    let text = [row.as_str(); 10].join("\n");
    let error = DepthTable::parse_with(text.as_bytes(), options).unwrap_err();
    assert!(matches!(error.kind, DepthTableErrorKind::TooLarge { .. }), "{error}");
    let small = ParseOptions { limits: ReadLimits { max_pixels: 1000, max_bytes: 10 }, threads: 1 };
    assert!(matches!(
        DepthTable::parse_with(text.as_bytes(), small).unwrap_err().kind,
        DepthTableErrorKind::TooLarge { .. }
    ));
}

fn depth_value() -> impl Strategy<Value = f32> {
    prop_oneof![
        1 => Just(f32::INFINITY),
        1 => Just(0.0f32),
        4 => (0u32..0x7f80_0000).prop_map(f32::from_bits),
        4 => 1e-3f32..1e4,
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn text_round_trip(width in 1u32..40, height in 1u32..40, seed in prop::collection::vec(depth_value(), 1..64)) {
        let values: Vec<f32> = (0..width * height).map(|k| seed[k as usize % seed.len()]).collect();
        let table = DepthTable::new(width, height, values).unwrap();
        for threads in [1, 3] {
            let text = table.to_text(threads);
            prop_assert_eq!(&text, &table.to_text(1));
            let back = DepthTable::parse_with(&text, ParseOptions { threads, ..Default::default() }).unwrap();
            prop_assert_eq!(&back, &table);
        }
    }
}

/// A scratch directory for one test, removed when the test ends.
fn temp_dir(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new().prefix(&format!("depth-remap-test-{name}-")).tempdir().unwrap()
}

#[test]
fn files_round_trip_atomically_as_text_and_exr() {
    let scratch_dir = temp_dir("files");
    let dir = scratch_dir.path();
    let mut table = DepthTable::all_misses(37, 23);
    for j in 0..23 {
        for i in 0..37 {
            if (i + j) % 5 != 0 {
                table.set(i, j, 0.1 + (i * j) as f32 * 1.37);
            }
        }
    }
    for name in ["t.depth", "t.exr", "T.EXR"] {
        let path = dir.join(name);
        fs::write(&path, b"old contents").unwrap();
        table.write(&path).unwrap();
        assert_eq!(DepthTable::read(&path).unwrap(), table, "{name}");
    }
    // No temporary files are left behind.
    let mut names: Vec<String> =
        fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
    names.sort();
    assert_eq!(names, ["T.EXR", "t.depth", "t.exr"]);
    // Writing into a missing directory fails cleanly.
    assert!(table.write(dir.join("missing/t.depth")).is_err());
}

#[test]
fn exr_without_z_or_with_nan_is_an_error() {
    use exr::prelude::*;
    let scratch_dir = temp_dir("exr");
    let dir = scratch_dir.path();
    let write = |name: &str, channel: &str, values: Vec<f32>| {
        let path = dir.join(name);
        let layer = Layer::new(
            (2, 2),
            LayerAttributes::default(),
            Encoding::UNCOMPRESSED,
            AnyChannels::sort(SmallVec::from_vec(vec![AnyChannel::new(channel, FlatSamples::F32(values))])),
        );
        Image::from_layer(layer).write().to_file(&path).unwrap();
        path
    };
    let y = write("y.exr", "Y", vec![1.0; 4]);
    let error = DepthTable::read(&y).unwrap_err();
    assert_eq!(
        error.to_string(),
        format!("{}: no `Z` channel in the OpenEXR file (channels: Y)", y.display())
    );
    let nan = write("nan.exr", "Z", vec![1.0, 2.0, f32::NAN, 3.0]);
    let error = DepthTable::read(&nan).unwrap_err();
    assert_eq!(
        error.to_string(),
        format!("{}: pixel (0, 1) holds NaN, which is not a depth (a miss is +inf)", nan.display())
    );
    let garbage = dir.join("garbage.exr");
    fs::write(&garbage, b"not an exr file").unwrap();
    assert!(DepthTable::read(&garbage).unwrap_err().to_string().starts_with(&garbage.display().to_string()));
}
