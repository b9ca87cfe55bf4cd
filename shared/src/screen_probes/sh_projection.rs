//! ProjectScreenProbes: a probe's 64 cells projected onto order-2 SH (9 coefficients per colour),
//! from which per-pixel interpolation reads irradiance (`crate::sh::ShL2Rgb::irradiance`).
//!
//! One workgroup of 64 lanes per probe tile. Lane = cell: [`cell_sh_terms`] writes the cell's 9
//! terms `radiance × Y_i(direction of the cell centre) × CELL_SOLID_ANGLE` into workgroup memory
//! (entry [`sh_term_index`]); barrier; lanes `0..9` each sum one coefficient over the 64 cells
//! in cell order ([`sum_sh_coefficient`]), so the GPU and [`project_probe`] add in the same
//! order. Each cell weighs its true solid angle `2π / 64` (the reference uses `1/8`).

use glam::Vec3;

use super::LANES;
use super::hemisphere::{CELL_SOLID_ANGLE, ProbeFrame};
use super::{PROBE_CELLS, cell_is_filled, cell_radiance};
use crate::sh::{SH_COEFFICIENT_COUNT, sh9_basis};

/// Workgroup-memory entries of the projection: one per coefficient per cell.
pub const SH_TERMS: usize = SH_COEFFICIENT_COUNT * LANES;

/// Where cell `cell`'s term of coefficient `coefficient` lives in workgroup memory.
#[inline]
pub fn sh_term_index(coefficient: u32, cell: u32) -> usize {
    (coefficient * PROBE_CELLS + cell) as usize
}

/// Lane = cell `index` of the probe with frame `frame`: its 9 terms `[r, g, b, 0]`, in the order
/// of [`sh9_basis`], of the world direction through the cell's centre; zeros for an empty cell.
#[inline]
pub fn cell_sh_terms(
    frame: &ProbeFrame,
    index: u32,
    cell: [f32; 4],
) -> [[f32; 4]; SH_COEFFICIENT_COUNT] {
    let mut terms = [[0.0; 4]; SH_COEFFICIENT_COUNT];
    if !cell_is_filled(cell) {
        return terms;
    }
    let radiance = cell_radiance(cell);
    let basis = sh9_basis(frame.cell_direction(index));
    let mut i = 0;
    while i < SH_COEFFICIENT_COUNT {
        terms[i] = (radiance * (basis[i] * CELL_SOLID_ANGLE))
            .extend(0.0)
            .to_array();
        i += 1;
    }
    terms
}

/// Lane `coefficient < 9`: the coefficient, the sum of the 64 cells' terms in cell order.
#[inline]
pub fn sum_sh_coefficient(terms: &[[f32; 4]; SH_TERMS], coefficient: u32) -> [f32; 4] {
    let mut sum = Vec3::ZERO;
    let mut cell = 0;
    while cell < PROBE_CELLS {
        let i = sh_term_index(coefficient, cell);
        if i < SH_TERMS {
            let t = terms[i];
            sum += Vec3::new(t[0], t[1], t[2]);
        }
        cell += 1;
    }
    sum.extend(0.0).to_array()
}

/// The CPU model of one ProjectScreenProbes workgroup: the 9 coefficients `[r, g, b, 0]` of the
/// probe with frame `frame` (`hemisphere::record_frame` of its record) and its 64 `cells`,
/// summed in the kernel's order.
pub fn project_probe(frame: &ProbeFrame, cells: &[[f32; 4]]) -> [[f32; 4]; SH_COEFFICIENT_COUNT] {
    let mut terms = [[0.0; 4]; SH_TERMS];
    let mut cell = 0;
    while cell < PROBE_CELLS && (cell as usize) < cells.len() {
        let t = cell_sh_terms(frame, cell, cells[cell as usize]);
        let mut i = 0;
        while i < SH_COEFFICIENT_COUNT {
            terms[sh_term_index(i as u32, cell)] = t[i];
            i += 1;
        }
        cell += 1;
    }
    let mut out = [[0.0; 4]; SH_COEFFICIENT_COUNT];
    let mut i = 0;
    while i < SH_COEFFICIENT_COUNT {
        out[i] = sum_sh_coefficient(&terms, i as u32);
        i += 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::PI;
    use crate::screen_probes::{EMPTY, make_cell};
    use crate::sh::ShL2Rgb;

    fn sh(coefficients: [[f32; 4]; 9]) -> ShL2Rgb {
        ShL2Rgb {
            coefficients: coefficients.map(|c| Vec3::new(c[0], c[1], c[2])),
        }
    }

    fn frame(n: Vec3) -> ProbeFrame {
        ProbeFrame {
            position: Vec3::ZERO,
            normal: n.normalize(),
        }
    }

    /// Bound on the relative irradiance error at the normal for uniform radiance over the
    /// hemisphere. The exact order-2 projection gives exactly π L there (the band-limit error is
    /// 0: band 2 of a hemisphere step has no zonal term), so all of the error is the 64-cell
    /// centre-point quadrature. Measured: +2.104 % for every normal (the cells turn with the
    /// frame): +1.5625 % from band 1 (Σ z_centre × 2π/64 = π (1 + 1/32)) and +0.54 % from the
    /// band-2 zonal term the quadrature does not cancel.
    const UNIFORM_BOUND: f32 = 0.0215;

    #[test]
    fn uniform_radiance_gives_pi_l_at_the_normal() {
        let l = Vec3::new(0.5, 1.0, 2.0);
        let cells = [make_cell(l, 1.0); 64];
        let mut worst = 0.0f32;
        for n in [
            Vec3::Z,
            Vec3::X,
            -Vec3::Y,
            Vec3::new(0.3, -0.5, 0.8),
            Vec3::new(-1.0, 2.0, -0.1),
        ] {
            let f = frame(n);
            let e = sh(project_probe(&f, &cells)).irradiance(f.normal);
            let expected = l * PI;
            let error = ((e - expected) / expected).abs().max_element();
            worst = worst.max(error);
            // The ambient term alone is exact: 64 cells × 2π/64 × Y00 × L.
            let c = project_probe(&f, &cells)[0];
            assert!((c[0] - 2.0 * PI * 0.282_094_8 * l.x).abs() < 1e-5);
            assert_eq!(c[3], 0.0);
        }
        assert!(worst < UNIFORM_BOUND, "relative error {worst}");
        assert!(worst > 0.02, "the quadrature error is known: {worst}");
        // The far side gets nothing: irradiance at −n is π L (1/2 − 1/2) = 0 in exact order 2;
        // the quadrature leaves −1.02 % of π L (measured).
        let f = frame(Vec3::Z);
        let back = sh(project_probe(&f, &cells)).irradiance(-Vec3::Z) / (l * PI);
        assert!(back.abs().max_element() < 0.011, "{back}");
    }

    #[test]
    fn projection_matches_add_sample_and_skips_empty_cells() {
        let f = frame(Vec3::new(0.2, 0.7, -0.4));
        let mut cells = [EMPTY; 64];
        let mut reference = ShL2Rgb::ZERO;
        for c in 0..64u32 {
            if c % 5 != 0 {
                let r = Vec3::new(c as f32, 1.0, 0.5 * c as f32);
                cells[c as usize] = make_cell(r, 2.0);
                reference.add_sample(f.cell_direction(c), r, CELL_SOLID_ANGLE);
            }
        }
        let got = sh(project_probe(&f, &cells));
        for i in 0..9 {
            let d = (got.coefficients[i] - reference.coefficients[i])
                .abs()
                .max_element();
            assert!(d < 1e-3, "coefficient {i}: {d}");
        }
        assert_eq!(project_probe(&f, &[EMPTY; 64]), [[0.0; 4]; 9]);
        // A probe lit from one side gives more irradiance on that side.
        let mut side = [EMPTY; 64];
        for c in 0..64u32 {
            let lit = f.cell_direction(c).dot(Vec3::X) > 0.0;
            side[c as usize] = make_cell(Vec3::splat(if lit { 1.0 } else { 0.0 }), 1.0);
        }
        let s = sh(project_probe(&f, &side));
        let toward = (f.normal + Vec3::X).normalize();
        let away = (f.normal - Vec3::X).normalize();
        assert!(s.irradiance(toward).x > 2.0 * s.irradiance(away).x);
    }
}
