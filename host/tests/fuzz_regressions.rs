//! Inputs found while fuzzing the readers (`fuzz/`, `scripts/fuzz.sh`), each kept in
//! `tests/data/bad/fuzz-*` with the exact error or warning it must now give. CPU only.

use gi_host::Error;
use gi_host::image_io::HdrImage;
use gi_host::scene::{Scene, Warning};
use std::path::{Path, PathBuf};

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path)
}

/// Loads a scene that must fail with a scene error; returns its element and reason.
fn scene_error(path: &str) -> (String, String) {
    match Scene::load(repo(path)) {
        Ok(_) => panic!("{path} loads, but it should fail"),
        Err(Error::Scene { element, why, .. }) => (element, why),
        Err(e) => panic!("{path}: not a scene error: {e}"),
    }
}

fn load(path: &str) -> (Scene, Vec<Warning>) {
    Scene::load(repo(path)).unwrap_or_else(|e| panic!("{path} does not load: {e}"))
}

// A URI naming a device used to be read to its end: /dev/zero has none (memory ran out).
#[cfg(unix)]
#[test]
fn a_buffer_uri_naming_a_device_is_an_error() {
    let (element, why) = scene_error("tests/data/bad/fuzz-buffer-uri-device.gltf");
    assert_eq!(element, "buffers[0] (uri \"/dev/zero\")");
    assert_eq!(why, "/dev/zero is not a regular file");
}

#[cfg(unix)]
#[test]
fn an_image_uri_naming_a_device_is_a_warning_and_the_factor_is_used() {
    let (scene, warnings) = load("tests/data/bad/fuzz-image-uri-device.gltf");
    let w = warnings
        .iter()
        .find(|w| w.element == "images[0] (uri \"/dev/zero\")")
        .unwrap_or_else(|| panic!("no warning about images[0]: {warnings:#?}"));
    assert!(w.message.contains("/dev/zero is not a regular file"), "{w}");
    assert!(scene.textures.is_empty());
    assert_eq!(scene.materials[0].base_color_texture, None);
}

// The header alone sized the pixel buffer: this 369-byte file asked for over a petabyte
// (796262404 × 131378 pixels) and the allocation aborted the process.
#[test]
fn an_exr_whose_header_declares_a_huge_image_is_an_error() {
    let file = repo("tests/data/bad/fuzz-exr-huge-data-window.exr");
    match HdrImage::read(&file) {
        Ok(image) => panic!("decoded a {}x{} image", image.width(), image.height()),
        Err(Error::Image { path, why }) => {
            assert_eq!(path, file);
            assert_eq!(
                why,
                "OpenEXR layer 0 of 796262404x131378 pixels is larger than the 67108864 pixels an \
             image may have"
            );
        }
        Err(e) => panic!("not an image error: {e}"),
    }
}
