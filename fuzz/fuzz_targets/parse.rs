//! Any bytes through the whole reader (lexer, parser, scene builder), then everything that
//! renders or writes the result: nothing may panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use rib_parser::{LoadOptions, load_bytes};

fuzz_target!(|data: &[u8]| {
    match load_bytes("fuzz.rib", data.to_vec(), &LoadOptions::default()) {
        Ok(loaded) => {
            let _ = loaded.render_warnings();
            let _ = rib_parser::summary::dump(&loaded.scene);
            let _ = rib_parser::writer::write_scene(&loaded.scene);
        }
        Err(e) => {
            let _ = e.render();
        }
    }
});
