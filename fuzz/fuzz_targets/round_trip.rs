//! Whatever scene the reader builds from the input, writing it and reading it back must work.
#![no_main]

use libfuzzer_sys::fuzz_target;
use rib_parser::{LoadOptions, load_bytes};

fuzz_target!(|data: &[u8]| {
    if let Ok(loaded) = load_bytes("fuzz.rib", data.to_vec(), &LoadOptions::default()) {
        let text = rib_parser::writer::write_scene(&loaded.scene);
        if let Err(e) = load_bytes("written.rib", text.clone().into_bytes(), &LoadOptions::default()) {
            panic!("the writer's output does not read back:\n{}\n{text}", e.render());
        }
    }
});
