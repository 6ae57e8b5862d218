//! Every positive finite `f32` through the fast writer and the fast reader, against std.
//! Heavy (2^31 values, minutes): run by `cargo xtask depth-exhaustive`; the unit tests in
//! `float_text.rs` check a sample in the normal suite.

use depth_remap::float_text::{parse_f32_token, push_f32, push_f32_std};

#[test]
#[ignore = "minutes of work: run by `cargo xtask depth-exhaustive`"]
fn every_f32_is_written_like_std_and_read_back_exactly() {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()) as u32;
    let end = 0x7f80_0000u32; // +inf
    let per_thread = end.div_ceil(threads);
    let failures: Vec<String> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                scope.spawn(move || {
                    let mut failures = Vec::new();
                    let (mut fast, mut slow) = (Vec::with_capacity(32), Vec::with_capacity(32));
                    for bits in t * per_thread..((t + 1) * per_thread).min(end) {
                        let v = f32::from_bits(bits);
                        fast.clear();
                        slow.clear();
                        push_f32(&mut fast, v);
                        push_f32_std(&mut slow, v);
                        let (parsed, length) = parse_f32_token(&fast);
                        if fast != slow || parsed != Ok(v) || length != fast.len() {
                            failures.push(format!(
                                "{bits:#x}: fast {:?}, std {:?}, read back {parsed:?}",
                                String::from_utf8_lossy(&fast),
                                String::from_utf8_lossy(&slow)
                            ));
                            if failures.len() > 20 {
                                break;
                            }
                        }
                    }
                    failures
                })
            })
            .collect();
        handles.into_iter().flat_map(|h| h.join().unwrap()).collect()
    });
    assert!(failures.is_empty(), "{} failures:\n{}", failures.len(), failures.join("\n"));
}
