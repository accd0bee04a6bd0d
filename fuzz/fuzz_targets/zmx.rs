//! The Zemax `.zmx` reader: any bytes give a spec or an error (never a panic), and a spec it accepts
//! builds a lens with finite first-order data and finite traced rays, or is refused.
#![no_main]

mod common;

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Ok(loaded) = unicac_optics::format::zmx::parse(data, Path::new("fuzz.zmx")) {
        common::check_spec(&loaded.spec);
    }
});
