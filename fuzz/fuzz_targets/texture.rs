//! The texture decoders (PNG, JPEG, KTX2, DDS, recognised by their content) on arbitrary bytes,
//! as the loader calls them for a base colour or emissive (sRGB) texture.
#![no_main]

use gi_host::scene::texture_files;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = texture_files::decode(data, true);
});
