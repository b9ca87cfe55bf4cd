//! Differential testing of this crate: [`evaluate`] runs one of its functions on four raw input
//! words and returns up to eight raw output words. The `difftest` kernel runs the very same
//! function on the GPU, so a test can compare both sides bit for bit (integers) or within the
//! function's stated ulp bound (floats). Any drift between the CPU and a GPU compiler shows up
//! here before it shows up in an image.

use crate::color::luminance;
use crate::hash::{pcg, pcg_chain, xxhash32, xxhash32_chain};
use crate::hash_cells::layout::HashGridParams;
use crate::hash_cells::{CellDescriptor, cell_descriptor, cell_index};
use crate::math::unorm24;
use crate::octahedral::{
    equal_area_hemi_decode, equal_area_hemi_encode, hemi_octahedral_decode, hemi_octahedral_encode,
    octahedral_decode, octahedral_encode, probe_cell_direction, probe_direction_cell,
};
use crate::packing::{
    f16_to_f32, f32_to_f16, pack_radiance_half, pack_score_lane, pack_seed, pack_snorm10x3,
    quantize_probe_radiance, unpack_snorm10x3,
};
use crate::random::{Random, halton23, pixel_sample, radical_inverse};
use crate::reservoir::Reservoir;
use crate::sampling::{
    area_to_solid_angle_pdf, orthonormal_basis, sample_cosine_hemisphere, sample_triangle,
    sample_uniform_sphere,
};
use crate::screen_probes::hemisphere::ProbeFrame;
use crate::screen_probes::hysteresis::{apply_hysteresis, hysteresis_weight};
use crate::screen_probes::interpolate::probe_weight;
use crate::screen_probes::sh_projection::{
    SH_TERMS, cell_sh_terms, sh_term_index, sum_sh_coefficient,
};
use crate::screen_probes::{GiFrameParams, PROBE_CELLS, ProbeRecord};
use crate::sh::ShL2Rgb;
use bytemuck::{Pod, Zeroable};
use glam::{UVec2, Vec2, Vec3};

/// Output words per evaluation.
pub const OUTPUT_WORDS: usize = 8;

/// One input: four raw words, read as `f32` bits or integers as each function needs.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct DiffCase {
    /// The raw words.
    pub input: [u32; 4],
}

/// One output: eight raw words; unused words are 0.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct DiffOutput {
    /// The raw words.
    pub words: [u32; OUTPUT_WORDS],
}

/// Push constants of the `difftest` kernel.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct DiffPush {
    /// Index into [`FUNCTIONS`].
    pub function: u32,
    /// Number of cases in the input buffer.
    pub count: u32,
    /// Explicit padding to 16 bytes.
    pub _pad: [u32; 2],
}

/// How one function's outputs are compared.
pub struct FunctionInfo {
    /// Name in reports.
    pub name: &'static str,
    /// Bit `w` set: output word `w` is an `f32`, compared within the tolerance below (NaN matches
    /// NaN); clear: an integer, compared bit for bit.
    pub float_outputs: u32,
    /// Bit `w` set: integer word `w` is a float snapped to an integer (a cell index), and word
    /// `w + SNAP_SOURCE_OFFSET` holds that float before snapping. GPU and CPU may then differ by
    /// one, but only when the float lies within the tolerance of a cell boundary.
    pub snapped_outputs: u32,
    /// Allowed error relative to the CPU value.
    pub relative: f32,
    /// Allowed absolute error (for results near zero, and for GLSL.std.450's `sin`, `cos` and
    /// `atan`, which Vulkan bounds absolutely, not relatively).
    pub absolute: f32,
}

/// Where a snapped integer's source float sits, relative to the integer's word.
pub const SNAP_SOURCE_OFFSET: usize = 5;

/// One ulp of `f32` at 1.0, for the bounds below.
const ULP: f32 = f32::EPSILON;

const fn exact(name: &'static str) -> FunctionInfo {
    floats(name, 0, 0.0, 0.0)
}

const fn floats(
    name: &'static str,
    float_outputs: u32,
    relative: f32,
    absolute: f32,
) -> FunctionInfo {
    FunctionInfo {
        name,
        float_outputs,
        snapped_outputs: 0,
        relative,
        absolute,
    }
}

/// Every function under test, indexed by [`DiffPush::function`]. The bounds follow what Vulkan
/// allows a device that computes like the CPU (lavapipe): `+ - *` exact; division 2.5 ulp;
/// `sqrt` inherits `inversesqrt`'s bound (lavapipe was measured at up to 111 ulp for tiny
/// arguments, hence 2^-16 relative wherever a square root feeds the result); `sin`, `cos` and
/// `atan` only an absolute bound (2^-11 in GLSL.std.450; on lavapipe the measured worst absolute
/// error of the maps that use them is below 1e-5).
pub const FUNCTIONS: [FunctionInfo; 25] = [
    exact("hash::pcg"),
    exact("hash::xxhash32"),
    exact("hash::pcg_chain"),
    exact("hash::xxhash32_chain"),
    floats("random::Random", 0b1100, 0.0, 0.0),
    floats("random::halton", 0b11111, 0.0, 0.0),
    floats("octahedral::octahedral", 0b11111, 4.0 * ULP, 4.0 * ULP),
    floats("octahedral::hemi_octahedral", 0b11111, 4.0 * ULP, 4.0 * ULP),
    floats("octahedral::equal_area_hemi", 0b11111, 1e-5, 1e-5),
    FunctionInfo {
        snapped_outputs: 0b11,
        ..floats("octahedral::probe_cells", 0b111_1100, 1e-5, 1e-5)
    },
    floats(
        "sampling::orthonormal_basis",
        0b11_1111,
        1.0 / 65536.0,
        4.0 * ULP,
    ),
    floats("sampling::directions", 0b11_1111, 1e-5, 1e-5),
    floats(
        "sampling::triangle_and_pdf",
        0b1111,
        1.0 / 65536.0,
        4.0 * ULP,
    ),
    exact("hash_cells::cell_descriptor"),
    floats("reservoir::Reservoir", 0b1110, 4.0 * ULP, 0.0),
    floats("packing::half", 0b0100, 0.0, 0.0),
    floats("packing::snorm10x3", 0b1110, 4.0 * ULP, 0.0),
    exact("packing::seed_score"),
    exact("packing::fixed_point"),
    floats("sh::ShL2Rgb", 0b11_1111, 1e-5, 1e-4),
    floats("color", 0b11, 4.0 * ULP, 0.0),
    exact("hash_cells::cell_index"),
    // A power of 8 of a quotient: 8 × 2.5 ulp of division, plus the plane test's dot product.
    floats("screen_probes::probe_weight", 0b1, 64.0 * ULP, 1e-6),
    // 64 cells × 9 terms summed in lane order: products exact, the basis's sqrt-free
    // polynomials and the direction's decode (sin, cos, atan: absolute 1e-5).
    floats("screen_probes::project_probe", 0b111_1111, 1e-4, 1e-4),
    floats("screen_probes::hysteresis", 0b111, 16.0 * ULP, 1e-6),
];

fn f(w: u32) -> f32 {
    f32::from_bits(w)
}

fn vec3(words: [u32; 4]) -> Vec3 {
    Vec3::new(f(words[0]), f(words[1]), f(words[2]))
}

/// A unit direction from three words; NaN when they are not a usable direction.
fn direction(words: [u32; 4]) -> Vec3 {
    let v = vec3(words);
    v / v.length()
}

fn put3(out: &mut [u32; OUTPUT_WORDS], at: usize, v: Vec3) {
    out[at] = v.x.to_bits();
    out[at + 1] = v.y.to_bits();
    out[at + 2] = v.z.to_bits();
}

/// Runs function number `function` of [`FUNCTIONS`] on `input`. Unknown numbers give zeros.
pub fn evaluate(function: u32, input: [u32; 4]) -> [u32; OUTPUT_WORDS] {
    let mut o = [0u32; OUTPUT_WORDS];
    let [a, b, c, d] = input;
    match function {
        0 => o[0] = pcg(a),
        1 => o[0] = xxhash32(a),
        2 => o[0] = pcg_chain([a, b, c, d]),
        3 => o[0] = xxhash32_chain([a, b, c, d]),
        4 => {
            let mut r = Random::new(a, b);
            o[0] = r.next_u32();
            o[1] = r.next_u32();
            o[2] = r.next_f32().to_bits();
            o[3] = r.next_f32().to_bits();
        }
        5 => {
            let h = halton23(a);
            o[0] = h.x.to_bits();
            o[1] = h.y.to_bits();
            o[2] = radical_inverse(a, 2 + b % 30).to_bits();
            let p = pixel_sample(UVec2::new(c % 4096, d % 4096), a);
            o[3] = p.x.to_bits();
            o[4] = p.y.to_bits();
        }
        6..=8 => {
            let dir = direction(input);
            let (e, back) = match function {
                6 => {
                    let e = octahedral_encode(dir);
                    (e, octahedral_decode(e))
                }
                7 => {
                    let e = hemi_octahedral_encode(dir);
                    (e, hemi_octahedral_decode(e))
                }
                _ => {
                    let e = equal_area_hemi_encode(dir);
                    (e, equal_area_hemi_decode(e))
                }
            };
            o[0] = e.x.to_bits();
            o[1] = e.y.to_bits();
            put3(&mut o, 2, back);
        }
        9 => {
            let dir = direction(input);
            let cell = probe_direction_cell(dir, 8);
            o[0] = cell.x;
            o[1] = cell.y;
            put3(
                &mut o,
                2,
                probe_cell_direction(UVec2::new(d % 8, (d / 8) % 8), 8),
            );
            // The continuous coordinates the cells were snapped from.
            let scaled = (equal_area_hemi_encode(dir) * 0.5 + 0.5) * 8.0;
            o[SNAP_SOURCE_OFFSET] = scaled.x.to_bits();
            o[SNAP_SOURCE_OFFSET + 1] = scaled.y.to_bits();
        }
        10 => {
            let (t, bt) = orthonormal_basis(direction(input));
            put3(&mut o, 0, t);
            put3(&mut o, 3, bt);
        }
        11 => {
            let u = Vec2::new(unorm24(a), unorm24(b));
            put3(&mut o, 0, sample_cosine_hemisphere(u));
            put3(&mut o, 3, sample_uniform_sphere(u));
        }
        12 => {
            let bary = sample_triangle(Vec2::new(unorm24(a), unorm24(b)));
            put3(&mut o, 0, bary);
            o[3] = area_to_solid_angle_pdf(f(a), f(b), f(c)).to_bits();
        }
        13 => {
            let params = HashGridParams::new(Vec3::ZERO, f(d), 0);
            let eye = Vec3::new(f(d), 0.0, 0.0);
            let dir = Vec3::new(f(c), f(a), f(b));
            let desc: CellDescriptor = cell_descriptor(eye, vec3(input), dir, f(c), &params);
            o[0] = desc.lod as u32;
            o[1] = desc.tile[0] as u32;
            o[2] = desc.tile[1] as u32 ^ desc.tile[2] as u32;
            o[3] = desc.cell[0] | desc.cell[1] << 16;
            o[4] = desc.dir_bin[0] | desc.dir_bin[1] << 8 | desc.dir_bin[2] << 16;
            o[5] = desc.short_ray;
            o[6] = desc.bucket;
            o[7] = desc.checksum;
        }
        14 => {
            let mut r = Reservoir::EMPTY;
            let mut rng = Random::new(d, 7);
            r.update(a, f(a).abs(), rng.next_f32());
            r.update(b, f(b).abs(), rng.next_f32());
            let mut other = Reservoir::EMPTY;
            other.update(c, f(c).abs(), rng.next_f32());
            other.finalize(f(c).abs());
            r.merge(&other, f(c).abs(), rng.next_f32(), 20.0);
            r.finalize(f(r.sample).abs());
            o[0] = r.sample;
            o[1] = r.w_sum.to_bits();
            o[2] = r.m.to_bits();
            o[3] = r.ucw.to_bits();
        }
        15 => {
            o[0] = f32_to_f16(f(a));
            o[1] = pack_radiance_half(f(b));
            o[2] = f16_to_f32(c & 0xffff).to_bits();
        }
        16 => {
            let p = pack_snorm10x3(vec3(input));
            o[0] = p;
            let n = unpack_snorm10x3(d);
            o[1] = n.x.to_bits();
            o[2] = n.y.to_bits();
            o[3] = n.z.to_bits();
        }
        17 => {
            o[0] = pack_seed(UVec2::new(a, b));
            o[1] = pack_score_lane(f(c), d);
        }
        18 => {
            // Hash-cell accumulators: 64-bit fixed point, low word in 0 and high word in 2.
            let [lo, hi] = crate::fixed_point::encode(f(a));
            o[0] = lo;
            o[1] = quantize_probe_radiance(f(b));
            o[2] = hi;
        }
        19 => {
            let mut sh = ShL2Rgb::ZERO;
            let radiance = Vec3::new(unorm24(d) * 100.0, 1.0, 0.5);
            sh.add_sample(direction(input), radiance, 1.0);
            sh.add_sample(Vec3::Z, Vec3::ONE, 0.5);
            put3(&mut o, 0, sh.irradiance(Vec3::new(0.0, 0.6, 0.8)));
            put3(&mut o, 3, sh.radiance(Vec3::X));
        }
        20 => {
            o[0] = luminance(vec3(input)).to_bits();
            o[1] = hysteresis_weight([f(a), f(b)]).to_bits();
        }
        21 => o[0] = cell_index(a, b, c, d),
        22 => {
            let frame = GiFrameParams {
                probe_cell_const: 0.05,
                ..GiFrameParams::default()
            };
            let normal = direction(input);
            let position = Vec3::new(0.0, 0.0, 4.0);
            let probe = ProbeRecord {
                position: (position + Vec3::new(f(a), f(b), f(c)) * 0.05).to_array(),
                normal: pack_snorm10x3((normal + Vec3::new(0.0, 0.1, 0.0)).normalize()),
                seed: 0,
                depth: 4.0 + unorm24(d) * 0.5,
                age: 0,
                _pad: 0,
            };
            o[0] = probe_weight(&frame, position, 4.0, normal, &probe).to_bits();
        }
        23 => {
            // The projection of a probe of random cells, term by term as ProjectScreenProbes
            // sums it.
            let probe = ProbeFrame {
                position: Vec3::ZERO,
                normal: direction(input),
            };
            let mut terms = [[0.0f32; 4]; SH_TERMS];
            let mut cell = 0;
            while cell < PROBE_CELLS {
                let h = pcg(d ^ cell);
                let radiance = [unorm24(h), unorm24(h >> 4), unorm24(h >> 8), 1.0];
                let t = cell_sh_terms(&probe, cell, radiance);
                let mut k = 0;
                while k < t.len() {
                    terms[sh_term_index(k as u32, cell)] = t[k];
                    k += 1;
                }
                cell += 1;
            }
            let mut irradiance = ShL2Rgb::ZERO;
            let mut k = 0;
            while k < irradiance.coefficients.len() {
                let c = sum_sh_coefficient(&terms, k as u32);
                irradiance.coefficients[k] = Vec3::new(c[0], c[1], c[2]);
                k += 1;
            }
            put3(&mut o, 0, irradiance.irradiance(probe.normal));
            let c = irradiance.coefficients;
            put3(&mut o, 3, Vec3::new(c[0].x, c[2].y, c[6].z));
            o[6] = c[8].x.to_bits();
        }
        24 => put3(
            &mut o,
            0,
            apply_hysteresis(
                vec3(input).abs(),
                Vec3::splat(unorm24(d) * 4.0),
                hysteresis_weight([unorm24(d) * 63.0, 63.0]),
            ),
        ),
        _ => {}
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_function_writes_something_for_ordinary_input() {
        let input = [0.3f32.to_bits(), 0.4f32.to_bits(), 0.5f32.to_bits(), 5];
        for (i, info) in FUNCTIONS.iter().enumerate() {
            assert_ne!(
                evaluate(i as u32, input),
                [0; OUTPUT_WORDS],
                "{} returned nothing",
                info.name
            );
            assert!(info.float_outputs < 1 << OUTPUT_WORDS, "{}", info.name);
            assert_eq!(
                info.float_outputs & info.snapped_outputs,
                0,
                "{}",
                info.name
            );
        }
        assert_eq!(evaluate(FUNCTIONS.len() as u32, input), [0; OUTPUT_WORDS]);
    }

    #[test]
    fn layouts() {
        assert_eq!(core::mem::size_of::<DiffCase>(), 16);
        assert_eq!(core::mem::size_of::<DiffOutput>(), 32);
        assert_eq!(core::mem::size_of::<DiffPush>(), 16);
        assert_eq!(core::mem::offset_of!(DiffPush, count), 4);
    }
}
