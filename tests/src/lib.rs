//! Support for the integration tests: contexts with validation on, the check that it stayed
//! silent, and the check that long-lived buffers are device-local.

use gi_host::image_io::HdrImage;
use gi_host::scene::{Instance, Light, Material, Mesh, Scene};
use gi_host::vulkan::{BufferInfo, Context, ContextOptions, MemoryLocation};
use gi_host::{KernelVariant, TraceMode};
use glam::{Mat4, Vec3, Vec4};

/// A context on the test device with the validation layer on, running `variant`.
pub fn context(variant: KernelVariant) -> Context {
    let trace = match variant {
        KernelVariant::RayQuery => TraceMode::RayQuery,
        KernelVariant::Software => TraceMode::Software,
    };
    let ctx = Context::new(&ContextOptions {
        validation: true,
        device: None,
        trace,
    })
    .unwrap_or_else(|e| panic!("cannot open a Vulkan device for {variant} kernels: {e}"));
    assert_eq!(ctx.variant(), variant);
    ctx
}

/// The kernel variants the test device runs, in [`KernelVariant::ALL`]'s order: software BVH
/// traversal always, ray queries where the device has them. A device without them (GPUs without
/// ray tracing, e.g. NVIDIA's H100 and H200) says so, and a test then checks the software
/// variant alone; lavapipe, the suite's device in CI, must have them (Mesa >= 25, which
/// `scripts/setup.sh` installs), so there nothing is skipped.
pub fn variants() -> Vec<KernelVariant> {
    static RAY_QUERY: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let ray_query = *RAY_QUERY.get_or_init(|| {
        let probe = Context::new(&ContextOptions {
            validation: false,
            device: None,
            trace: TraceMode::Auto,
        })
        .unwrap_or_else(|e| panic!("cannot open a Vulkan device: {e}"));
        let has = probe.variant() == KernelVariant::RayQuery;
        let name = probe.capabilities().name.clone();
        assert!(
            has || !name.contains("llvmpipe"),
            "{name} lacks ray queries: the suite needs Mesa >= 25's lavapipe (scripts/setup.sh)"
        );
        if !has {
            println!("{name} lacks ray queries: testing the software BVH traversal kernels only");
        }
        has
    });
    KernelVariant::ALL
        .into_iter()
        .filter(|&v| ray_query || v == KernelVariant::Software)
        .collect()
}

/// Whether `ctx`'s device runs kernels with the CPU's arithmetic: a CPU device (lavapipe), which
/// neither fuses a product and a sum into an FMA nor flushes denormals, nor takes liberties with
/// infinities and NaN. A GPU may do all three (Vulkan allows it: NVIDIA's do), so checks that a
/// kernel equals the CPU bit for bit hold on such a device only; elsewhere the tests hold the
/// device to Vulkan's precision.
pub fn computes_like_the_cpu(ctx: &Context) -> bool {
    ctx.capabilities().device_type == ash::vk::PhysicalDeviceType::CPU
}

/// The fastest variant the test device runs ([`variants`]' last): ray queries where it has
/// them. For references and checks that need one variant only.
pub fn fastest_variant() -> KernelVariant {
    *variants()
        .last()
        .expect("software traversal runs everywhere")
}

/// Destroys `ctx` and fails the test on any validation warning or error, leaks included.
pub fn finish_without_validation_messages(ctx: Context) {
    let messages = ctx.finish().expect("tests always run with validation on");
    assert!(
        messages.is_empty(),
        "{} validation messages:\n{}",
        messages.len(),
        messages.join("\n")
    );
}

/// Path of a file under the repository's `scenes/`.
pub fn scene_path(file: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scenes")
        .join(file)
}

/// The scene `file` of the repository's `scenes/`, loaded (its warnings dropped).
pub fn load_scene(file: &str) -> Scene {
    Scene::load(scene_path(file))
        .unwrap_or_else(|e| panic!("{file}: {e}"))
        .0
}

/// The committed path-traced reference of `scene` (e.g. `cornell-box`) at `side`×`side`
/// (`tests/data/reference/`, written by `bash scripts/references.sh`).
pub fn reference_image(scene: &str, side: u32) -> HdrImage {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data/reference")
        .join(format!("{scene}-{side}.exr"));
    HdrImage::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Path of a file under `../shared/scenes/third-party/` beside the repository (never copied into
/// it). Tests that use it carry
/// `#[cfg_attr(not(third_party_scenes), ignore = "...")]` (set by `tests/build.rs`).
pub fn third_party_scene_path(file: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/scenes/third-party")
        .join(file)
}

/// Fails unless every buffer of `live` (a [`Context::live_buffers`] snapshot) asked for
/// device-local memory, except the small parameter and staging buffers named in
/// `host_visible`. The message lists every offender with its size and location.
pub fn assert_device_local_except(live: &[BufferInfo], host_visible: &[&str]) {
    let offenders: Vec<String> = live
        .iter()
        .filter(|b| {
            b.location != MemoryLocation::GpuOnly && !host_visible.contains(&b.name.as_str())
        })
        .map(|b| format!("{:?}: {} bytes in {:?}", b.name, b.bytes, b.location))
        .collect();
    assert!(
        offenders.is_empty(),
        "buffers in host-visible memory that are not parameters or staging:\n{}",
        offenders.join("\n")
    );
}

/// A scene of quads (each `[corner, edge u, edge v]`, wound towards `u × v`) with one material
/// per quad.
pub fn quad_scene(
    name: &str,
    quads: &[[Vec3; 3]],
    materials: Vec<Material>,
    lights: Vec<Light>,
) -> Scene {
    let mut mesh = Mesh {
        name: name.to_owned(),
        ..Default::default()
    };
    for (i, [o, u, v]) in quads.iter().enumerate() {
        let n = u.cross(*v).normalize();
        let base = mesh.positions.len() as u32;
        mesh.positions.extend([*o, *o + *u, *o + *u + *v, *o + *v]);
        mesh.normals.extend([n; 4]);
        mesh.triangles
            .extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
        mesh.materials
            .extend([i.min(materials.len() - 1) as u32; 2]);
    }
    let instance = Instance {
        name: name.to_owned(),
        node: 0,
        mesh: 0,
        transform: Mat4::IDENTITY,
    };
    Scene::from_parts(name, vec![mesh], vec![instance], materials, vec![], lights)
}

/// A Lambertian material of grey `albedo` emitting `emission` (grey).
pub fn lambertian(albedo: f32, emission: f32) -> Material {
    Material {
        base_color: Vec4::new(albedo, albedo, albedo, 1.0),
        emissive: Vec3::splat(emission),
        metallic: 0.0,
        ..Default::default()
    }
}

/// A closed cube `[-1, 1]³` of albedo `albedo` emitting `emission` inwards on every face. Faces
/// are wound alternately inwards and outwards; those wound outwards are double-sided, so that
/// every face emits inwards: both the front-face and the double-sided rule are exercised, and
/// every surface is shaded from its inner side whatever its winding.
pub fn furnace(albedo: f32, emission: f32) -> Scene {
    let quads = [
        [Vec3::new(-1.0, -1.0, -1.0), Vec3::X * 2.0, Vec3::Y * 2.0],
        [Vec3::new(-1.0, -1.0, 1.0), Vec3::X * 2.0, Vec3::Y * 2.0],
        [Vec3::new(-1.0, -1.0, -1.0), Vec3::Z * 2.0, Vec3::X * 2.0],
        [Vec3::new(-1.0, 1.0, -1.0), Vec3::Z * 2.0, Vec3::X * 2.0],
        [Vec3::new(-1.0, -1.0, -1.0), Vec3::Y * 2.0, Vec3::Z * 2.0],
        [Vec3::new(1.0, -1.0, -1.0), Vec3::Y * 2.0, Vec3::Z * 2.0],
    ];
    let inwards = lambertian(albedo, emission);
    let outwards = Material {
        double_sided: true,
        ..inwards.clone()
    };
    let materials = (0..6)
        .map(|i| if i % 2 == 0 { &inwards } else { &outwards }.clone())
        .collect();
    quad_scene("furnace", &quads, materials, vec![])
}
