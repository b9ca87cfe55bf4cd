//! The whole chain on a real Vulkan device (lavapipe in CI): rust-gpu SPIR-V, pipelines, push
//! descriptors, dispatch, read-back, acceleration structures and ray queries.

use gi_host::KernelVariant;
use gi_host::vulkan::{
    AccelerationStructure, Buffer, DescriptorSet, Instance, Kernel, KernelModule, Resource,
    SHADING_BINDINGS, SceneSet, SceneSets, SplitBuffer, TEXTURES_BINDING, TRIANGLES_BINDING,
    TopLevel, VERTICES_BINDING,
};
use gi_shared::abi::WORKGROUP_SIZE;
use gi_shared::finite_check::FiniteCheckPush;
use gi_shared::ray::{HitRecord, Ray};
use gi_tests::{context, finish_without_validation_messages, variants};

#[test]
fn smoke_dispatch_matches_cpu_in_both_variants() {
    for variant in variants() {
        let ctx = context(variant);
        let report = gi_host::smoke::run(&ctx, 1000).unwrap();
        assert_eq!(report.invocations, 1000);
        assert_eq!(report.mismatches, 0, "{variant}");
        finish_without_validation_messages(ctx);
    }
}

#[test]
fn both_variants_declare_their_entry_points() {
    let sw = KernelVariant::Software.entry_points();
    let rq = KernelVariant::RayQuery.entry_points();
    for entries in [&sw, &rq] {
        for name in [
            "smoke::smoke",
            "difftest::difftest",
            "trace_rays::trace_rays",
            "gbuffer::gbuffer",
            "path_tracer::path_tracer",
        ] {
            assert!(
                entries.iter().any(|e| e == name),
                "{name} missing: {entries:?}"
            );
        }
    }
    assert_eq!(sw.len(), rq.len(), "the variants differ in entry points");
    // Only the kernels that trace are built with ray queries.
    let tracing = gi_host::kernels::entry_points(&KernelVariant::RayQuery.tracing_spirv_words());
    assert!(tracing.iter().all(|e| gi_host::kernels::traces(e)));
    assert!(!tracing.iter().any(|e| e == "smoke::smoke"), "{tracing:?}");
}

gi_host::bindings! {
    /// `trace_rays::trace_rays`'s set 0, as the kernel declares it.
    struct TraceRays<'a> {
        rays: &'a Buffer,
        hits: &'a Buffer,
    }
}

gi_host::bindings! {
    /// `finite_check::count_non_finite`'s set 0.
    struct CountNonFinite<'a> {
        words: &'a Buffer,
        counts: &'a Buffer,
    }
}

gi_host::bindings! {
    /// The same bindings, swapped: the kernel reads `rays` at binding 0.
    struct Swapped<'a> {
        hits: &'a Buffer,
        rays: &'a Buffer,
    }
}

gi_host::bindings! {
    /// `hits` left out.
    struct Missing<'a> {
        rays: &'a Buffer,
    }
}

gi_host::bindings! {
    /// `hits` bound as an image.
    struct WrongKind<'a> {
        rays: &'a Buffer,
        hits: &'a gi_host::vulkan::Image,
    }
}

/// A set 0 the host declares differently from the kernel is refused when the pipeline is made,
/// with the kernel and the binding named: a swapped pair, a missing binding, a wrong kind.
#[test]
fn bindings_that_are_not_the_kernels_are_refused_at_pipeline_creation() {
    let ctx = context(KernelVariant::Software);
    let module = KernelModule::new(&ctx).unwrap();
    let entry = "trace_rays::trace_rays";
    let swapped = Kernel::new::<Swapped>(&ctx, &module, entry, 0).err();
    let missing = Kernel::new::<Missing>(&ctx, &module, entry, 0).err();
    let wrong = Kernel::new::<WrongKind>(&ctx, &module, entry, 0).err();
    let message = |e: Option<gi_host::Error>| e.map(|e| e.to_string()).unwrap_or_default();
    assert_eq!(
        message(swapped),
        "invalid argument kernel bindings: kernel trace_rays::trace_rays: binding 0 is `rays` in \
         the kernel, the host declares `hits` in its place (swapped?)"
    );
    assert_eq!(
        message(missing),
        "invalid argument kernel bindings: kernel trace_rays::trace_rays: binding 1 `hits` \
         (storage buffer) is not bound by the host"
    );
    assert_eq!(
        message(wrong),
        "invalid argument kernel bindings: kernel trace_rays::trace_rays: binding 1 `hits` is a \
         storage buffer in the kernel, the host binds a storage image"
    );
    // The kernel's own declaration makes a pipeline.
    assert!(Kernel::new::<TraceRays>(&ctx, &module, entry, 0).is_ok());
    drop(module);
    finish_without_validation_messages(ctx);
}

#[test]
fn missing_entry_point_is_a_clear_error() {
    let ctx = context(KernelVariant::Software);
    let module = KernelModule::new(&ctx).unwrap();
    let err = Kernel::new::<TraceRays>(&ctx, &module, "no_such::kernel", 0)
        .err()
        .expect("there is no such kernel");
    assert!(err.to_string().contains("no_such::kernel"), "{err}");
    drop(module);
    finish_without_validation_messages(ctx);
}

#[test]
fn resources_free_themselves_whenever_they_are_dropped() {
    let ctx = context(KernelVariant::Software);
    let early = Buffer::device_zeroed::<u32>(&ctx, "early", 4).unwrap();
    let late = Buffer::device_zeroed::<u32>(&ctx, "late", 4).unwrap();
    drop(early);
    assert_eq!(ctx.live_buffers().len(), 1);
    // A resource alive at `finish` would hide its own destruction from the check: it is reported.
    let messages = ctx.finish().expect("tests always run with validation on");
    assert!(
        messages.len() == 1 && messages[0].contains("outlived Context::finish"),
        "{messages:?}"
    );
    // The device and instance go with it, after the context.
    drop(late);
}

/// Two instances of a two-triangle mesh: a unit quad in z = 0 (instance 7) and the same quad
/// moved to z = -2 (instance 9).
#[test]
fn ray_queries_hit_the_expected_triangles() {
    if !variants().contains(&KernelVariant::RayQuery) {
        return; // `variants` said why
    }
    let ctx = context(KernelVariant::RayQuery);
    let vertices = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    let indices = [0, 1, 2, 0, 2, 3];
    let blas = AccelerationStructure::triangles(&ctx, &vertices, &indices, false).unwrap();
    let identity = |z: f32| {
        [
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, z],
        ]
    };
    let tlas = TopLevel::new(
        &ctx,
        &[
            Instance {
                blas: &blas,
                transform: identity(0.0),
                custom_index: 7,
            },
            Instance {
                blas: &blas,
                transform: identity(-2.0),
                custom_index: 9,
            },
        ],
    )
    .unwrap();

    let down = |x: f32, y: f32, t_max: f32| Ray {
        origin: [x, y, 1.0],
        t_min: 0.0,
        direction: [0.0, 0.0, -1.0],
        t_max,
    };
    let rays = [
        down(0.75, 0.25, 100.0), // first triangle of the top quad, from above
        down(0.25, 0.75, 100.0), // second triangle
        down(0.25, 0.75, 0.5),   // stops short of everything
        down(2.0, 2.0, 100.0),   // misses beside the quads
        Ray {
            origin: [0.25, 0.75, -1.0],
            t_min: 0.0,
            direction: [0.0, 0.0, -2.0],
            t_max: 100.0,
        }, // lower quad, t in units of |d|
        Ray {
            origin: [0.75, 0.25, -1.0],
            t_min: 0.0,
            direction: [0.0, 0.0, 1.0],
            t_max: 100.0,
        }, // top quad from below
    ];
    let expected = [
        (7, 0, 1.0, 1),
        (7, 1, 1.0, 1),
        (u32::MAX, u32::MAX, f32::INFINITY, 0),
        (u32::MAX, u32::MAX, f32::INFINITY, 0),
        (9, 1, 0.5, 1),
        (7, 0, 1.0, 0),
    ];
    let ray_buf = Buffer::device_local(&ctx, "rays", &rays, Default::default()).unwrap();
    let hit_buf = Buffer::device_zeroed::<HitRecord>(&ctx, "hits", rays.len()).unwrap();
    let module = KernelModule::new(&ctx).unwrap();
    let kernel = Kernel::new::<TraceRays>(&ctx, &module, "trace_rays::trace_rays", 0).unwrap();
    drop(module);
    let geometry = DescriptorSet::new(
        &ctx,
        SceneSet::Geometry,
        &[Resource::AccelerationStructure(tlas.handle())],
    )
    .unwrap();
    let bindings = TraceRays {
        rays: &ray_buf,
        hits: &hit_buf,
    };
    let groups = [(rays.len() as u32).div_ceil(WORKGROUP_SIZE), 1, 1];
    // A kernel that traces needs the scene, and only it takes one.
    let err = ctx
        .submit(|cmd| kernel.dispatch(&ctx, cmd, &bindings, &[], groups))
        .unwrap()
        .unwrap_err();
    assert!(err.to_string().contains("dispatch_traced"), "{err}");
    // The shading data a kernel that traces binds too: nothing here reads it.
    let placeholder = Buffer::device_zeroed::<[u32; 4]>(&ctx, "placeholder", 1).unwrap();
    let empty = SplitBuffer::device_local::<[u32; 4]>(&ctx, "placeholder", &[], 1 << 20).unwrap();
    let mut shading_data = [Resource::Buffer(&placeholder); SHADING_BINDINGS];
    shading_data[TEXTURES_BINDING] = Resource::Textures(&[]);
    shading_data[VERTICES_BINDING] = Resource::Split(&empty);
    shading_data[TRIANGLES_BINDING] = Resource::Split(&empty);
    let shading = DescriptorSet::new(&ctx, SceneSet::Shading, &shading_data).unwrap();
    let scene = SceneSets {
        geometry: &geometry,
        shading: &shading,
    };
    ctx.submit(|cmd| {
        kernel
            .dispatch_traced(&ctx, cmd, scene, &bindings, &[], groups)
            .unwrap();
        gi_host::vulkan::compute_barrier(&ctx, cmd);
    })
    .unwrap();
    let hits = hit_buf.read_back::<HitRecord>(&ctx).unwrap();
    for (i, (hit, (instance, primitive, t, front))) in hits.iter().zip(expected).enumerate() {
        assert_eq!(
            (hit.instance, hit.primitive),
            (instance, primitive),
            "ray {i}: {hit:?}"
        );
        if hit.is_hit() {
            assert!(
                (hit.t - t).abs() < 1e-5,
                "ray {i}: t = {} expected {t}",
                hit.t
            );
            assert_eq!(hit.front_face, front, "ray {i}: {hit:?}");
            // Rebuild the hit point from barycentrics and check it lies under the ray.
            let tri = &indices[primitive as usize * 3..primitive as usize * 3 + 3];
            let [u, v] = hit.barycentrics;
            let p = |k: usize| {
                (1.0 - u - v) * vertices[tri[0] as usize][k]
                    + u * vertices[tri[1] as usize][k]
                    + v * vertices[tri[2] as usize][k]
            };
            let ray = rays[i];
            assert!(
                (p(0) - ray.origin[0]).abs() < 1e-5 && (p(1) - ray.origin[1]).abs() < 1e-5,
                "ray {i}: barycentrics {u},{v}"
            );
        } else {
            assert_eq!(hit.t, f32::INFINITY, "ray {i}");
        }
    }
    drop(kernel);
    drop(geometry);
    drop(shading);
    drop(placeholder);
    drop(empty);
    drop(ray_buf);
    drop(hit_buf);
    drop(tlas);
    drop(blas);
    finish_without_validation_messages(ctx);
}

/// The validation layer's synchronization checks are on: a kernel that reads a buffer right
/// after a fill, with no barrier between them, is reported as a hazard (the rest of the GPU
/// suite runs with the same checks, and must stay silent).
#[test]
fn a_missing_barrier_is_reported() {
    let ctx = context(KernelVariant::Software);
    let module = KernelModule::new(&ctx).unwrap();
    let kernel = Kernel::new::<CountNonFinite>(
        &ctx,
        &module,
        gi_host::frame::FiniteCheck::ENTRY,
        std::mem::size_of::<FiniteCheckPush>() as u32,
    )
    .unwrap();
    let words = Buffer::device_zeroed::<f32>(&ctx, "filled words", 64).unwrap();
    let counts = Buffer::device_zeroed::<u32>(&ctx, "counts", 1).unwrap();
    let push = FiniteCheckPush {
        word_count: 64,
        record_words: 1,
        float_mask: 1,
        slot: 0,
    };
    ctx.submit(|cmd| {
        words.record_fill_zero(&ctx, cmd);
        // No transfer barrier here: the read-after-write hazard under test.
        kernel.dispatch(
            &ctx,
            cmd,
            &CountNonFinite {
                words: &words,
                counts: &counts,
            },
            bytemuck::bytes_of(&push),
            [1, 1, 1],
        )
    })
    .unwrap()
    .unwrap();
    drop((kernel, module, words, counts));
    let messages = ctx.finish().unwrap();
    assert!(
        messages.iter().any(|m| m.contains("SYNC-HAZARD-READ")),
        "no hazard reported: {messages:?}"
    );
}
