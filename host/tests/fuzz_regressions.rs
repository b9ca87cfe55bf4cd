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

/// A small deterministic generator (xorshift64*) for the mutations below.
struct Mutations(u64);

impl Mutations {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    /// Mutants of `seed`: cut at 16 lengths, and 48 copies with 1–8 bytes set at random places to
    /// random values or to the extremes (0, 0xff, 0x7f, 0x80) that break sizes and counts.
    fn of(&mut self, seed: &[u8]) -> Vec<Vec<u8>> {
        let mut mutants: Vec<Vec<u8>> = (0..16)
            .map(|k| seed[..seed.len() * k / 16].to_vec())
            .collect();
        for _ in 0..48 {
            let mut m = seed.to_vec();
            if m.is_empty() {
                break;
            }
            for _ in 0..1 + self.next() % 8 {
                let at = (self.next() % m.len() as u64) as usize;
                m[at] = match self.next() % 6 {
                    0 => 0,
                    1 => 0xff,
                    2 => 0x7f,
                    3 => 0x80,
                    _ => self.next() as u8,
                };
            }
            mutants.push(m);
        }
        mutants
    }
}

/// Every file of `dirs` (not recursing), sorted.
fn seeds(dirs: &[&str]) -> Vec<(PathBuf, Vec<u8>)> {
    let mut files: Vec<PathBuf> = dirs
        .iter()
        .flat_map(|d| std::fs::read_dir(repo(d)).unwrap_or_else(|e| panic!("{d}: {e}")))
        .map(|entry| entry.expect("directory entry").path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    files
        .into_iter()
        .map(|p| {
            let bytes = std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            (p, bytes)
        })
        .collect()
}

/// Replays a fuzz target's seeds (the directories `scripts/fuzz.sh` gives it) and 64 mutants of
/// each through the target's own entry point: CI exercises the readers on broken inputs in every
/// test run without a fuzzing build. `accepted` bounds how many seeds must still load, so the
/// test notices seeds that stopped reaching the readers' deeper paths.
fn replay(target: fn(&[u8]) -> bool, dirs: &[&str], accepted_seeds: usize) {
    let mut mutations = Mutations(0x9e37_79b9_7f4a_7c15);
    let seeds = seeds(dirs);
    let accepted = seeds.iter().filter(|(_, bytes)| target(bytes)).count();
    assert!(
        accepted >= accepted_seeds,
        "only {accepted} of {} seeds in {dirs:?} are accepted",
        seeds.len()
    );
    let (mut mutants, mut loaded) = (0, 0);
    for (path, bytes) in &seeds {
        for mutant in mutations.of(bytes) {
            // A panic fails the test and names the seed; the result itself may be either.
            let result = std::panic::catch_unwind(|| target(&mutant));
            assert!(result.is_ok(), "a mutant of {} panics", path.display());
            mutants += 1;
            loaded += usize::from(matches!(result, Ok(true)));
        }
    }
    println!(
        "{dirs:?}: {accepted} of {} seeds accepted; {mutants} mutants, {loaded} accepted",
        seeds.len()
    );
}

#[test]
fn scene_seeds_and_their_mutants_load_or_fail_cleanly() {
    replay(
        gi_host::fuzzing::scene,
        &["scenes", "tests/data", "tests/data/bad"],
        8,
    );
}

#[test]
fn texture_seeds_and_their_mutants_decode_or_fail_cleanly() {
    replay(gi_host::fuzzing::texture, &["fuzz/seeds/texture"], 10);
}

#[test]
fn environment_seeds_and_their_mutants_decode_or_fail_cleanly() {
    replay(
        gi_host::fuzzing::environment,
        &["fuzz/seeds/environment"],
        3,
    );
}
