//! Throughput of the functions every probe ray runs: the hash-cell descriptor, the probe direction
//! maps and half-float packing.

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use gi_shared::hash_cells::layout::HashGridParams;
use gi_shared::hash_cells::{DEFAULT_CELL_SIZE_PIXELS, cell_descriptor, cell_size_const};
use gi_shared::octahedral::{
    equal_area_hemi_decode, equal_area_hemi_encode, octahedral_decode, octahedral_encode,
};
use gi_shared::packing::{f16_to_f32, f32_to_f16, pack_radiance_half};
use gi_shared::random::Random;
use gi_shared::sampling::sample_uniform_sphere;
use glam::{Vec2, Vec3};

/// Inputs per iteration: large enough to amortise the loop, small enough to stay in L1.
const BATCH: usize = 1024;

fn directions(rng: &mut Random) -> Vec<Vec3> {
    (0..BATCH)
        .map(|_| sample_uniform_sphere(rng.next_vec2()))
        .collect()
}

fn bench_cell_descriptor(c: &mut Criterion) {
    let mut rng = Random::new(1, 0);
    let csc = cell_size_const(60f32.to_radians(), 1920, 1080, DEFAULT_CELL_SIZE_PIXELS);
    let params = HashGridParams::new(Vec3::new(1.0, 2.0, 3.0), csc, 0);
    let dirs = directions(&mut rng);
    let hits: Vec<(Vec3, f32)> = dirs
        .iter()
        .map(|&d| {
            let t = rng.next_f32() * 20.0;
            (params.eye() + d * t, t)
        })
        .collect();
    let mut group = c.benchmark_group("hash_cells");
    group.throughput(Throughput::Elements(BATCH as u64));
    group.bench_function("cell_descriptor", |b| {
        b.iter(|| {
            let mut acc = 0u32;
            for (&(p, t), &d) in hits.iter().zip(&dirs) {
                let desc = cell_descriptor(params.eye(), black_box(p), d, t, &params);
                acc = acc.wrapping_add(desc.bucket ^ desc.checksum);
            }
            acc
        })
    });
    group.finish();
}

fn bench_octahedral(c: &mut Criterion) {
    let mut rng = Random::new(2, 0);
    let dirs = directions(&mut rng);
    let hemi: Vec<Vec3> = dirs.iter().map(|d| d.with_z(d.z.abs())).collect();
    let squares: Vec<Vec2> = dirs.iter().map(|_| rng.next_vec2() * 2.0 - 1.0).collect();
    let mut group = c.benchmark_group("octahedral");
    group.throughput(Throughput::Elements(BATCH as u64));
    group.bench_function("octahedral_encode", |b| {
        b.iter(|| {
            dirs.iter()
                .map(|&d| octahedral_encode(black_box(d)))
                .sum::<Vec2>()
        })
    });
    group.bench_function("octahedral_decode", |b| {
        b.iter(|| {
            squares
                .iter()
                .map(|&e| octahedral_decode(black_box(e)))
                .sum::<Vec3>()
        })
    });
    group.bench_function("equal_area_hemi_encode", |b| {
        b.iter(|| {
            hemi.iter()
                .map(|&d| equal_area_hemi_encode(black_box(d)))
                .sum::<Vec2>()
        })
    });
    group.bench_function("equal_area_hemi_decode", |b| {
        b.iter(|| {
            squares
                .iter()
                .map(|&e| equal_area_hemi_decode(black_box(e)))
                .sum::<Vec3>()
        })
    });
    group.finish();
}

fn bench_half(c: &mut Criterion) {
    let mut rng = Random::new(3, 0);
    // Radiance-like values over many binades, including some beyond the half range.
    let values: Vec<f32> = (0..BATCH)
        .map(|_| (rng.next_f32() * 40.0 - 20.0).exp2())
        .collect();
    let halves: Vec<u32> = (0..BATCH as u32).map(|i| i.wrapping_mul(64)).collect();
    let mut group = c.benchmark_group("half");
    group.throughput(Throughput::Elements(BATCH as u64));
    group.bench_function("f32_to_f16", |b| {
        b.iter(|| {
            values
                .iter()
                .fold(0u32, |a, &x| a ^ f32_to_f16(black_box(x)))
        })
    });
    group.bench_function("pack_radiance_half", |b| {
        b.iter(|| {
            values
                .iter()
                .fold(0u32, |a, &x| a ^ pack_radiance_half(black_box(x)))
        })
    });
    group.bench_function("f16_to_f32", |b| {
        b.iter(|| {
            halves
                .iter()
                .map(|&h| f16_to_f32(black_box(h)))
                .sum::<f32>()
        })
    });
    group.finish();
}

fn config() -> Criterion {
    Criterion::default()
        .sample_size(20)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
}

// A private module keeps the `pub fn` that `criterion_group!` generates out of the documented API.
mod group {
    use super::*;
    criterion_group! {
        name = benches;
        config = config();
        targets = bench_cell_descriptor, bench_octahedral, bench_half
    }
}
criterion_main!(group::benches);
