//! The unicac lens JSON reader: any bytes give a spec or an error naming the line, never a panic; an
//! accepted spec builds a finite lens or is refused.
#![no_main]

mod common;

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Ok(spec) = unicac_optics::format::json::parse(data, Path::new("fuzz.json")) {
        common::check_spec(&spec);
    }
});
