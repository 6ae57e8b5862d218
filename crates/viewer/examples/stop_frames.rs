//! The frames after the cursor sphere stops, one by one, in the frame bench's rooms
//! (`benches/rooms`): what `fullscreen-lit-stop-worst-*` times as its dearest frame, without
//! the bench binary's minutes of building every group's compositors first.
//!
//! `cargo run --release -p viewer --example stop_frames -- [near] [glossy] [--rounds N]
//! [--passes]` (run with `XDG_RUNTIME_DIR` set where lavapipe wants one). It times the plain
//! frame (the median of 12), then per room and round moves the sphere `STOP_MOVES` frames and
//! times each frame at rest until the frame is kept, in CPU time of the process, and prints the
//! dearest against the plain frame. With `--passes`, the last round's frames are timed pass by
//! pass (`Compositor::set_pass_timing`, which waits after each pass, so they run slower): each
//! frame's passes of 3 ms or more, then each pass's total over the round.

#[allow(dead_code)]
#[path = "../benches/rooms/mod.rs"]
mod rooms;

use rooms::{
    STOP_FRAMES, STOP_MOVES, bind_room_scene, lit_room, room, sphere_at, stop_frames_with_reflections,
};
use std::time::Duration;
use viewer::{Backends, Compositor, CompositorSettings, Gpu};

/// The process's CPU time, every thread counted (lavapipe's rasteriser threads do the GPU's work).
fn cpu_now() -> Duration {
    viewer::compositor::process_cpu_time().expect("the process's CPU time (Unix)")
}

/// The CPU time since `from`, in ms.
fn cpu_ms(from: Duration) -> f64 {
    cpu_now().saturating_sub(from).as_secs_f64() * 1e3
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let passes = args.iter().any(|a| a == "--passes");
    let rounds: usize = args
        .iter()
        .position(|a| a == "--rounds")
        .and_then(|k| args.get(k + 1))
        .map(|n| n.parse().expect("--rounds takes a number"))
        .unwrap_or(2);
    let named: Vec<&str> =
        args.iter().map(String::as_str).filter(|a| *a == "near" || *a == "glossy").collect();
    let wanted = |room: &str| named.is_empty() || named.contains(&room);

    let gpu = Gpu::new(Backends::default()).expect("a GPU adapter (lavapipe: cargo xtask install-test-deps)");
    let plain = room(512);
    let keep_off = CompositorSettings { keep_frame_at_rest: false, ..CompositorSettings::default() };
    let mut compositor = Compositor::new(&gpu, &plain, keep_off).expect("compositor");
    let mut plain_ms: Vec<f64> = (0..12)
        .map(|_| {
            let start = cpu_now();
            compositor.render(&sphere_at(0)).expect("render");
            compositor.wait_idle().expect("wait");
            cpu_ms(start)
        })
        .collect();
    plain_ms.sort_by(f64::total_cmp);
    let plain_median = plain_ms[6];
    println!(
        "plain frame: median {plain_median:.1} ms of CPU (12 frames, {:.1} to {:.1})",
        plain_ms[0], plain_ms[11]
    );
    drop(compositor);

    // As `hybrid-view` draws by default, and as the bench's stop frames.
    let settings = CompositorSettings {
        amortise_while_moving: true,
        settle_at_rest: true,
        keep_frame_at_rest: true,
        ..CompositorSettings::default()
    };
    let (mut near, mut glossy) = (lit_room(512, false), lit_room(512, true));
    bind_room_scene(&mut near, true, false);
    bind_room_scene(&mut glossy, true, true);
    let glossy_frames = stop_frames_with_reflections(&glossy);
    for (scene, name, stop_frames) in [(&near, "near", STOP_FRAMES), (&glossy, "glossy", glossy_frames)] {
        if !wanted(name) {
            continue;
        }
        let mut compositor = Compositor::new(&gpu, scene, settings).expect("compositor");
        compositor.render(&sphere_at(0)).expect("render");
        compositor.wait_idle().expect("wait");
        let mut frame = 0;
        for round in 0..rounds {
            let timed = passes && round + 1 == rounds;
            for _ in 0..STOP_MOVES {
                frame += 1;
                compositor.render(&sphere_at(frame)).expect("render");
                compositor.wait_idle().expect("wait");
            }
            compositor.set_pass_timing(timed);
            let mut before = compositor.pass_times().0;
            let mut times = Vec::with_capacity(stop_frames);
            for k in 0..stop_frames {
                let start = cpu_now();
                compositor.render(&sphere_at(frame)).expect("render");
                compositor.wait_idle().expect("wait");
                times.push(cpu_ms(start));
                if timed {
                    let after = compositor.pass_times().0;
                    let mut parts: Vec<(f64, &str)> = after
                        .iter()
                        .map(|a| {
                            let earlier = before.iter().find(|b| b.pass == a.pass).and_then(|b| b.cpu);
                            let cpu = a.cpu.unwrap_or_default().saturating_sub(earlier.unwrap_or_default());
                            (cpu.as_secs_f64() * 1e3, a.pass)
                        })
                        .filter(|(ms, _)| *ms >= 3.0)
                        .collect();
                    parts.sort_by(|a, b| b.0.total_cmp(&a.0));
                    let parts: Vec<String> =
                        parts.iter().map(|(ms, pass)| format!("{pass} {ms:.0}")).collect();
                    println!("{name} frame {k:3}: {:6.1} ms | {}", times[k], parts.join(", "));
                    before = after;
                }
            }
            compositor.set_pass_timing(false);
            if timed {
                let (totals, _) = compositor.pass_times();
                for t in &totals {
                    let ms = t.cpu.unwrap_or_default().as_secs_f64() * 1e3;
                    println!("{name} total: {} {ms:.0} ms over {} frames", t.pass, t.frames);
                }
            }
            let (worst_at, worst) =
                times.iter().copied().enumerate().max_by(|a, b| a.1.total_cmp(&b.1)).unwrap_or((0, 0.0));
            let each: Vec<String> = times.iter().map(|t| format!("{t:.0}")).collect();
            println!(
                "{name} round {round}: dearest frame {worst_at} after the stop, {worst:.1} ms ({:.2} plain frames); each, ms: {}",
                worst / plain_median,
                each.join(" ")
            );
        }
    }
}
