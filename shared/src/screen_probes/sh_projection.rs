//! ProjectScreenProbes: a probe's 64 cells projected onto order-2 SH (9 coefficients per colour),
//! from which per-pixel interpolation reads irradiance (`crate::sh::ShL2Rgb::irradiance`).
//!
//! One workgroup of 64 lanes per probe tile. Lane = cell: [`cell_sh_terms`] writes the cell's 9
//! terms `radiance × ∫_cell Y_i(ω) dω` into workgroup memory (entry [`sh_term_index`]); barrier;
//! lanes `0..9` each sum one coefficient over the 64 cells in cell order
//! ([`sum_sh_coefficient`]), so the GPU and [`project_probe`] add in the same order.
//!
//! Each cell is integrated over its own solid angle, not sampled at its centre: a centre sample
//! times `2π / 64` read +2.1 % irradiance for a uniform hemisphere. The map is equal-area, so the
//! cells need no Jacobian (each is exactly `2π / 64` sr, [`CELL_SOLID_ANGLE`]), but `Y_i` varies
//! across a cell and the map creases along the square's diagonals, which run along the diagonal
//! of the 16 cells `x == y` and `x + y == 7`. [`cell_basis_integrals`] cuts every cell into two
//! triangles along that diagonal (the anti-diagonal for the others) and integrates each with a
//! degree-4 rule of 6 positive weights ([`cell_node`]): 12 directions per lane. `z` and `z²` are
//! polynomials of degree 2 and 4 of the map's coordinates on each triangle, so the zonal terms, and
//! with them the irradiance of uniform radiance at the normal, are exact up to f32 rounding.

use glam::{Vec2, Vec3};

use super::LANES;
use super::hemisphere::{CELL_SOLID_ANGLE, ProbeFrame, cell_coords, tangent_direction_in_cell};
use super::{PROBE_CELLS, cell_is_filled, cell_radiance};
use crate::sh::{SH_COEFFICIENT_COUNT, sh9_basis};

/// Workgroup-memory entries of the projection: one per coefficient per cell.
pub const SH_TERMS: usize = SH_COEFFICIENT_COUNT * LANES;

/// Quadrature nodes of one cell ([`cell_node`]): 2 triangles × 6 points, so 12 decodes and
/// basis evaluations per lane.
///
/// Why this rule: a cell's `∫ Y_i` errs at most 7.2e-5 × [`CELL_SOLID_ANGLE`] (the 4 cells at the
/// pole, where the map is conical), 2.3e-6 × elsewhere (f64, against a 16²-fold subdivision of each
/// triangle; the tests measure 7.4e-5 against an independent brute force). Sub-cell centres give
/// less for more, the crease costing them their cancellation: 4 × 4 of them take 16 directions
/// and err 5.1e-3 × (+0.13 % uniform irradiance). A 3-point rule per triangle (6 directions)
/// errs 6.5e-4 ×, a 7-point degree-5 one (14) 6.1e-5 ×.
pub const CELL_NODES: u32 = 12;

/// Points of the half cell `u.x ≥ u.y` (the triangle `(0, 0), (1, 0), (1, 1)` of `u ∈ [0, 1]²`)
/// of Dunavant's degree-4 rule (1985, "High degree efficient symmetrical Gaussian quadrature rules
/// for the triangle"): the barycentric orbits `(0.108103018, 0.445948491, 0.445948491)` and
/// `(0.816847573, 0.091576214, 0.091576214)`.
const HALF_CELL_NODES: [[f32; 2]; 6] = [
    [0.891_896_98, 0.445_948_49],
    [0.554_051_5, 0.445_948_49],
    [0.554_051_5, 0.108_103_018],
    [0.183_152_42, 0.091_576_21],
    [0.908_423_8, 0.091_576_21],
    [0.908_423_8, 0.816_847_57],
];

/// Weights of [`HALF_CELL_NODES`] as fractions of the cell: Dunavant's weights (0.223381590 and
/// 0.109951744, summing to 1 over the triangle) halved, the triangle being half the cell. The 12
/// sum to 1 (f32: 1 + 7e-9).
const HALF_CELL_WEIGHTS: [f32; 6] = [
    0.111_690_8,
    0.111_690_8,
    0.111_690_8,
    0.054_975_87,
    0.054_975_87,
    0.054_975_87,
];

/// Where cell `cell`'s term of coefficient `coefficient` lives in workgroup memory.
#[inline]
pub fn sh_term_index(coefficient: u32, cell: u32) -> usize {
    (coefficient * PROBE_CELLS + cell) as usize
}

/// Quadrature node `node < CELL_NODES` of cell `index`: its point `u ∈ [0, 1]²` in the cell (as
/// `ProbeFrame::direction_in_cell` takes it) and its weight, the solid angle it stands for
/// (positive; a cell's 12 sum to [`CELL_SOLID_ANGLE`]). Nodes `0..6` lie on one side of the
/// cell's split diagonal, `6..12` are their mirror images across it; the split follows the map's
/// crease: the main diagonal in cells `x == y`, the anti-diagonal in all others.
#[inline]
pub fn cell_node(index: u32, node: u32) -> (Vec2, f32) {
    let k = (node % 6) as usize;
    let p = HALF_CELL_NODES[k];
    let mut u = if node < 6 {
        Vec2::new(p[0], p[1])
    } else {
        Vec2::new(p[1], p[0])
    };
    let c = cell_coords(index);
    if c.x != c.y {
        u.x = 1.0 - u.x;
    }
    (u, HALF_CELL_WEIGHTS[k] * CELL_SOLID_ANGLE)
}

/// `∫_cell Y_i(ω) dω` of cell `index` of the probe with frame `frame`, in world directions, in
/// the order of [`sh9_basis`]: the [`CELL_NODES`] nodes of [`cell_node`] summed in node order.
#[inline]
pub fn cell_basis_integrals(frame: &ProbeFrame, index: u32) -> [f32; SH_COEFFICIENT_COUNT] {
    let mut sum = [0.0; SH_COEFFICIENT_COUNT];
    let mut node = 0;
    while node < CELL_NODES {
        let (u, weight) = cell_node(index, node);
        let basis = sh9_basis(frame.direction_in_cell(index, u));
        let mut i = 0;
        while i < SH_COEFFICIENT_COUNT {
            sum[i] += basis[i] * weight;
            i += 1;
        }
        node += 1;
    }
    sum
}

/// The mean cosine to the probe's normal over cell `index`, `∫_cell cos θ dω / CELL_SOLID_ANGLE`,
/// from the nodes of [`cell_basis_integrals`] (exact up to f32 rounding: `cos θ` is of degree 2 on
/// each half cell). From 0.16 (the rim's corner cells) to 0.97 (the four at the pole); the
/// cosine weight of a probe ray ([`cosine_weight`]) divides by it.
#[inline]
pub fn cell_mean_cosine(index: u32) -> f32 {
    let mut sum = 0.0;
    let mut node = 0;
    while node < CELL_NODES {
        let (u, weight) = cell_node(index, node);
        sum += tangent_direction_in_cell(index, u).z * weight;
        node += 1;
    }
    sum / CELL_SOLID_ANGLE
}

/// The weight a probe ray's radiance takes in its cell: its cosine to the probe's normal over the
/// cell's mean cosine ([`cell_mean_cosine`]), `direction_z` being the ray's direction in the
/// probe's tangent frame (`hemisphere::tangent_direction_in_cell`). A cell then holds
/// `∫_cell L cos / ∫_cell cos` rather than the mean of `L`, so that its irradiance at the probe's
/// normal is exact whatever the light's place inside it. Without the weight, light that arrives
/// at grazing angles (a lit floor seen from a wall, light under a door) counted at the mean cosine
/// of its rim cell, up to 4 times its own (cells span `cos θ` from 0 to 0.44 there): a band of
/// radiance below `cos θ = 0.1` read 4.3 times its irradiance, a patch within 10° of the horizon
/// 2.1 times.
#[inline]
pub fn cosine_weight(index: u32, direction_z: f32) -> f32 {
    let mean = cell_mean_cosine(index);
    if mean > 0.0 && direction_z > 0.0 {
        direction_z / mean
    } else {
        0.0
    }
}

/// Lane = cell `index` of the probe with frame `frame`: its 9 terms `[r, g, b, 0]`, in the order
/// of [`sh9_basis`], `radiance × ∫_cell Y_i` ([`cell_basis_integrals`]); zeros for an empty cell.
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
    let integrals = cell_basis_integrals(frame, index);
    let mut i = 0;
    while i < SH_COEFFICIENT_COUNT {
        terms[i] = (radiance * integrals[i]).extend(0.0).to_array();
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
    use glam::DVec3;

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

    /// Normals along the six axes and tilted ones.
    fn normals() -> [Vec3; 9] {
        [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            -Vec3::X,
            Vec3::Y,
            -Vec3::Y,
            Vec3::new(0.3, -0.5, 0.8),
            Vec3::new(-1.0, 2.0, -0.1),
            Vec3::new(0.2, 0.7, -0.4),
        ]
    }

    /// The cells' mean cosines integrate the cosine lobe: `Σ cos̄ × 2π / 64 = π`, and they span
    /// the range the doc states.
    #[test]
    fn cell_mean_cosines_sum_to_the_cosine_lobe() {
        let sum: f64 = (0..PROBE_CELLS)
            .map(|c| f64::from(cell_mean_cosine(c) * CELL_SOLID_ANGLE))
            .sum();
        assert!((sum / core::f64::consts::PI - 1.0).abs() < 1e-6, "{sum}");
        let (lo, hi) = (0..PROBE_CELLS)
            .map(cell_mean_cosine)
            .fold((1.0f32, 0.0f32), |(lo, hi), c| (lo.min(c), hi.max(c)));
        eprintln!("mean cosines {lo} to {hi}");
        assert!(
            (0.15..0.16).contains(&lo) && (0.96..0.97).contains(&hi),
            "{lo} {hi}"
        );
        assert_eq!(cosine_weight(0, 0.0), 0.0);
        assert_eq!(cosine_weight(0, f32::NAN), 0.0);
        assert!((cosine_weight(27, cell_mean_cosine(27)) - 1.0).abs() < 1e-6);
    }

    /// The old projection, for comparison: each cell sampled at its centre, weighted `2π / 64`.
    fn centre_sampled(f: &ProbeFrame, cells: &[[f32; 4]; 64]) -> ShL2Rgb {
        let mut s = ShL2Rgb::ZERO;
        for c in 0..PROBE_CELLS {
            if cell_is_filled(cells[c as usize]) {
                s.add_sample(
                    f.cell_direction(c),
                    cell_radiance(cells[c as usize]),
                    CELL_SOLID_ANGLE,
                );
            }
        }
        s
    }

    /// Bound on the relative irradiance error at the normal for uniform radiance over the
    /// hemisphere. The exact order-2 projection gives exactly π L there (band 2 of a hemisphere
    /// step has no zonal term), and the cell quadrature integrates the zonal terms exactly, so
    /// only f32 rounding remains. Measured: worst 1.8e-7 over the normals of `normals()`, 1.3e-7 of
    /// π L at −n (centre samples: +2.104 % for every normal, −1.02 % at −n).
    const UNIFORM_BOUND: f32 = 1e-5;

    #[test]
    fn uniform_radiance_gives_pi_l_at_the_normal() {
        let l = Vec3::new(0.5, 1.0, 2.0);
        let cells = [make_cell(l, 1.0); 64];
        let mut worst = 0.0f32;
        let mut worst_back = 0.0f32;
        for n in normals() {
            let f = frame(n);
            let projected = project_probe(&f, &cells);
            let expected = l * PI;
            let e = sh(projected).irradiance(f.normal) / expected;
            let before = centre_sampled(&f, &cells).irradiance(f.normal) / expected;
            println!("normal {n}: irradiance / πL: centre samples {before}, integrated {e}");
            assert!((before - 1.0).min_element() > 0.02, "{before}");
            worst = worst.max((e - 1.0).abs().max_element());
            // The ambient term alone: 64 cells × 2π/64 × Y00 × L.
            let c = projected[0];
            assert!((c[0] - 2.0 * PI * 0.282_094_8 * l.x).abs() < 1e-5);
            assert_eq!(c[3], 0.0);
            // The far side gets nothing: irradiance at −n is π L (1/2 − 1/2) = 0 in exact order 2
            // (centre samples left −1.02 % of π L).
            let back = sh(projected).irradiance(-f.normal) / expected;
            worst_back = worst_back.max(back.abs().max_element());
        }
        println!("worst relative error at the normal {worst:e}, at −normal {worst_back:e}");
        assert!(worst < UNIFORM_BOUND, "relative error {worst}");
        assert!(worst_back < UNIFORM_BOUND, "far side {worst_back}");
    }

    #[test]
    fn cell_weights_are_positive_and_cover_the_hemisphere() {
        let mut total = 0.0f64;
        for index in 0..PROBE_CELLS {
            let mut cell = 0.0f32;
            for node in 0..CELL_NODES {
                let (u, w) = cell_node(index, node);
                assert!(w > 0.0, "cell {index} node {node}: {w}");
                assert!(u.cmpgt(Vec2::ZERO).all() && u.cmplt(Vec2::ONE).all(), "{u}");
                cell += w;
                total += w as f64;
            }
            assert!(
                (cell / CELL_SOLID_ANGLE - 1.0).abs() < 1e-6,
                "cell {index}: {cell}"
            );
        }
        let two_pi = 2.0 * std::f64::consts::PI;
        assert!((total / two_pi - 1.0).abs() < 1e-6, "{total}");
        // Every node's direction lies in its own cell, whatever the frame.
        for n in normals() {
            let f = frame(n);
            for index in 0..PROBE_CELLS {
                for node in 0..CELL_NODES {
                    let d = f.direction_in_cell(index, cell_node(index, node).0);
                    assert_eq!(f.direction_cell(d), Some(index), "{n} {index} {node}");
                }
            }
        }
    }

    /// `∫ p` over the unit square of the node table, f64.
    fn node_sum(index: u32, p: impl Fn(f64, f64) -> f64) -> f64 {
        (0..CELL_NODES)
            .map(|node| {
                let (u, w) = cell_node(index, node);
                p(u.x as f64, u.y as f64) * (w / CELL_SOLID_ANGLE) as f64
            })
            .sum()
    }

    #[test]
    fn nodes_integrate_degree_four_exactly_on_either_side_of_the_crease() {
        // Cell 0 (x == y) splits along u.x = u.y, cell 1 along u.x + u.y = 1. A polynomial of
        // degree ≤ 4 on each side, creased along the split, is integrated exactly.
        for a in 0..=4 {
            for b in 0..=4 - a {
                let exact = 1.0 / ((a + 1) * (b + 1)) as f64;
                for index in [0, 1] {
                    let got = node_sum(index, |x, y| x.powi(a) * y.powi(b));
                    assert!((got - exact).abs() < 1e-7, "x^{a} y^{b}: {got}");
                }
            }
        }
        // ∫ |x − y|^k over the square: 2 / ((k + 1)(k + 2)); the same for |x + y − 1|^k.
        for k in 1..=4 {
            let exact = 2.0 / ((k + 1) * (k + 2)) as f64;
            let main = node_sum(0, |x, y| (x - y).abs().powi(k));
            let anti = node_sum(1, |x, y| (x + y - 1.0).abs().powi(k));
            assert!((main - exact).abs() < 1e-7, "|x − y|^{k}: {main}");
            assert!((anti - exact).abs() < 1e-7, "|x + y − 1|^{k}: {anti}");
        }
    }

    fn unit(v: Vec3) -> DVec3 {
        v.as_dvec3().normalize()
    }

    /// Solid angle of the spherical triangle `a, b, c` (Van Oosterom & Strackee 1983).
    fn triangle_solid_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
        let det = a.dot(b.cross(c)).abs();
        2.0 * det.atan2(1.0 + a.dot(b) + b.dot(c) + c.dot(a))
    }

    /// Brute force for cell `index`: its solid angle and `∫ Y_i`. The cell is cut into `n × n`
    /// quads of the map, each weighted by the solid angle of the spherical quadrilateral on its
    /// corners (so it does not rely on the map being equal-area) and sampled at its centre.
    fn brute_force_cell(f: &ProbeFrame, index: u32, n: u32) -> (f64, [f64; 9]) {
        let mut area = 0.0;
        let mut integral = [0.0f64; 9];
        let at = |i: u32, j: u32| {
            unit(f.direction_in_cell(index, Vec2::new(i as f32, j as f32) / n as f32))
        };
        for j in 0..n {
            for i in 0..n {
                let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                let w = triangle_solid_angle(a, b, c) + triangle_solid_angle(a, c, d);
                let centre = Vec2::new(i as f32 + 0.5, j as f32 + 0.5) / n as f32;
                let basis = sh9_basis(f.direction_in_cell(index, centre));
                for k in 0..9 {
                    integral[k] += basis[k] as f64 * w;
                }
                area += w;
            }
        }
        (area, integral)
    }

    /// Bound on `|∫_cell Y_i − brute force|` per cell and coefficient, in units of the cell's
    /// solid angle. Measured worst 7.4e-5 (the 4 cells at the pole) over 3 frames; the brute force
    /// itself (128² quads, midpoints) errs about 5e-6. Centre samples: 8.4e-2.
    const CELL_INTEGRAL_BOUND: f64 = 1e-4;

    #[test]
    fn cell_integrals_match_brute_force() {
        let mut worst = 0.0f64;
        let mut worst_centre = 0.0f64;
        let mut worst_area = 0.0f64;
        let w = CELL_SOLID_ANGLE as f64;
        for n in [Vec3::Z, -Vec3::X, Vec3::new(0.3, -0.5, 0.8)] {
            let f = frame(n);
            for index in 0..PROBE_CELLS {
                let (area, exact) = brute_force_cell(&f, index, 128);
                // Each cell is 2π/64 sr: the weights need no Jacobian.
                worst_area = worst_area.max((area / w - 1.0).abs());
                let got = cell_basis_integrals(&f, index);
                let centre = sh9_basis(f.cell_direction(index));
                for k in 0..9 {
                    worst = worst.max((got[k] as f64 - exact[k]).abs() / w);
                    let c = (centre[k] * CELL_SOLID_ANGLE) as f64;
                    worst_centre = worst_centre.max((c - exact[k]).abs() / w);
                }
            }
        }
        println!(
            "worst |∫Y − brute force| / (2π/64): integrated {worst:e}, centre samples \
             {worst_centre:e}; worst cell solid angle / (2π/64) − 1: {worst_area:e}"
        );
        // Measured 5.8e-6: the brute force's chords along the cell's curved edges.
        assert!(worst_area < 2e-5, "cell solid angles: {worst_area}");
        assert!(worst < CELL_INTEGRAL_BOUND, "{worst}");
        assert!(worst_centre > 0.05, "{worst_centre}");
    }

    /// Brute force of the radiance function the cells stand for (`cells[c]` over cell `c`, 0
    /// below the hemisphere), per cell: `∫_cell Y_i` from `n` equal-solid-angle directions over
    /// the whole sphere (a Fibonacci spiral, which no cell edge lines up with, unlike a z–φ grid),
    /// each binned into its cell with `direction_cell`, so it relies on neither the map's decode
    /// nor its area. f64 sums. A probe's projection is `Σ_c cells[c] × this[c]`.
    fn binned_cell_integrals(f: &ProbeFrame, n: u32) -> [[f64; 9]; 64] {
        let weight = 4.0 * std::f64::consts::PI / n as f64;
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        let mut out = [[0.0; 9]; 64];
        for i in 0..n {
            let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let phi = golden * i as f64;
            let d = DVec3::new(r * phi.cos(), r * phi.sin(), z).as_vec3();
            if let Some(c) = f.direction_cell(d) {
                let basis = sh9_basis(d);
                for k in 0..9 {
                    out[c as usize][k] += basis[k] as f64 * weight;
                }
            }
        }
        out
    }

    /// Bound on `|coefficient − brute force|` for one bright cell of radiance 1 and for a cosine
    /// lobe peaking at 1, in units of a cell's solid angle. Measured worst over 3 frames (32 · 10⁶
    /// directions; the binning adds its own noise, 1.6e-4 with 9 · 10⁶): bright cells 8.5e-5 (the
    /// pole cells, as in `CELL_INTEGRAL_BOUND`), lobe 3.2e-5; centre samples: 8.4e-2 and 2.4e-1.
    const BINNED_BOUND: f64 = 2e-4;

    /// Bound on the relative error of the lobe's irradiance along the normal and the lobe's axis
    /// against the binned brute force. Measured worst 3.1e-6 (centre samples: +2.2 %).
    const LOBE_IRRADIANCE_BOUND: f32 = 2e-5;

    #[test]
    fn bright_cell_and_cosine_lobe_match_binned_brute_force() {
        let w = CELL_SOLID_ANGLE as f64;
        let mut worst_cell = 0.0f64;
        let mut worst_lobe = 0.0f64;
        let mut centre_cell = 0.0f64;
        let mut centre_lobe = 0.0f64;
        let mut lobe_irradiance = 0.0f32;
        let mut centre_irradiance = 0.0f32;
        let colour = Vec3::new(1.0, 0.5, 0.25);
        for n in [Vec3::Z, -Vec3::X, Vec3::new(-1.0, 2.0, -0.1)] {
            let f = frame(n);
            let binned = binned_cell_integrals(&f, 32_000_000);
            let brute_force = |cells: &[[f32; 4]; 64]| {
                let mut e = [DVec3::ZERO; 9];
                for c in 0..64 {
                    if cell_is_filled(cells[c]) {
                        for k in 0..9 {
                            e[k] += cell_radiance(cells[c]).as_dvec3() * binned[c][k];
                        }
                    }
                }
                e
            };
            let compare = |got: ShL2Rgb, exact: &[DVec3; 9]| {
                (0..9)
                    .map(|k| {
                        (got.coefficients[k].as_dvec3() - exact[k])
                            .abs()
                            .max_element()
                    })
                    .fold(0.0, f64::max)
                    / w
            };
            // Every cell alone.
            for bright in 0..PROBE_CELLS {
                let mut cells = [EMPTY; 64];
                cells[bright as usize] = make_cell(colour, 1.0);
                let exact = brute_force(&cells);
                worst_cell = worst_cell.max(compare(sh(project_probe(&f, &cells)), &exact));
                centre_cell = centre_cell.max(compare(centre_sampled(&f, &cells), &exact));
            }
            // A cosine lobe, cos⁴ around a tilted axis, taken at the cell centres.
            let axis = (f.normal + Vec3::new(0.4, -0.3, 0.2)).normalize();
            let mut cells = [EMPTY; 64];
            for c in 0..PROBE_CELLS {
                let cos = f.cell_direction(c).dot(axis).max(0.0);
                cells[c as usize] = make_cell(colour * cos.powi(4), 1.0);
            }
            let exact = brute_force(&cells);
            let got = sh(project_probe(&f, &cells));
            let centre = centre_sampled(&f, &cells);
            worst_lobe = worst_lobe.max(compare(got, &exact));
            centre_lobe = centre_lobe.max(compare(centre, &exact));
            let exact = sh(exact.map(|e| e.as_vec3().extend(0.0).to_array()));
            for d in [f.normal, axis] {
                let e = exact.irradiance(d).x;
                let a = got.irradiance(d).x;
                let c = centre.irradiance(d).x;
                println!("lobe irradiance along {d}: brute force {e}, integrated {a}, centre {c}");
                lobe_irradiance = lobe_irradiance.max((a / e - 1.0).abs());
                centre_irradiance = centre_irradiance.max((c / e - 1.0).abs());
            }
        }
        println!(
            "worst |coefficient − binned brute force| / (2π/64): bright cell {worst_cell:e} \
             (centre samples {centre_cell:e}), lobe {worst_lobe:e} (centre samples \
             {centre_lobe:e}); lobe irradiance {lobe_irradiance:e} (centre samples \
             {centre_irradiance:e})"
        );
        assert!(worst_cell < BINNED_BOUND, "{worst_cell}");
        assert!(worst_lobe < BINNED_BOUND, "{worst_lobe}");
        assert!(lobe_irradiance < LOBE_IRRADIANCE_BOUND, "{lobe_irradiance}");
        assert!(centre_cell > 10.0 * BINNED_BOUND && centre_lobe > 10.0 * BINNED_BOUND);
        assert!(centre_irradiance > 10.0 * LOBE_IRRADIANCE_BOUND);
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
                for node in 0..CELL_NODES {
                    let (u, w) = cell_node(c, node);
                    reference.add_sample(f.direction_in_cell(c, u), r, w);
                }
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

    #[test]
    fn empty_and_nan_cells_give_zeros_in_every_frame() {
        let empty = [
            EMPTY,
            [f32::NAN; 4],
            make_cell(Vec3::ONE, f32::NAN),
            make_cell(Vec3::ONE, -2.0),
        ];
        for n in normals() {
            let f = frame(n);
            for index in 0..PROBE_CELLS {
                for cell in empty {
                    assert_eq!(cell_sh_terms(&f, index, cell), [[0.0; 4]; 9]);
                }
            }
            let mut cells = [EMPTY; 64];
            for c in 0..64 {
                cells[c] = empty[c % 4];
            }
            assert_eq!(project_probe(&f, &cells), [[0.0; 4]; 9]);
            // Fewer than 64 cells: the missing ones count as empty.
            assert_eq!(project_probe(&f, &[]), [[0.0; 4]; 9]);
            let half = project_probe(&f, &[make_cell(Vec3::ONE, 1.0); 32]);
            let mut padded = [EMPTY; 64];
            padded[..32].copy_from_slice(&[make_cell(Vec3::ONE, 1.0); 32]);
            assert_eq!(half, project_probe(&f, &padded));
        }
    }
}
