//! The image loader (PNG, TIFF, OpenEXR through `unicac_image::io::decode_image`, the code behind
//! `read_image`): any bytes decode or give an error, never a panic or an unbounded allocation; a
//! decoded image has the buffer its header promises.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Ok(loaded) = unicac_image::io::decode_image(Path::new("fuzz.img"), data) {
        let image = &loaded.image;
        assert_eq!(image.data.len(), image.width * image.height * image.channels);
        assert_eq!(loaded.channel_names.len(), image.channels);
        let _ = loaded.to_linear();
    }
});
